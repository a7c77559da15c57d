// The anchor for scoring: a plain Eigen W^T x built for this machine's best instruction
// set (-march=native), in its own shared library so that none of its Eigen instantiations can be
// merged with the baseline-ISA ones of kata_bench (inline symbols stay hidden in the .so).
#include "eigen_native.hpp"

#include <Eigen/Core>

namespace kata_bench {

void eigen_native_wtx(const float* w, int rows, int cols, const float* x, float* y) {
  const Eigen::Map<const Eigen::MatrixXf> wm(w, rows, cols);
  const Eigen::Map<const Eigen::VectorXf> xv(x, rows);
  Eigen::Map<Eigen::VectorXf> yv(y, cols);
  yv.noalias() = wm.transpose() * xv;
}

}  // namespace kata_bench
