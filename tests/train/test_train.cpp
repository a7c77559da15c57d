// Tests of the offline trainer: Lasso optimality, the trace-ratio solvers, planted-metric
// recovery, pair generation and the eq. 36-37 precision.
#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "train/linalg.hpp"
#include "train/sparse_coding.hpp"
#include "train/trace_ratio.hpp"

using namespace kata::train;

namespace {

Eigen::MatrixXd random_matrix(int rows, int cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> nd;
  Eigen::MatrixXd m(rows, cols);
  for (int c = 0; c < cols; ++c)
    for (int r = 0; r < rows; ++r) m(r, c) = nd(rng);
  return m;
}

// Unit-length columns, like normalised poses.
Eigen::MatrixXd unit_columns(Eigen::MatrixXd m) {
  for (int c = 0; c < m.cols(); ++c) m.col(c).normalize();
  return m;
}

// An independent Lasso solver: proximal gradient (ISTA) with a fixed step, run long.
Eigen::VectorXd ista(const Eigen::MatrixXd& g, const Eigen::VectorXd& b, double gamma, int exclude, int iters) {
  const int n = static_cast<int>(g.rows());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(g, Eigen::EigenvaluesOnly);
  const double step = 1.0 / (2.0 * es.eigenvalues().maxCoeff());
  Eigen::VectorXd a = Eigen::VectorXd::Zero(n);
  for (int it = 0; it < iters; ++it) {
    Eigen::VectorXd v = a - step * 2.0 * (g * a - b);
    for (int j = 0; j < n; ++j) {
      const double t = step * gamma;
      a[j] = v[j] > t ? v[j] - t : (v[j] < -t ? v[j] + t : 0.0);
    }
    if (exclude >= 0) a[exclude] = 0.0;
  }
  return a;
}

double objective_dense(const Eigen::MatrixXd& g, const Eigen::VectorXd& b, double yy, double gamma,
                       const Eigen::VectorXd& a) {
  return yy - 2.0 * a.dot(b) + a.dot(g * a) + gamma * a.lpNorm<1>();
}

Eigen::MatrixXd random_orthonormal(int d, int r, std::mt19937& rng) {
  std::normal_distribution<double> nd;
  Eigen::MatrixXd m(d, r);
  for (int c = 0; c < r; ++c)
    for (int k = 0; k < d; ++k) m(k, c) = nd(rng);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(m);
  return qr.householderQ() * Eigen::MatrixXd::Identity(d, r);
}

}  // namespace

TEST(SparseCoding, RandomProblemsSatisfyKktAndZeroDiagonal) {
  for (unsigned seed : {1u, 2u, 3u}) {
    // Positive, correlated data (like min/max-normalised features), d < N so the Lasso is needed.
    Eigen::MatrixXd x = unit_columns(random_matrix(30, 80, seed).array().abs().matrix() +
                                     Eigen::MatrixXd::Constant(30, 80, 0.3));
    const Eigen::MatrixXd g = x.transpose() * x;
    LassoOptions opt;
    opt.gamma = 0.02;
    SparseCodingStats st;
    const CsrMatrix a = sparse_code(g, opt, &st);
    ASSERT_EQ(a.rows, 80);
    EXPECT_LE(st.max_kkt, 1e-6);
    for (int i = 0; i < a.rows; ++i) {
      std::vector<int> idx(a.col.begin() + a.row_ptr[i], a.col.begin() + a.row_ptr[i + 1]);
      std::vector<double> val(a.val.begin() + a.row_ptr[i], a.val.begin() + a.row_ptr[i + 1]);
      for (int j : idx) EXPECT_NE(j, i) << "a_ii must be 0";
      LassoProblem p{&g, g.col(i).data(), g(i, i), i};
      // Independent check of the optimality conditions.
      EXPECT_LE(lasso_kkt_violation(p, opt.gamma, idx, val), 1e-6) << "problem " << i;
      // Independent duality gap from X itself (a certificate of optimality): theta = s (y - X a)
      // with s making theta dual-feasible, D = |y|^2 - |y - theta|^2, gap = P - D >= 0.
      Eigen::VectorXd av = Eigen::VectorXd::Zero(80);
      for (size_t k = 0; k < idx.size(); ++k) av[idx[k]] = val[k];
      const Eigen::VectorXd y = x.col(i);
      const Eigen::VectorXd res = y - x * av;
      Eigen::VectorXd corr = x.transpose() * res;
      corr[i] = 0.0;
      const double s = std::min(1.0, opt.gamma / (2.0 * corr.cwiseAbs().maxCoeff()));
      const double primal = res.squaredNorm() + opt.gamma * av.lpNorm<1>();
      const double dual = y.squaredNorm() - (y - s * res).squaredNorm();
      EXPECT_LE(primal - dual, 1e-9) << "problem " << i;
      EXPECT_NEAR(lasso_objective(p, opt.gamma, idx, val), primal, 1e-12);
      // And no worse than a slow, independent solver (ISTA) run long.
      if (i < 3) {
        const Eigen::VectorXd ref = ista(g, g.col(i), opt.gamma, i, 5000);
        EXPECT_LE(primal, objective_dense(g, g.col(i), g(i, i), opt.gamma, ref) + 1e-12) << "problem " << i;
      }
    }
    EXPECT_GT(st.mean_support, 0.0);
  }
}

TEST(SparseCoding, KktCheckerRejectsAWrongSolution) {
  Eigen::MatrixXd x = unit_columns(random_matrix(10, 20, 7));
  const Eigen::MatrixXd g = x.transpose() * x;
  LassoProblem p{&g, g.col(0).data(), g(0, 0), 0};
  LassoOptions opt;
  opt.gamma = 0.05;
  LassoWorkspace ws;
  LassoSolution s = solve_lasso(p, opt, ws);
  EXPECT_LE(s.kkt, 1e-6);
  EXPECT_LE(s.gap, 1e-8);
  ASSERT_FALSE(s.value.empty());
  std::vector<double> v = s.value;
  v[0] *= 1.01;
  EXPECT_GT(lasso_kkt_violation(p, opt.gamma, s.index, v), 1e-6);
  // a_00 != 0 is refused.
  std::vector<int> idx = s.index;
  idx.push_back(0);
  v = s.value;
  v.push_back(1e-3);
  EXPECT_GT(lasso_kkt_violation(p, opt.gamma, idx, v), 1.0);
}

TEST(SparseCoding, NearDuplicateColumns) {
  // Highly correlated columns (neighbouring frames of a 120 fps clip) are the hard case for
  // coordinate descent; the Newton polish on the support must still reach the KKT tolerance.
  Eigen::MatrixXd base = random_matrix(40, 20, 11).array().abs().matrix();
  Eigen::MatrixXd x(40, 200);
  std::mt19937 rng(5);
  std::normal_distribution<double> nd(0.0, 0.01);
  for (int c = 0; c < 200; ++c) {
    const double t = (c % 10) / 10.0;
    x.col(c) = (1 - t) * base.col(c / 10) + t * base.col((c / 10 + 1) % 20);
    for (int r = 0; r < 40; ++r) x(r, c) += nd(rng);
  }
  x = unit_columns(x);
  const Eigen::MatrixXd g = x.transpose() * x;
  LassoOptions opt;
  opt.gamma = 0.01;
  SparseCodingStats st;
  const CsrMatrix a = sparse_code(g, opt, &st);
  EXPECT_LE(st.max_kkt, 1e-6);
  for (int i = 0; i < a.rows; ++i)
    for (int64_t k = a.row_ptr[i]; k < a.row_ptr[i + 1]; ++k) EXPECT_NE(a.col[k], i);
}

TEST(TraceRatio, NewtonAndBisectionAgree) {
  for (unsigned seed : {1u, 2u}) {
    const int d = 40, r = 6;
    Eigen::MatrixXd ma = random_matrix(d, 60, seed);
    Eigen::MatrixXd mb = random_matrix(d, 80, seed + 100);
    const Eigen::MatrixXd a = ma * ma.transpose();
    const Eigen::MatrixXd b = mb * mb.transpose() + 0.1 * Eigen::MatrixXd::Identity(d, d);
    const TraceRatioResult n = trace_ratio_newton(a, b, r);
    const TraceRatioResult bi = trace_ratio_bisection(a, b, r, 1e-12);
    EXPECT_NEAR(n.eta, bi.eta, 1e-8 * n.eta);
    // f(eta*) = 0 relative to the scale of the terms.
    const double scale = (n.w.transpose() * a * n.w).trace();
    EXPECT_LE(std::abs(n.f_at_eta), 1e-9 * scale);
    EXPECT_LE(std::abs(bi.f_at_eta), 1e-9 * scale);
    // W^T W = I.
    EXPECT_LE((n.w.transpose() * n.w - Eigen::MatrixXd::Identity(r, r)).norm(), 1e-10);
    EXPECT_LE((bi.w.transpose() * bi.w - Eigen::MatrixXd::Identity(r, r)).norm(), 1e-10);
    // Bounds of eq. 29-30, computed here independently.
    const TraceRatioBounds bounds = trace_ratio_bounds(a, b, r);
    EXPECT_NEAR(bounds.lower, a.trace() / b.trace(), 1e-12 * bounds.lower);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ea(a), eb(b);
    const double upper = ea.eigenvalues().tail(r).sum() / eb.eigenvalues().head(r).sum();
    EXPECT_NEAR(bounds.upper, upper, 1e-10 * upper);
    EXPECT_GE(n.eta, bounds.lower);
    EXPECT_LE(n.eta, bounds.upper);
    // The value achieved by each W is eta*.
    EXPECT_NEAR(trace_ratio_value(a, b, n.w), n.eta, 1e-10 * n.eta);
    EXPECT_NEAR(trace_ratio_value(a, b, bi.w), n.eta, 1e-8 * n.eta);
    EXPECT_LT(n.iterations, 30);
  }
}

TEST(TraceRatio, BeatsRandomOrthonormalW) {
  const int d = 8, r = 3;
  Eigen::MatrixXd ma = random_matrix(d, 10, 21), mb = random_matrix(d, 12, 22);
  const Eigen::MatrixXd a = ma * ma.transpose();
  const Eigen::MatrixXd b = mb * mb.transpose() + 0.05 * Eigen::MatrixXd::Identity(d, d);
  const TraceRatioResult n = trace_ratio_newton(a, b, r);
  std::mt19937 rng(3);
  double best = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const Eigen::MatrixXd w = random_orthonormal(d, r, rng);
    const double v = trace_ratio_value(a, b, w);
    best = std::max(best, v);
    EXPECT_LE(v, n.eta * (1 + 1e-12));
  }
  EXPECT_GT(best, n.bounds.lower);  // the random search is not degenerate
}

TEST(Linalg, ThreadedProductsMatchEigen) {
  const Eigen::MatrixXd x = random_matrix(37, 101, 9);
  EXPECT_LE((gram_matrix(x, 2) - x.transpose() * x).norm(), 1e-10);
  EXPECT_LE((gram_matrix(x, 3) - x.transpose() * x).norm(), 1e-10);
  EXPECT_LE((outer_product(x, 2) - x * x.transpose()).norm(), 1e-10);
}

TEST(Linalg, PartialEigenMatchesFullSolver) {
  for (int n : {65, 150}) {
    Eigen::MatrixXd r = random_matrix(n, n / 2, static_cast<unsigned>(n));
    Eigen::MatrixXd m = r * r.transpose() - 0.3 * Eigen::MatrixXd::Identity(n, n);
    // A repeated eigenvalue (a cluster) on top.
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> full(m);
    const int k = 10;
    Eigen::MatrixXd v;
    const Eigen::VectorXd vals = top_eigen(m, k, &v);
    for (int j = 0; j < k; ++j) EXPECT_NEAR(vals[j], full.eigenvalues()[n - 1 - j], 1e-9 * full.eigenvalues().cwiseAbs().maxCoeff());
    EXPECT_LE((v.transpose() * v - Eigen::MatrixXd::Identity(k, k)).norm(), 1e-10);
    EXPECT_LE((m * v - v * vals.asDiagonal()).norm(), 1e-8 * full.eigenvalues().cwiseAbs().maxCoeff());
    const Eigen::VectorXd low = bottom_eigen(m, 3, nullptr);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(low[j], full.eigenvalues()[j], 1e-9 * full.eigenvalues().cwiseAbs().maxCoeff());
  }
  // Exactly repeated top eigenvalues: the subspace must still be an invariant one.
  const int n = 100;
  Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(random_matrix(n, n, 77)).householderQ();
  Eigen::VectorXd ev = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);
  ev.tail(4).setConstant(2.0);
  const Eigen::MatrixXd m = q * ev.asDiagonal() * q.transpose();
  Eigen::MatrixXd v;
  const Eigen::VectorXd vals = top_eigen(m, 6, &v);
  EXPECT_NEAR(vals[0], 2.0, 1e-10);
  EXPECT_NEAR(vals[3], 2.0, 1e-10);
  EXPECT_LE((v.transpose() * v - Eigen::MatrixXd::Identity(6, 6)).norm(), 1e-10);
  EXPECT_LE((m * v - v * vals.asDiagonal()).norm(), 1e-8);
}
