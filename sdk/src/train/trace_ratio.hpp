// The trace-ratio problem of the paper (eq. 27-33):
//   eta* = max_{W^T W = I, W d x r} Tr(W^T A W) / Tr(W^T B W),  A, B symmetric, B positive definite,
// solved to its global optimum through f(eta) = max_{W^T W = I} Tr(W^T (A - eta B) W) = the sum
// of the r largest eigenvalues of A - eta B, which is decreasing and zero exactly at eta*.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace kata::train {

struct TraceRatioBounds {
  double lower = 0.0;  // eq. 29: Tr(A) / Tr(B)
  double upper = 0.0;  // eq. 30: (sum of the r largest eigenvalues of A) / (sum of the r smallest of B)
};
TraceRatioBounds trace_ratio_bounds(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r);

// f(eta) of eq. 31; when `w` is not null, the maximiser (top-r eigenvectors of A - eta B).
double trace_ratio_f(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double eta, int r, Eigen::MatrixXd* w);

// Tr(W^T A W) / Tr(W^T B W).
double trace_ratio_value(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::MatrixXd& w);

struct TraceRatioResult {
  Eigen::MatrixXd w;          // d x r, W^T W = I
  double eta = 0.0;           // eta*
  double f_at_eta = 0.0;      // f(eta*) (0 at the optimum)
  int iterations = 0;         // eigen-decompositions
  TraceRatioBounds bounds;
  std::vector<double> history;  // eta per iteration
};

using TraceRatioProgress = std::function<void(int iteration, double eta)>;

// The iterative (Newton-type) update: eta <- Tr(W^T A W) / Tr(W^T B W), W = top-r eigenvectors of
// A - eta B, until the relative change is below `tol`; started from the larger of eq. 29's bound
// and the ratio of the ratio-trace solution (both are lower bounds). f_at_eta is f at the eta of
// the last decomposition. The upper bound of eq. 30 costs two more decompositions.
TraceRatioResult trace_ratio_newton(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r,
                                    double tol = 1e-12, int max_iter = 100, const TraceRatioProgress& progress = {},
                                    bool compute_upper_bound = true);
// The paper's bisection on eta between the bounds of eq. 29-30 using the sign of f (eq. 33),
// until (hi - lo) <= rel_tol * hi; W from the final eta.
TraceRatioResult trace_ratio_bisection(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r,
                                       double rel_tol = 1e-10, int max_iter = 200,
                                       const TraceRatioProgress& progress = {});

}  // namespace kata::train
