// Tests of the offline trainer: Lasso optimality, the trace-ratio solvers, planted-metric
// recovery, pair generation and the eq. 36-37 precision.
#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "gpd/gpd.hpp"
#include "support/temp_paths.hpp"

#include "common/error.hpp"
#include "metric/metric.hpp"
#include "metric/model.hpp"
#include "train/joint_form.hpp"
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

// ---------------------------------------------------------------------------------------------
// Pipeline pieces on synthetic and real data.

#include <cstdio>
#include <fstream>
#include <set>

#include "common/error.hpp"
#include "train/clips.hpp"
#include "train/evaluate.hpp"
#include "train/pairs.hpp"
#include "train/pipeline.hpp"
#include "train/rdsr.hpp"

namespace {

const std::string kData = std::string(KATA_DATA_DIR) + "/cmu";
const std::vector<std::string> kClips = {"02_01.bvh", "02_02.bvh", "05_02.bvh", "05_03.bvh", "07_01.bvh", "09_01.bvh"};

}  // namespace

TEST(Rdsr, RecoversAPlantedMetric) {
  // Positive pairs differ only along a known k-dimensional subspace U (x_l = x_k + U z, z large):
  // a metric that calls them similar must ignore U, so span(W) should be U's complement.
  // Measure: |U^T W|_F^2 / k, the mean squared cosine of the principal angles between span(U)
  // and span(W): 0 when W is orthogonal to U, r/d = 0.75 on average for a random W.
  const int d = 16, k = 4, r = d - k, n = 300, p = 80;
  std::mt19937 rng(42);
  Eigen::MatrixXd u = random_orthonormal(d, k, rng);
  Eigen::MatrixXd x = random_matrix(d, n, 1);
  Eigen::MatrixXd pa = random_matrix(d, p, 2);
  Eigen::MatrixXd pb = pa + u * (3.0 * random_matrix(k, p, 3));
  RdsrOptions opt;
  opt.rank = r;
  opt.alpha = 10.0;  // relative to Tr(X S_L X^T) / Tr(S_W)
  opt.lasso.gamma = 0.5;
  const RdsrResult res = train_rdsr(x, pa, pb, opt);
  EXPECT_LE((res.w.transpose() * res.w - Eigen::MatrixXd::Identity(r, r)).norm(), 1e-10);
  const double overlap = (u.transpose() * res.w).squaredNorm() / k;
  EXPECT_LT(overlap, 0.01) << "mean squared cosine between span(U) and span(W)";
  EXPECT_LE(res.coding.max_kkt, 1e-6);
  // Supervised only (eq. 46) recovers it too; with alpha tiny (labels ignored) it does not.
  const RdsrResult sup = train_rdsr(Eigen::MatrixXd(d, 0), pa, pb, opt);
  EXPECT_LT((u.transpose() * sup.w).squaredNorm() / k, 0.01);
  opt.alpha = 1e-6;
  const RdsrResult unsup = train_rdsr(x, pa, pb, opt);
  EXPECT_GT((u.transpose() * unsup.w).squaredNorm() / k, 0.3);
}

TEST(Precision, HandComputedThresholds) {
  // d < delta => predicted similar. Best delta between 0.2 and 0.3 (or 0.4 and 0.5): 5 of 6.
  Precision p = best_threshold({0.1, 0.2, 0.3, 0.4, 0.5, 0.6}, {1, 1, 0, 1, 0, 0});
  EXPECT_EQ(p.correct, 5);
  EXPECT_NEAR(p.precision, 5.0 / 6.0, 1e-15);
  // Ties move together: a tied positive/negative pair cannot be split.
  p = best_threshold({0.5, 0.5, 0.1, 0.9}, {1, 0, 1, 0});
  EXPECT_EQ(p.correct, 3);
  // All negatives closer than all positives: predicting everything dissimilar is best (3 of 5).
  p = best_threshold({0.1, 0.2, 0.3, 0.8, 0.9}, {0, 0, 0, 1, 1});
  EXPECT_EQ(p.correct, 3);
}

TEST(SparseCoding, RealPosesSatisfyKkt) {
  ClipStore store(kData);
  store.load({"02_01.bvh", "05_02.bvh"}, 2);
  std::vector<const float*> rows;
  for (const char* c : {"02_01.bvh", "05_02.bvh"}) {
    const ClipData& d = store.get(c);
    for (int f = 1; f < d.frames; f += 5) rows.push_back(d.row(f));
  }
  const Normaliser n = fit_normaliser(rows, kata::metric::Normalisation::kMinMaxUnit);
  const Eigen::MatrixXd x = normalised_columns(n, rows);
  for (Eigen::Index c = 0; c < x.cols(); ++c) EXPECT_NEAR(x.col(c).norm(), 1.0, 1e-12);
  const Eigen::MatrixXd g = x.transpose() * x;
  LassoOptions opt;
  opt.gamma = 0.05;
  SparseCodingStats st;
  const CsrMatrix a = sparse_code(g, opt, &st);
  EXPECT_LE(st.max_kkt, 1e-6);
  for (int i = 0; i < a.rows; i += 7) {
    std::vector<int> idx(a.col.begin() + a.row_ptr[i], a.col.begin() + a.row_ptr[i + 1]);
    std::vector<double> val(a.val.begin() + a.row_ptr[i], a.val.begin() + a.row_ptr[i + 1]);
    for (int j : idx) EXPECT_NE(j, i);
    LassoProblem p{&g, g.col(i).data(), g(i, i), i};
    EXPECT_LE(lasso_kkt_violation(p, opt.gamma, idx, val), 1e-6);
  }
}

TEST(Pairs, CrossBodyIsReproducibleBalancedAndValid) {
  ClipStore store(kData);
  CrossBodyOptions o;
  o.per_class = 25;
  o.seed = 7;
  const auto p1 = cross_body_pairs(store, kClips, o, 2);
  const auto p2 = cross_body_pairs(store, kClips, o, 2);
  ASSERT_EQ(p1.size(), 50u);
  ASSERT_EQ(p2.size(), p1.size());
  int pos = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    EXPECT_EQ(p1[i].clip_a, p2[i].clip_a);
    EXPECT_EQ(p1[i].frame_a, p2[i].frame_a);
    EXPECT_EQ(p1[i].clip_b, p2[i].clip_b);
    EXPECT_EQ(p1[i].frame_b, p2[i].frame_b);
    EXPECT_EQ(p1[i].label, p2[i].label);
    pos += p1[i].label;
    const ClipSpec a = parse_clip_spec(p1[i].clip_a), b = parse_clip_spec(p1[i].clip_b);
    EXPECT_EQ(a.file, b.file);              // the same capture ...
    EXPECT_NE(p1[i].clip_a, p1[i].clip_b);  // ... on two bodies
    const ClipData& da = store.get(p1[i].clip_a);
    const ClipData& db = store.get(p1[i].clip_b);
    if (p1[i].label == 1) {
      EXPECT_EQ(p1[i].frame_a, p1[i].frame_b);
    } else {
      EXPECT_GE(std::abs(p1[i].frame_a - p1[i].frame_b), 30);  // 0.25 s at 120 fps
      EXPECT_LT(ClipData::joint_distance(da.row(p1[i].frame_a), db.row(p1[i].frame_b)), o.tau);
    }
  }
  EXPECT_EQ(pos, 25);
  o.seed = 8;
  const auto p3 = cross_body_pairs(store, kClips, o, 2);
  bool differs = false;
  for (size_t i = 0; i < p3.size(); ++i) differs |= p3[i].frame_a != p1[i].frame_a;
  EXPECT_TRUE(differs);
}

TEST(Pairs, TransitionIsReproducibleBalancedAndFileRoundTrips) {
  ClipStore store(kData);
  TransitionOptions o;
  o.per_class = 10;
  o.seed = 3;
  const auto p1 = transition_pairs(store, kClips, o, 2);
  const auto p2 = transition_pairs(store, kClips, o, 2);
  ASSERT_EQ(p1.size(), 20u);
  int pos = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    EXPECT_EQ(p1[i].frame_a, p2[i].frame_a);
    EXPECT_EQ(p1[i].clip_b, p2[i].clip_b);
    EXPECT_NE(p1[i].clip_a, p1[i].clip_b);
    pos += p1[i].label;
    const ClipData& da = store.get(p1[i].clip_a);
    const ClipData& db = store.get(p1[i].clip_b);
    EXPECT_LT(ClipData::joint_distance(da.row(p1[i].frame_a), db.row(p1[i].frame_b)), o.tau);
  }
  EXPECT_EQ(pos, 10);
  const std::string path = kata::test::temp_path("kata_pairs_roundtrip.csv");
  PairFile f;
  f.comments = {"kata pairs test"};
  f.pairs = p1;
  write_pairs(path, f);
  const PairFile back = read_pairs(path);
  ASSERT_EQ(back.pairs.size(), p1.size());
  EXPECT_EQ(back.comments[0], "kata pairs test");
  for (size_t i = 0; i < p1.size(); ++i) {
    EXPECT_EQ(back.pairs[i].clip_a, p1[i].clip_a);
    EXPECT_EQ(back.pairs[i].frame_b, p1[i].frame_b);
    EXPECT_EQ(back.pairs[i].label, p1[i].label);
  }
}

// The independent protocol, checked against its own definition computed here from the
// block-1 joint coordinates (hip at the origin, so MJD is the mean over 16 joints of which the
// hip adds 0).
TEST(Pairs, UniformTransitionFollowsTheIndependentProtocol) {
  ClipStore store(kData);
  const std::vector<std::string> clips = {"02_01.bvh", "02_02.bvh", "07_01.bvh", "05_02.bvh"};
  UniformTransitionOptions o;
  o.per_class = 12;
  o.seed = 5;
  o.max_attempts = 5000000;
  const auto p1 = uniform_transition_pairs(store, clips, o, 2);
  const auto p2 = uniform_transition_pairs(store, clips, o, 2);
  ASSERT_EQ(p1.size(), 24u);
  auto mjd = [](const float* a, const float* b) {
    double s = 0.0;
    for (int j = 0; j < 15; ++j)
      s += std::hypot(static_cast<double>(a[3 * j]) - b[3 * j], static_cast<double>(a[3 * j + 1]) - b[3 * j + 1],
                      static_cast<double>(a[3 * j + 2]) - b[3 * j + 2]);
    return s / 16.0;
  };
  int pos = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    const PairRecord& r = p1[i];
    EXPECT_EQ(r.frame_a, p2[i].frame_a);
    EXPECT_EQ(r.clip_b, p2[i].clip_b);
    EXPECT_NE(r.clip_a, r.clip_b);
    const ClipData& a = store.get(r.clip_a);
    const ClipData& b = store.get(r.clip_b);
    // Frame 0 dropped: index 2 of the rest is BVH frame 3; i < (F - 1) - 120.
    EXPECT_GE(r.frame_a, 3);
    EXPECT_GE(r.frame_b, 3);
    EXPECT_LT(r.frame_a - 1, a.frames - 1 - 120);
    EXPECT_LT(r.frame_b - 1, b.frames - 1 - 120);
    EXPECT_LT(mjd(a.row(r.frame_a), b.row(r.frame_b)), 0.06);
    double f = 0.0;
    for (int k = 1; k <= 120; ++k) f += mjd(a.row(r.frame_a + k), b.row(r.frame_b + k));
    f /= 120.0;
    if (r.label == 1) {
      EXPECT_LT(f, 0.06);
      ++pos;
    } else {
      EXPECT_GT(f, 0.12);
    }
  }
  EXPECT_EQ(pos, 12);
}

TEST(Eval, IssueJcdHasNoHipTerms) {
  ClipStore store(kData);
  const ClipData& a = store.get("02_01.bvh");
  const ClipData& b = store.get("07_01.bvh");
  const float* x = a.row(100);
  const float* y = b.row(80);
  double hand = 0.0;
  for (int j = 0; j < 15; ++j)
    for (int c = 0; c < 3; ++c) {
      const double dp = static_cast<double>(x[3 * j + c]) - y[3 * j + c];
      const double dv = static_cast<double>(x[1591 + 6 * j + c]) - y[1591 + 6 * j + c];
      hand += dp * dp + dv * dv;
    }
  EXPECT_NEAR(jcd_local(x, y), hand, 1e-12 * hand);
  // The eq. 42 JCD adds the hip height and its velocity on top.
  const double dh = static_cast<double>(x[45]) - y[45], dvh = static_cast<double>(x[1681]) - y[1681];
  EXPECT_NEAR(jcd(x, y, false), hand + dh * dh + dvh * dvh, 1e-12 * hand);
}

TEST(Normaliser, KineticWeightScalesBlockNineOnly) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  std::vector<std::vector<float>> data(20, std::vector<float>(kata::gpd::kDims));
  std::vector<const float*> rows;
  for (auto& r : data) {
    for (float& v : r) v = u(rng);
    r[7] = 0.5f;  // a constant dimension
    rows.push_back(r.data());
  }
  Normaliser n = fit_normaliser(rows, kata::metric::Normalisation::kMinMaxUnit);
  const double gain = 3.0;
  weigh_kinetics(n, gain);
  EXPECT_EQ(n.kind, kata::metric::Normalisation::kBlockBalanced);
  std::vector<double> got(kata::gpd::kDims), want(kata::gpd::kDims);
  const float* x = rows[4];
  n.apply(x, got.data());
  double ss = 0.0;
  for (int i = 0; i < kata::gpd::kDims; ++i) {
    float lo = rows[0][i], hi = rows[0][i];
    for (const float* r : rows) {
      lo = std::min(lo, r[i]);
      hi = std::max(hi, r[i]);
    }
    const double v = hi > lo ? (static_cast<double>(x[i]) - lo) / (static_cast<double>(hi) - lo) : 0.0;
    want[i] = i >= 1591 ? gain * v : v;
    ss += want[i] * want[i];
  }
  for (int i = 0; i < kata::gpd::kDims; ++i) EXPECT_NEAR(got[i], want[i] / std::sqrt(ss), 1e-6) << i;
  EXPECT_THROW(weigh_kinetics(n, 0.0), kata::Error);
}

TEST(Eval, HandMadePairFile) {
  // Three identical pairs (distance 0) labelled similar, one identical pair labelled dissimilar,
  // three pairs of clearly different poses labelled dissimilar: the best any threshold can do is
  // 6 of 7 (the mislabelled identical pair is always wrong).
  const std::string path = kata::test::temp_path("kata_eval_hand.csv");
  {
    std::ofstream out(path);
    out << "# hand-made\nclip_a,frame_a,clip_b,frame_b,label\n"
        << "02_01.bvh,10,02_01.bvh,10,1\n05_02.bvh,200,05_02.bvh,200,1\n07_01.bvh,50,07_01.bvh,50,1\n"
        << "09_01.bvh,40,09_01.bvh,40,0\n"
        << "02_01.bvh,10,05_02.bvh,300,0\n05_03.bvh,100,09_01.bvh,60,0\n07_01.bvh,20,05_02.bvh,900,0\n";
  }
  ClipStore store(kData);
  const PairFile f = read_pairs(path);
  const PairRows rows = pair_rows(store, f.pairs);
  std::vector<double> d;
  for (size_t i = 0; i < rows.label.size(); ++i) d.push_back(jcd(rows.a[i], rows.b[i], false));
  EXPECT_EQ(d[0], 0.0);
  for (int i = 4; i < 7; ++i) EXPECT_GT(d[static_cast<size_t>(i)], 0.0);
  const Precision p = best_threshold(d, rows.label);
  EXPECT_EQ(p.correct, 6);
  EXPECT_NEAR(p.precision, 6.0 / 7.0, 1e-15);
  // JCD by hand for one pair from the raw features: sum of squared joint coordinate and velocity
  // differences (hip: height only).
  const float* a = rows.a[4];
  const float* b = rows.b[4];
  auto sub = [](float x, float y) { return static_cast<double>(x) - static_cast<double>(y); };
  double hand = sub(a[45], b[45]) * sub(a[45], b[45]) + sub(a[1681], b[1681]) * sub(a[1681], b[1681]);
  for (int j = 0; j < 15; ++j)
    for (int c = 0; c < 3; ++c) {
      const double dp = sub(a[3 * j + c], b[3 * j + c]);
      const double dv = sub(a[1591 + 6 * j + c], b[1591 + 6 * j + c]);
      hand += dp * dp + dv * dv;
    }
  EXPECT_NEAR(d[4], hand, 1e-9 * hand);
}

TEST(Rdsr, PcaRestriction) {
  // W = P V stays orthonormal and inside span(P); with P = all d directions the optimum is the
  // unrestricted one (same eta*).
  const int d = 12, n = 200, p = 60;
  Eigen::MatrixXd x = random_matrix(d, n, 5), pa = random_matrix(d, p, 6);
  Eigen::MatrixXd pb = pa + 0.3 * random_matrix(d, p, 7);
  RdsrOptions opt;
  opt.rank = 4;
  opt.lasso.gamma = 0.5;
  const RdsrResult full = train_rdsr(x, pa, pb, opt);
  opt.pca = d;
  const RdsrResult same = train_rdsr(x, pa, pb, opt);
  EXPECT_NEAR(same.eta, full.eta, 1e-8 * full.eta);
  opt.pca = 6;
  const RdsrResult sub = train_rdsr(x, pa, pb, opt);
  EXPECT_LE((sub.w.transpose() * sub.w - Eigen::MatrixXd::Identity(4, 4)).norm(), 1e-10);
  EXPECT_LE(sub.eta, full.eta * (1 + 1e-10));  // a restriction cannot beat the optimum
  Eigen::MatrixXd basis;
  top_eigen(centered_scatter(x, 1), 6, &basis);
  EXPECT_LE((sub.w - basis * (basis.transpose() * sub.w)).norm(), 1e-8);  // inside span(P)
}

TEST(Rdsr, NegativeWeightKeepsWhatNegativesDifferIn) {
  // Negative pairs differ only along dimension 0, positives a little everywhere: with the
  // negatives' scatter in the numerator W keeps dimension 0 (|W^T e_0| near 1), the beta
  // reported is negative_weight x Tr(X S_C X^T) / Tr(S_B), and without negative pairs it refuses.
  const int d = 12, n = 200, p = 60;
  Eigen::MatrixXd x = random_matrix(d, n, 15), pa = random_matrix(d, p, 16);
  Eigen::MatrixXd pb = pa + 0.3 * random_matrix(d, p, 17);
  Eigen::MatrixXd na = random_matrix(d, p, 18), nb = na;
  nb.row(0) += 3.0 * Eigen::RowVectorXd::Ones(p);
  RdsrOptions opt;
  opt.rank = 3;
  opt.lasso.gamma = 0.5;
  opt.negative_weight = 10.0;
  const RdsrResult r = train_rdsr(x, pa, pb, opt, {}, na, nb);
  EXPECT_GT(r.w.row(0).norm(), 0.99);
  EXPECT_NEAR(r.trace_sb, within_scatter(na, nb, 1).trace(), 1e-9 * r.trace_sb);
  EXPECT_NEAR(r.beta_absolute, 10.0 * r.trace_sc / r.trace_sb, 1e-12 * r.beta_absolute);
  opt.negative_weight = 0.0;
  const RdsrResult plain = train_rdsr(x, pa, pb, opt);
  EXPECT_LT(plain.w.row(0).norm(), r.w.row(0).norm());
  opt.negative_weight = 1.0;
  EXPECT_THROW(train_rdsr(x, pa, pb, opt), kata::Error);
}

TEST(Rdsr, BlockDimensionsAreTheGpdLayout) {
  // Block 1 (joint coordinates) is dims 0..45, block 9 (kinetics) 1591..1682 (gpd.hpp offsets).
  const std::vector<int> d = block_dimensions({9, 1});
  ASSERT_EQ(d.size(), 46u + 92u);
  EXPECT_EQ(d[0], 0);
  EXPECT_EQ(d[45], 45);
  EXPECT_EQ(d[46], 1591);
  EXPECT_EQ(d.back(), 1682);
  EXPECT_EQ(block_dimensions({}).size(), static_cast<size_t>(kata::gpd::kDims));
  EXPECT_EQ(block_dimensions({2}).size(), 120u);  // 46..165
  EXPECT_THROW(block_dimensions({0}), kata::Error);
  EXPECT_THROW(block_dimensions({10}), kata::Error);
  EXPECT_THROW(block_dimensions({9, 9}), kata::Error);
}

TEST(Rdsr, BlocksRestrictWToTheirDimensions) {
  const int d = kata::gpd::kDims, p = 120, r = 3;
  const Eigen::MatrixXd pa = random_matrix(d, p, 31), pb = pa + 0.2 * random_matrix(d, p, 32);
  RdsrOptions opt;
  opt.rank = r;
  opt.blocks = {9};
  // Eq. 46 (N' = 0): W = the r smallest eigenvectors of S_W's kinetics sub-block, zero elsewhere;
  // checked against an eigen-solve of the 92 x 92 block computed here from the differences.
  const RdsrResult e46 = train_rdsr(Eigen::MatrixXd(), pa, pb, opt);
  ASSERT_EQ(e46.w.rows(), d);
  EXPECT_EQ(e46.w.topRows(kata::gpd::kOffsetJk).norm(), 0.0);
  const Eigen::MatrixXd diff = (pa - pb).bottomRows(d - kata::gpd::kOffsetJk);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(diff * diff.transpose());
  const Eigen::MatrixXd v = es.eigenvectors().leftCols(r);  // ascending eigenvalues
  const Eigen::MatrixXd wk = e46.w.bottomRows(d - kata::gpd::kOffsetJk);
  EXPECT_LE((wk * wk.transpose() - v * v.transpose()).norm(), 1e-8);
  // With unlabeled poses and negatives, restricted to blocks 1 and 9: W is zero on blocks 2-8,
  // orthonormal, and the trace ratio of the 138 x 138 corners of A and B cut here by hand (dims
  // 0..45 and 1591..1682, from the full matrices built step by step: codes, X S_L X^T, X S_C X^T,
  // beta S_B, alpha S_W) has the same optimum and the same subspace.
  const Eigen::MatrixXd x = random_matrix(d, 60, 33);
  Eigen::MatrixXd na = random_matrix(d, p, 34), nb = na;
  nb.row(100) += 30.0 * random_matrix(1, p, 38);
  nb.row(1600) += 20.0 * random_matrix(1, p, 39);
  opt.lasso.gamma = 0.5;
  opt.negative_weight = 3.0;
  opt.blocks = {1, 9};
  const RdsrResult cut = train_rdsr(x, pa, pb, opt, {}, na, nb);
  EXPECT_EQ(cut.w.middleRows(46, kata::gpd::kOffsetJk - 46).norm(), 0.0);
  EXPECT_LE((cut.w.transpose() * cut.w - Eigen::MatrixXd::Identity(r, r)).norm(), 1e-10);
  std::vector<int> dims;
  for (int k = 0; k < 46; ++k) dims.push_back(k);
  for (int k = 1591; k < 1683; ++k) dims.push_back(k);
  SparseCodingStats stats;
  const CsrMatrix codes = sparse_code(gram_matrix(x, 1), opt.lasso, &stats);
  const Eigen::MatrixXd sl = laplacian_scatter(x, codes, 1)(dims, dims);
  const Eigen::MatrixXd sw = within_scatter(pa, pb, 1)(dims, dims), sb = within_scatter(na, nb, 1)(dims, dims);
  const Eigen::MatrixXd sc = centered_scatter(x, 1)(dims, dims);
  const double beta = 3.0 * sc.trace() / sb.trace(), alpha = sl.trace() / sw.trace();
  EXPECT_NEAR(cut.beta_absolute, beta, 1e-9 * beta);
  const TraceRatioResult hand = trace_ratio_newton(sc + beta * sb, sl + alpha * sw, r);
  EXPECT_NEAR(cut.eta, hand.eta, 1e-8 * hand.eta);
  const Eigen::MatrixXd wc = cut.w(dims, Eigen::all);
  EXPECT_LE((wc * wc.transpose() - hand.w * hand.w.transpose()).norm(), 1e-6);
  // A rank or PCA size beyond the blocks' dimensions, and blocks on vectors that are not GPD, refuse.
  opt.rank = 139;
  EXPECT_THROW(train_rdsr(x, pa, pb, opt, {}, na, nb), kata::Error);
  opt.rank = r;
  opt.pca = 139;
  EXPECT_THROW(train_rdsr(x, pa, pb, opt, {}, na, nb), kata::Error);
  opt.pca = 0;
  EXPECT_THROW(train_rdsr(random_matrix(12, 20, 35), random_matrix(12, 5, 36), random_matrix(12, 5, 37), opt), kata::Error);
}

#include "train/retrieval.hpp"

TEST(Retrieval, HandComputedPrecisionAtScope) {
  // Six 1-D "poses" x = 0, 1, 2, 10, 11, 30 (padded to 2-D), categories A A B B B A, subjects
  // 1 2 1 2 1 2; ties go to the lower index. Pool "all": top-1 correct for queries 0, 1, 3, 4 (4/6);
  // top-2 per query 1/2, 1/2, 0, 1, 1, 0 (3/6); top-3 1/3, 1/3, 1/3, 2/3, 2/3, 0 (7/18). Pool
  // "other subjects": top-1 4/6; top-2 1/2, 1/2, 1/2, 1, 1/2, 0 (3/6); top-3 = all three candidates
  // 2/3, 1/3, 1/3, 2/3, 1/3, 1/3 (8/18).
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(2, 6);
  x.row(0) << 0, 1, 2, 10, 11, 30;
  const std::vector<int> cat = {0, 0, 1, 1, 1, 0}, sub = {1, 2, 1, 2, 1, 2};
  const Eigen::MatrixXd d = pairwise_sq_l2(x);
  EXPECT_NEAR(d(0, 3), 100.0, 1e-12);
  EXPECT_NEAR((pairwise_diag(x, Eigen::VectorXd::Ones(2)) - d).norm(), 0.0, 1e-9);
  const std::vector<double> all = retrieval_precision(d, cat, sub, {1, 2, 3}, RetrievalPool::kAll);
  EXPECT_NEAR(all[0], 4.0 / 6.0, 1e-15);
  EXPECT_NEAR(all[1], 3.0 / 6.0, 1e-15);
  EXPECT_NEAR(all[2], 7.0 / 18.0, 1e-15);
  const std::vector<double> other = retrieval_precision(d, cat, sub, {1, 2, 3}, RetrievalPool::kOtherSubjects);
  EXPECT_NEAR(other[0], 4.0 / 6.0, 1e-15);
  EXPECT_NEAR(other[1], 3.0 / 6.0, 1e-15);
  EXPECT_NEAR(other[2], 8.0 / 18.0, 1e-15);
  // A README table with a "motion type" column (as ../shared/data/cmu's).
  const std::string readme = kata::test::temp_path("kata_retrieval_readme.md");
  {
    std::ofstream out(readme);
    out << "# x\n\n| file | subject | motion type | fps |\n|---|---|---|---|\n| 02_05.bvh | 2 | boxing/strike | 120 |\n"
        << "| 09_01.bvh | 9 | run | 120 |\n\nother | text |\n";
  }
  const auto types = read_motion_types(readme);
  ASSERT_EQ(types.size(), 2u);
  EXPECT_EQ(types.at("02_05.bvh"), "boxing/strike");
  EXPECT_EQ(types.at("09_01.bvh"), "run");
  EXPECT_EQ(clip_subject("09_12.bvh"), 9);
}

namespace {

// Random raw GPD vectors at the magnitudes a body produces: static dims in [0, 1], local
// positions within +-0.5 body heights, velocities +-2 /s, accelerations +-40 /s^2.
std::vector<float> random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> x(kata::gpd::kDims);
  for (int i = 0; i < kata::gpd::kDims; ++i) x[static_cast<size_t>(i)] = 0.5f + 0.5f * u(rng);
  for (int i = 0; i < 45; ++i) x[static_cast<size_t>(i)] = 0.5f * u(rng);
  for (int j = 0; j < 15; ++j)
    for (int k = 0; k < 6; ++k) x[static_cast<size_t>(kata::gpd::kOffsetJk + 6 * j + k)] = (k < 3 ? 2.0f : 40.0f) * u(rng);
  return x;
}

}  // namespace

// The joint form's d^2 computed by hand from its matrices, and the kata model made of it scored by
// the SDK's own Metric (min/max ranges, shift/scale, unit length, W): the same distance.
TEST(JointForm, ModelScoresTheFormsDistance) {
  std::mt19937 rng(7);
  JointForm form;
  form.terms = 3;
  for (int a = 0; a < 3; ++a) {
    Eigen::Matrix3d l = Eigen::Matrix3d::Zero();
    l << 1.0 - 0.2 * a, 0, 0, 0.1, 0.05 + 0.01 * a, 0, -0.001, 0.0005, 0.0002;
    form.lower[static_cast<size_t>(a)] = l;
  }
  std::vector<std::vector<float>> poses;
  for (int i = 0; i < 40; ++i) poses.push_back(random_pose(rng));
  Normaliser ranges;
  ranges.min.assign(kata::gpd::kDims, -50.0f);
  ranges.max.assign(kata::gpd::kDims, 50.0f);
  kata::metric::Model made = joint_form_model(form, ranges, kata::gpd::Stencil::kBackward);
  made.delta_star = 1.0;
  const std::vector<uint8_t> buffer = kata::metric::serialize_model(made);  // validated, as a file would be
  const kata::metric::Model model = kata::metric::parse_model(buffer.data(), buffer.size());
  ASSERT_EQ(model.rank, 135);
  kata::metric::Metric metric(model);
  auto ws = metric.make_workspace();
  std::vector<float> ua(static_cast<size_t>(model.rank)), ub(ua.size());
  for (int i = 0; i + 1 < static_cast<int>(poses.size()); i += 2) {
    const float* a = poses[static_cast<size_t>(i)].data();
    const float* b = poses[static_cast<size_t>(i) + 1].data();
    double by_hand = 0.0;  // sum over joints and axes of u^T L L^T u, u = (dp, dv, da)
    for (int j = 0; j < 15; ++j)
      for (int ax = 0; ax < 3; ++ax) {
        auto diff = [&](int dim) { return static_cast<double>(a[dim]) - b[dim]; };
        const Eigen::Vector3d u(diff(3 * j + ax), diff(kata::gpd::kOffsetJk + 6 * j + ax),
                                diff(kata::gpd::kOffsetJk + 6 * j + 3 + ax));
        by_hand += u.dot(form.form(ax) * u);
      }
    EXPECT_NEAR(joint_form_distance2(form, a, b), by_hand, 1e-9 * by_hand);
    metric.project(a, ws, ua.data());
    metric.project(b, ws, ub.data());
    double d2 = 0.0;
    for (size_t c = 0; c < ua.size(); ++c) d2 += (static_cast<double>(ua[c]) - ub[c]) * (static_cast<double>(ua[c]) - ub[c]);
    EXPECT_NEAR(std::sqrt(d2), std::sqrt(by_hand), 1e-3 * std::sqrt(by_hand)) << "pair " << i;
  }
}

// Labels planted by a form with a position-velocity cross term: the fit recovers a form that
// separates them (JCD-like |dp|^2 + |dv|^2 does not), and its matrices are positive semidefinite.
TEST(JointForm, FitRecoversAPlantedCrossTerm) {
  std::mt19937 rng(11);
  JointForm planted;
  planted.terms = 2;
  for (auto& l : planted.lower) {
    l.setZero();
    l(0, 0) = 1.0;
    l(1, 0) = 0.25;  // M = [[1, .25], [.25, .0625 + .0001]]: future position dp + 0.25 dv
    l(1, 1) = 0.01;
  }
  std::vector<std::vector<float>> store;
  for (int i = 0; i < 1200; ++i) store.push_back(random_pose(rng));
  PairRows rows;
  std::vector<double> planted_d;
  for (int i = 0; i < 600; ++i) {
    rows.a.push_back(store[static_cast<size_t>(2 * i)].data());
    rows.b.push_back(store[static_cast<size_t>(2 * i + 1)].data());
    planted_d.push_back(joint_form_distance2(planted, rows.a.back(), rows.b.back()));
  }
  std::vector<double> sorted = planted_d;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (double d : planted_d) rows.label.push_back(d < median ? 1 : 0);
  JointFormOptions o;
  o.acceleration = false;
  const JointForm fit = fit_joint_form(rows, o);
  std::vector<double> fitted, jcd_like;
  for (size_t i = 0; i < rows.label.size(); ++i) {
    fitted.push_back(joint_form_distance2(fit, rows.a[i], rows.b[i]));
    double s = 0.0;
    for (int j = 0; j < 15; ++j)
      for (int ax = 0; ax < 3; ++ax) {
        const double dp = static_cast<double>(rows.a[i][3 * j + ax]) - rows.b[i][3 * j + ax];
        const double dv = static_cast<double>(rows.a[i][kata::gpd::kOffsetJk + 6 * j + ax]) -
                          rows.b[i][kata::gpd::kOffsetJk + 6 * j + ax];
        s += dp * dp + dv * dv;
      }
    jcd_like.push_back(s);
  }
  EXPECT_GE(best_threshold(fitted, rows.label).precision, 0.95);
  EXPECT_LT(best_threshold(jcd_like, rows.label).precision, 0.9);
  for (int ax = 0; ax < 3; ++ax) {
    const Eigen::Matrix2d m = fit.form(ax).topLeftCorner<2, 2>();
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(m).eigenvalues().minCoeff(), -1e-12);
    EXPECT_NEAR(m(0, 1) / m(0, 0), 0.25, 0.05) << "axis " << ax;  // the planted cross term
  }
}

TEST(JointForm, RefusesPairsWithOneLabel) {
  std::mt19937 rng(3);
  const std::vector<float> a = random_pose(rng), b = random_pose(rng);
  PairRows rows;
  rows.a = {a.data()};
  rows.b = {b.data()};
  rows.label = {1};
  EXPECT_THROW(fit_joint_form(rows, JointFormOptions{}), kata::Error);
}
