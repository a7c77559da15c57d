#include "train/evaluate.hpp"

#include <Eigen/Cholesky>

#include "common/error.hpp"
#include "gpd/gpd.hpp"

namespace kata::train {

const std::vector<double>& wjcd_weights() {
  // Hip Chest Neck Head LShoulder LElbow LHand RShoulder RElbow RHand LHip LKnee LFoot RHip RKnee RFoot
  static const std::vector<double> w = {1, 1, 0, 0, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1, 1, 0};
  return w;
}

double jcd(const float* a, const float* b, bool weighted, double lambda) {
  const auto& w = wjcd_weights();
  double pos = 0.0, vel = 0.0;
  // Hip: (0, hip height, 0) and its vertical velocity.
  const double wh = weighted ? w[0] : 1.0;
  const double dh = static_cast<double>(a[45]) - b[45];
  const double dvh = static_cast<double>(a[gpd::kOffsetJk + 90]) - b[gpd::kOffsetJk + 90];
  pos += wh * dh * dh;
  vel += wh * dvh * dvh;
  for (int j = 1; j < 16; ++j) {
    const double wj = weighted ? w[static_cast<size_t>(j)] : 1.0;
    if (wj == 0.0) continue;
    for (int c = 0; c < 3; ++c) {
      const double dp = static_cast<double>(a[3 * (j - 1) + c]) - b[3 * (j - 1) + c];
      const double dv = static_cast<double>(a[gpd::kOffsetJk + 6 * (j - 1) + c]) - b[gpd::kOffsetJk + 6 * (j - 1) + c];
      pos += wj * dp * dp;
      vel += wj * dv * dv;
    }
  }
  return pos + lambda * vel;
}

double jcd_local(const float* a, const float* b) {
  double sum = 0.0;
  for (int j = 0; j < 15; ++j)
    for (int c = 0; c < 3; ++c) {
      const double dp = static_cast<double>(a[3 * j + c]) - b[3 * j + c];
      const double dv = static_cast<double>(a[gpd::kOffsetJk + 6 * j + c]) - b[gpd::kOffsetJk + 6 * j + c];
      sum += dp * dp + dv * dv;
    }
  return sum;
}

Eigen::VectorXd lms_weights(const Eigen::MatrixXd& da, const Eigen::MatrixXd& db, const std::vector<int>& label,
                            double ridge) {
  const Eigen::Index p = da.cols();
  if (db.cols() != p || static_cast<Eigen::Index>(label.size()) != p || p == 0)
    throw Error(ErrorKind::kInvalidArgument, "lms: inconsistent pairs");
  const Eigen::MatrixXd e = (da - db).array().square().matrix().transpose();  // P x d
  Eigen::VectorXd t(p);
  for (Eigen::Index i = 0; i < p; ++i) t[i] = label[static_cast<size_t>(i)] == 1 ? 0.0 : 1.0;
  // lambda relative to the mean squared row norm of E; the smaller of the primal and dual forms.
  const double lambda = ridge * e.squaredNorm() / static_cast<double>(p);
  if (p <= e.cols()) {
    Eigen::MatrixXd k = e * e.transpose();  // dual: w = E^T (E E^T + lambda I)^-1 t
    k.diagonal().array() += lambda;
    return e.transpose() * k.ldlt().solve(t);
  }
  Eigen::MatrixXd k = e.transpose() * e;  // primal: w = (E^T E + lambda I)^-1 E^T t
  k.diagonal().array() += lambda;
  return k.ldlt().solve(e.transpose() * t);
}

}  // namespace kata::train
