// y (cols) = W^T x for a column-major W (rows x cols) and x (rows): Eigen, -march=native.
#pragma once

namespace kata_bench {

__attribute__((visibility("default"))) void eigen_native_wtx(const float* w, int rows, int cols, const float* x,
                                                             float* y);

}  // namespace kata_bench
