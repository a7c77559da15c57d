// y (cols) = W^T x for a column-major W (rows x cols) and x (rows): Eigen, -march=native.
#pragma once

namespace kata_bench {

__attribute__((visibility("default"))) void eigen_native_wtx(const float* w, int rows, int cols, const float* x,
                                                             float* y);

}  // namespace kata_bench

#include <cstdint>

namespace kata_bench {

// y (cols <= 64) = W^T x for a row-major W (rows x cols) of IEEE half floats, fp32 accumulation
// (-march=native): the cost of a half-precision W, measured before it is built.
__attribute__((visibility("default"))) void fp16_wtx(const uint16_t* w, int rows, int cols, const float* x, float* y);
// The same loop over an fp32 row-major W, its anchor.
__attribute__((visibility("default"))) void fp32_wtx_rowmajor(const float* w, int rows, int cols, const float* x,
                                                              float* y);

}  // namespace kata_bench
