#include "train/trace_ratio.hpp"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "common/error.hpp"
#include "train/linalg.hpp"

namespace kata::train {
namespace {

void check(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r) {
  if (a.rows() != a.cols() || b.rows() != b.cols() || a.rows() != b.rows())
    throw Error(ErrorKind::kInvalidArgument, "trace ratio: A and B must be square and of the same size");
  if (r < 1 || r > a.rows()) throw Error(ErrorKind::kInvalidArgument, "trace ratio: rank out of range");
}

}  // namespace

TraceRatioBounds trace_ratio_bounds(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r) {
  check(a, b, r);
  TraceRatioBounds out;
  out.lower = a.trace() / b.trace();
  const double top_a = top_eigen(a, r, nullptr).sum();
  const double low_b = bottom_eigen(b, r, nullptr).sum();
  if (!(low_b > 0)) throw Error(ErrorKind::kInvalidArgument, "trace ratio: B is not positive definite on r dimensions");
  out.upper = top_a / low_b;
  return out;
}

double trace_ratio_f(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double eta, int r, Eigen::MatrixXd* w) {
  const Eigen::MatrixXd m = a - eta * b;
  return top_eigen(m, r, w).sum();
}

double trace_ratio_value(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::MatrixXd& w) {
  return (w.transpose() * a * w).trace() / (w.transpose() * b * w).trace();
}

TraceRatioResult trace_ratio_newton(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r, double tol,
                                    int max_iter, const TraceRatioProgress& progress, bool compute_upper_bound) {
  check(a, b, r);
  TraceRatioResult res;
  res.bounds.lower = a.trace() / b.trace();
  double eta = res.bounds.lower;
  // Start from the ratio-trace solution (top-r generalised eigenvectors of (A, B), orthonormalised):
  // any orthonormal W gives a valid lower bound on eta*, and this one is usually close to it,
  // which saves most of the iterations a start at eq. 29's bound needs.
  Eigen::LLT<Eigen::MatrixXd> llt(b);
  if (llt.info() == Eigen::Success) {
    const Eigen::MatrixXd li_a = llt.matrixL().solve(a);                        // L^-1 A
    const Eigen::MatrixXd c = llt.matrixL().solve(li_a.transpose());            // L^-1 A L^-T
    Eigen::MatrixXd v;
    top_eigen(0.5 * (c + c.transpose()), r, &v);
    const Eigen::MatrixXd w0 = llt.matrixU().solve(v);                           // L^-T V
    const Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(w0).householderQ() *
                              Eigen::MatrixXd::Identity(a.rows(), r);
    const double eta0 = trace_ratio_value(a, b, q);
    ++res.iterations;
    if (std::isfinite(eta0) && eta0 > eta) eta = eta0;
  }
  Eigen::MatrixXd w;
  for (int it = 0; it < max_iter; ++it) {
    // f(eta) at the eta of this decomposition: at the last step it certifies eta* (f = 0).
    res.f_at_eta = trace_ratio_f(a, b, eta, r, &w);
    ++res.iterations;
    const double next = trace_ratio_value(a, b, w);
    res.history.push_back(next);
    if (progress) progress(it + 1, next);
    if (it > 0 && next < eta) break;  // keep the previous (better) W
    // In exact arithmetic eta increases monotonically; a step that does not increase it is at the
    // round-off floor of the eigen-decomposition.
    const bool done = std::abs(next - eta) <= tol * std::abs(next) || (it > 0 && next <= eta);
    eta = next;
    res.w = w;
    if (done) break;
  }
  res.eta = eta;
  if (compute_upper_bound) {
    res.bounds.upper = top_eigen(a, r, nullptr).sum() / bottom_eigen(b, r, nullptr).sum();
    res.iterations += 2;
  }
  return res;
}

TraceRatioResult trace_ratio_bisection(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, int r, double rel_tol,
                                       int max_iter, const TraceRatioProgress& progress) {
  TraceRatioResult res;
  res.bounds = trace_ratio_bounds(a, b, r);
  double lo = res.bounds.lower, hi = res.bounds.upper;
  for (int it = 0; it < max_iter && hi - lo > rel_tol * std::abs(hi); ++it) {
    const double mid = 0.5 * (lo + hi);
    const double f = trace_ratio_f(a, b, mid, r, nullptr);
    ++res.iterations;
    if (f > 0) lo = mid;
    else hi = mid;
    res.history.push_back(0.5 * (lo + hi));
    if (progress) progress(it + 1, 0.5 * (lo + hi));
  }
  res.eta = 0.5 * (lo + hi);
  res.f_at_eta = trace_ratio_f(a, b, res.eta, r, &res.w);
  ++res.iterations;
  return res;
}

}  // namespace kata::train
