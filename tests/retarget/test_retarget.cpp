// Tests of kata::retarget: distance matrices against hand-computed values, the analytic gradient
// against finite differences, SPG against an independent gradient descent, same-skeleton
// retargeting, the bone-length restoring step, placement, and no allocation per frame.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <functional>
#include <new>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include "common/cpu.hpp"
#include "io/bvh.hpp"
#include "retarget/distance.hpp"
#include "io/ghost_bvh.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/retargeter.hpp"
#include "retarget/spg.hpp"
#include "skeleton/skeleton.hpp"

// Allocation counting lives in alloc_count.cpp (its own translation unit, so the compiler
// never sees a replaced operator new and std::free meet inline).
#include "support/alloc_counter.hpp"

namespace {

using kata::retarget::PairTable;
using kata::retarget::Retargeter;
using kata::retarget::RetargetOptions;
using kata::retarget::StressInstance;

// Positions as a flat joints x 3 row-major vector.
using Pose = std::vector<double>;

double dist(const Pose& x, int a, int b) {
  const double dx = x[3 * a] - x[3 * b], dy = x[3 * a + 1] - x[3 * b + 1], dz = x[3 * a + 2] - x[3 * b + 2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// ---- An independent reference: tree paths by breadth-first search on the undirected tree. ----
struct Reference {
  std::vector<std::vector<int>> path;  // per (u, v) pair index, the joints from u to v
  std::vector<double> weight;          // priority per pair
  std::vector<double> delta;           // target distance per pair
  std::vector<int> u, v;
};

std::vector<int> bfs_path(const std::vector<int>& parents, int from, int to) {
  const int n = static_cast<int>(parents.size());
  std::vector<std::vector<int>> adj(n);
  for (int j = 1; j < n; ++j) {
    adj[j].push_back(parents[j]);
    adj[parents[j]].push_back(j);
  }
  std::vector<int> prev(n, -2);
  std::deque<int> queue{from};
  prev[from] = -1;
  while (!queue.empty()) {
    const int a = queue.front();
    queue.pop_front();
    for (int b : adj[a]) {
      if (prev[b] == -2) {
        prev[b] = a;
        queue.push_back(b);
      }
    }
  }
  std::vector<int> p;
  for (int a = to; a != -1; a = prev[a]) p.push_back(a);
  std::reverse(p.begin(), p.end());
  return p;
}

// The DGP instance of the paper, written straight from its formulas.
Reference reference_instance(const std::vector<int>& parents, const Pose& teacher, const std::vector<double>& student_len) {
  const int n = static_cast<int>(parents.size());
  Reference r;
  size_t pmax = 0;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      r.path.push_back(bfs_path(parents, a, b));
      r.u.push_back(a);
      r.v.push_back(b);
      pmax = std::max(pmax, r.path.back().size());
    }
  auto edge_len = [&](const Pose& x, const std::vector<double>* lens, int a, int b) {
    const int child = parents[a] == b ? a : b;
    return lens ? (*lens)[child] : dist(x, a, b);
  };
  for (size_t p = 0; p < r.path.size(); ++p) {
    double tau1 = 0.0, tau2 = 0.0;
    for (size_t i = 0; i + 1 < r.path[p].size(); ++i) {
      tau1 += edge_len(teacher, nullptr, r.path[p][i], r.path[p][i + 1]);
      tau2 += edge_len(teacher, &student_len, r.path[p][i], r.path[p][i + 1]);
    }
    r.delta.push_back(tau2 * dist(teacher, r.u[p], r.v[p]) / tau1);
    r.weight.push_back(static_cast<double>(pmax - r.path[p].size() + 2) / static_cast<double>(pmax));
  }
  return r;
}

// The stress written plainly, for the reference solver.
double reference_stress(const Reference& r, const Pose& x, Pose* grad) {
  double f = 0.0;
  if (grad) grad->assign(x.size(), 0.0);
  for (size_t p = 0; p < r.u.size(); ++p) {
    const double d = dist(x, r.u[p], r.v[p]);
    f += 0.5 * r.weight[p] * (d - r.delta[p]) * (d - r.delta[p]);
    if (grad && d > 0.0) {
      for (int k = 0; k < 3; ++k) {
        const double c = r.weight[p] * (d - r.delta[p]) * (x[3 * r.u[p] + k] - x[3 * r.v[p] + k]) / d;
        (*grad)[3 * r.u[p] + k] += c;
        (*grad)[3 * r.v[p] + k] -= c;
      }
    }
  }
  return f;
}

// Plain monotone gradient descent with Armijo backtracking, run until the gradient vanishes.
double gradient_descent(const Reference& r, Pose x, int* iterations, int max_iter = 400000) {
  Pose g, xn;
  double f = reference_stress(r, x, &g);
  double scale = 0.0;  // sqrt(sum w delta^2): the gradient's natural size
  for (size_t p = 0; p < r.u.size(); ++p) scale += r.weight[p] * r.delta[p] * r.delta[p];
  scale = std::sqrt(scale);
  double step = 1e-3;
  int stalled = 0;  // consecutive iterations without a relative decrease above 1e-15
  for (int it = 0; it < max_iter; ++it) {
    *iterations = it;
    double g2 = 0.0;
    for (double gi : g) g2 += gi * gi;
    // Converged; or f no longer moves in double precision (the Armijo test then only sees
    // rounding noise, so the step collapses without progress).
    if (std::sqrt(g2) < 1e-9 * scale || stalled > 100) break;
    step *= 2.0;
    while (true) {
      xn = x;
      for (size_t i = 0; i < x.size(); ++i) xn[i] -= step * g[i];
      const double fn = reference_stress(r, xn, nullptr);
      if (fn <= f - 0.5 * step * g2) {
        stalled = f - fn <= 1e-15 * f ? stalled + 1 : 0;
        x = xn;
        f = reference_stress(r, x, &g);
        break;
      }
      step *= 0.5;
      if (step < 1e-20) return f;
    }
  }
  return f;
}

// A random tree (each joint hangs from a random earlier joint) with a random posture.
struct RandomCase {
  std::vector<int> parents;
  std::vector<double> teacher_len, student_len;
  Pose teacher;
};

RandomCase random_case(std::mt19937& rng, int n, double length_change) {
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  RandomCase c;
  c.parents.push_back(-1);
  for (int j = 1; j < n; ++j) c.parents.push_back(static_cast<int>(uni(rng) * j));
  c.teacher_len.assign(n, 0.0);
  c.student_len.assign(n, 0.0);
  c.teacher.assign(3 * n, 0.0);
  for (int j = 1; j < n; ++j) {
    c.teacher_len[j] = 0.5 + uni(rng);
    c.student_len[j] = c.teacher_len[j] * (1.0 + length_change * (2.0 * uni(rng) - 1.0));
    double d[3] = {normal(rng), normal(rng), normal(rng)};
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; ++k) c.teacher[3 * j + k] = c.teacher[3 * c.parents[j] + k] + c.teacher_len[j] * d[k] / len;
  }
  return c;
}

Eigen::MatrixX3d to_matrix(const Pose& x) {
  Eigen::MatrixX3d m(x.size() / 3, 3);
  for (int j = 0; j < m.rows(); ++j) m.row(j) = Eigen::RowVector3d(x[3 * j], x[3 * j + 1], x[3 * j + 2]);
  return m;
}

// ---- Distance matrices ----

TEST(RetargetDistance, FourJointChainMatchesHandComputation) {
  const PairTable t = kata::retarget::build_pair_table({-1, 0, 1, 2});
  ASSERT_EQ(t.pairs, 6);
  EXPECT_EQ(t.max_path, 4);
  // Pairs in order (0,1) (0,2) (0,3) (1,2) (1,3) (2,3): path sizes and priorities (4 - |P| + 2) / 4.
  const std::vector<int> sizes = {2, 3, 4, 2, 3, 2};
  const std::vector<double> prio = {1.0, 0.75, 0.5, 1.0, 0.75, 1.0};
  for (int p = 0; p < 6; ++p) {
    EXPECT_EQ(t.path_size[p], sizes[p]);
    EXPECT_DOUBLE_EQ(t.priority[p], prio[p]);
  }
  // Path (0, 3) = 0, 1, 2, 3.
  const std::vector<int> p03(t.path_joints.begin() + t.path_offset[2], t.path_joints.begin() + t.path_offset[3]);
  EXPECT_EQ(p03, (std::vector<int>{0, 1, 2, 3}));
  // x0 = 0, x1 = (1,0,0), x2 = (1,2,0), x3 = (1,2,3): bones 1, 2, 3.
  const Pose x = {0, 0, 0, 1, 0, 0, 1, 2, 0, 1, 2, 3};
  std::vector<double> len(4);
  kata::retarget::bone_lengths(t, x.data(), len.data());
  EXPECT_EQ(len, (std::vector<double>{0, 1, 2, 3}));
  const Eigen::MatrixXd d = kata::retarget::normalised_distance_matrix(t, to_matrix(x), len);
  Eigen::MatrixXd expect(4, 4);
  expect << 0, 1, std::sqrt(5.0) / 3, std::sqrt(14.0) / 6,  //
      1, 0, 1, std::sqrt(13.0) / 5,                         //
      std::sqrt(5.0) / 3, 1, 0, 1,                          //
      std::sqrt(14.0) / 6, std::sqrt(13.0) / 5, 1, 0;
  EXPECT_LT((d - expect).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(RetargetDistance, SmallTreeMatchesHandComputation) {
  // 0 root; 1 and 2 children of 0; 3 child of 1.
  const PairTable t = kata::retarget::build_pair_table({-1, 0, 0, 1});
  EXPECT_EQ(t.max_path, 4);  // 2 - 0 - 1 - 3
  const int p23 = kata::retarget::pair_index(4, 2, 3);
  const std::vector<int> path(t.path_joints.begin() + t.path_offset[p23], t.path_joints.begin() + t.path_offset[p23 + 1]);
  EXPECT_EQ(path, (std::vector<int>{2, 0, 1, 3}));
  EXPECT_EQ(t.lca[p23], 0);
  EXPECT_EQ(t.lca[kata::retarget::pair_index(4, 0, 3)], 0);
  EXPECT_EQ(t.lca[kata::retarget::pair_index(4, 1, 3)], 1);
  // x0 = 0, x1 = (0,1,0) [bone 1], x2 = (2,0,0) [bone 2], x3 = (0,1,1) [bone 1].
  const Pose x = {0, 0, 0, 0, 1, 0, 2, 0, 0, 0, 1, 1};
  std::vector<double> len(4), cum(4), tau(6);
  kata::retarget::bone_lengths(t, x.data(), len.data());
  kata::retarget::path_weights(t, len.data(), cum.data(), tau.data());
  // tau: (0,1)=1 (0,2)=2 (0,3)=2 (1,2)=3 (1,3)=1 (2,3)=4.
  EXPECT_EQ(tau, (std::vector<double>{1, 2, 2, 3, 1, 4}));
  const Eigen::MatrixXd d = kata::retarget::normalised_distance_matrix(t, to_matrix(x), len);
  Eigen::MatrixXd expect(4, 4);
  expect << 0, 1, 1, std::sqrt(2.0) / 2,  //
      1, 0, std::sqrt(5.0) / 3, 1,        //
      1, std::sqrt(5.0) / 3, 0, std::sqrt(6.0) / 4, //
      std::sqrt(2.0) / 2, 1, std::sqrt(6.0) / 4, 0;
  EXPECT_LT((d - expect).cwiseAbs().maxCoeff(), 1e-15);
  // Priorities: bones 1; (0,3), (1,2): |P| = 3 -> 3/4; (2,3): |P| = 4 -> 1/2.
  EXPECT_EQ(t.priority, (std::vector<double>{1, 1, 0.75, 0.75, 1, 0.5}));
}

TEST(RetargetDistance, BonesNormaliseToOneAndPathsMatchBfs) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 5; ++trial) {
    const RandomCase c = random_case(rng, 25, 0.3);
    const PairTable t = kata::retarget::build_pair_table(c.parents);
    std::vector<double> len(25);
    kata::retarget::bone_lengths(t, c.teacher.data(), len.data());
    const Eigen::MatrixXd d = kata::retarget::normalised_distance_matrix(t, to_matrix(c.teacher), len);
    for (int j = 1; j < 25; ++j) EXPECT_NEAR(d(j, c.parents[j]), 1.0, 1e-14);
    // Non-bone distances are at most 1 (the triangle inequality along the path).
    EXPECT_LE(d.maxCoeff(), 1.0 + 1e-14);
    const Reference ref = reference_instance(c.parents, c.teacher, c.student_len);
    for (int p = 0; p < t.pairs; ++p) {
      const std::vector<int> path(t.path_joints.begin() + t.path_offset[p], t.path_joints.begin() + t.path_offset[p + 1]);
      ASSERT_EQ(path, ref.path[p]);
      EXPECT_DOUBLE_EQ(t.priority[p], ref.weight[p]);
    }
  }
}

TEST(RetargetDistance, CmuDropsTenCoincidentJoints) {
  const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
  ASSERT_EQ(clip.skeleton.joint_count(), 31);
  const auto drop = kata::retarget::coincident_joints(clip.skeleton);
  const auto reduced = kata::retarget::drop_joints(clip.skeleton, drop);
  EXPECT_EQ(reduced.skeleton.joint_count(), 21);
  EXPECT_EQ(kata::retarget::build_pair_table(reduced.skeleton.parents).pairs, 210);
  // The dropped joints sit on their kept ancestor at every frame.
  Eigen::MatrixX3d w(31, 3);
  kata::world_positions(clip, 100, w);
  for (int j = 0; j < 31; ++j) {
    const int k = reduced.source[reduced.kept_position[j]];
    EXPECT_LT((w.row(j) - w.row(k)).norm(), 1e-9) << clip.skeleton.names[j];
  }
  // Rest bone lengths of the reduced tree equal the distances at any frame (rigid bones).
  const auto len = kata::retarget::rest_bone_lengths(reduced.skeleton);
  for (int k = 1; k < 21; ++k) {
    const double d = (w.row(reduced.source[k]) - w.row(reduced.source[reduced.skeleton.parents[k]])).norm();
    EXPECT_NEAR(d, len[k], 1e-9 * len[k]);
  }
}

// ---- Stress and gradient ----

TEST(RetargetStress, GradientMatchesCentralDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const int n = 12;
  const PairTable t = kata::retarget::build_pair_table(random_case(rng, n, 0.0).parents);
  std::vector<double> w(t.pairs), delta(t.pairs);
  for (int p = 0; p < t.pairs; ++p) {
    w[p] = 0.2 + std::fabs(uni(rng));
    delta[p] = 1.0 + uni(rng);
  }
  const StressInstance in{n, t.pairs, t.u.data(), t.v.data(), w.data(), delta.data()};
  Pose x(3 * n), g(3 * n);  // SoA: all x, all y, all z
  for (double& xi : x) xi = 2.0 * uni(rng);
  kata::retarget::stress(in, x.data(), g.data());
  const double h = 1e-6;
  for (int i = 0; i < 3 * n; ++i) {
    Pose xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    const double fd = (kata::retarget::stress(in, xp.data(), nullptr) - kata::retarget::stress(in, xm.data(), nullptr)) / (2 * h);
    EXPECT_NEAR(g[i], fd, 1e-7 * std::max(1.0, std::fabs(fd))) << "coordinate " << i;
  }
  // The stress equals the plain formula.
  Pose rows(3 * n);
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < 3; ++k) rows[3 * j + k] = x[k * n + j];
  double f = 0.0;
  for (int p = 0; p < t.pairs; ++p) f += 0.5 * w[p] * std::pow(dist(rows, t.u[p], t.v[p]) - delta[p], 2);
  EXPECT_NEAR(kata::retarget::stress(in, x.data(), nullptr), f, 1e-12 * f);
}

// Every instruction set's kernel against the plain formula in long double: value and gradient,
// for joint counts whose rows end on every tail length of 4- and 8-pair vectors, with coincident
// joints (r = 0: no gradient from that pair) and zero-weight pairs among spread ones.
// The blocked AVX-512 kernel (the one the solver runs on AVX-512 machines; its own pair order,
// BlockedPairs) the same way, for joint counts that fill and leave partial blocks of 8.
TEST(RetargetStress, EveryKernelMatchesThePlainFormula) {
  using Kernel = std::function<double(const StressInstance&, const double*, double*)>;
  std::vector<std::pair<const char*, Kernel>> kernels = {{"portable", kata::retarget::detail::stress_portable}};
  if (kata::cpu_has_avx2()) kernels.emplace_back("avx2", kata::retarget::detail::stress_avx2);
  if (kata::cpu_has_avx512()) {
    kernels.emplace_back("avx512", kata::retarget::detail::stress_avx512);
    kernels.emplace_back("avx512 blocked", [](const StressInstance& in, const double* x, double* grad) {
      kata::retarget::detail::BlockedPairs blocked(in.joints), plain(in.joints);
      kata::retarget::detail::gather_blocked_avx512(blocked, in);  // the solver's gather
      plain.gather(in);
      for (int i = 0; i < 8 * blocked.steps; ++i) {
        EXPECT_EQ(blocked.weight()[i], plain.weight()[i]) << i;
        EXPECT_EQ(blocked.delta()[i], plain.delta()[i]) << i;
        const int p = plain.pair[i];
        EXPECT_EQ(plain.weight()[i], p >= 0 ? in.weight[p] : 0.0) << i;
      }
      if (grad) return kata::retarget::detail::stress_blocked_avx512(blocked, x, grad);
      Pose unused(3 * static_cast<size_t>(in.joints));
      return kata::retarget::detail::stress_blocked_avx512(blocked, x, unused.data());
    });
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int n : {2, 3, 5, 8, 9, 12, 15, 16, 17, 21, 24, 26, 33}) {
    const PairTable t = kata::retarget::build_pair_table(random_case(rng, n, 0.0).parents);
    std::vector<double> w(t.pairs), delta(t.pairs);
    for (int p = 0; p < t.pairs; ++p) {
      w[p] = p % 7 == 3 ? 0.0 : 0.2 + std::fabs(uni(rng));
      delta[p] = 30.0 * (1.0 + uni(rng));
    }
    const StressInstance in{n, t.pairs, t.u.data(), t.v.data(), w.data(), delta.data()};
    Pose x(3 * n);  // SoA, CMU-like units (tens)
    for (double& xi : x) xi = 40.0 * uni(rng);
    if (n >= 3) {
      for (int k = 0; k < 3; ++k) x[k * n + n - 1] = x[k * n + 1];  // the last joint on joint 1
    }
    long double f = 0.0L;
    std::vector<long double> g(3 * n, 0.0L);
    for (int p = 0; p < t.pairs; ++p) {
      const int a = t.u[p], b = t.v[p];
      long double d[3], r2 = 0.0L;
      for (int k = 0; k < 3; ++k) {
        d[k] = static_cast<long double>(x[k * n + a]) - x[k * n + b];
        r2 += d[k] * d[k];
      }
      const long double r = std::sqrt(r2), e = r - delta[p];
      f += 0.5L * w[p] * e * e;
      if (r > 0.0L) {
        for (int k = 0; k < 3; ++k) {
          g[k * n + a] += w[p] * e * d[k] / r;
          g[k * n + b] -= w[p] * e * d[k] / r;
        }
      }
    }
    long double gscale = 0.0L;
    for (long double gi : g) gscale = std::max(gscale, std::fabs(gi));
    for (const auto& [name, kernel] : kernels) {
      Pose grad(3 * n, -7.0);
      const double value = kernel(in, x.data(), grad.data());
      EXPECT_NEAR(value, static_cast<double>(f), 1e-13 * static_cast<double>(f)) << name << " n " << n;
      EXPECT_NEAR(kernel(in, x.data(), nullptr), static_cast<double>(f), 1e-13 * static_cast<double>(f)) << name;
      for (int i = 0; i < 3 * n; ++i)
        ASSERT_NEAR(grad[i], static_cast<double>(g[i]), 1e-12 * static_cast<double>(gscale)) << name << " n " << n << " i " << i;
    }
  }
}

// The per-frame target distances of every instruction set against the plain formula
// tau_s |t_u - t_v| / tau_t (long double), with teacher paths of zero length (the student's tau
// is kept), tiny and subnormal positive ones (no overflow to inf or NaN), coincident joints, and
// joint counts whose rows end on every tail length.
TEST(RetargetStress, EveryTargetsKernelMatchesThePlainFormula) {
  using Targets = void (*)(int, const double*, const double*, const double*, double*);
  std::vector<std::pair<const char*, Targets>> kernels = {{"portable", kata::retarget::detail::targets_portable}};
  if (kata::cpu_has_avx2()) kernels.emplace_back("avx2", kata::retarget::detail::targets_avx2);
  if (kata::cpu_has_avx512()) kernels.emplace_back("avx512", kata::retarget::detail::targets_avx512);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int n : {2, 3, 9, 16, 17, 21, 26}) {
    const int pairs = n * (n - 1) / 2;
    Pose t(3 * n), tau_s(pairs), tau_t(pairs);
    for (double& ti : t) ti = 40.0 * uni(rng);
    if (n >= 3) {
      for (int k = 0; k < 3; ++k) t[k * n + n - 1] = t[k * n + 1];  // the last joint on joint 1
    }
    for (int p = 0; p < pairs; ++p) {
      tau_s[p] = 20.0 + 10.0 * uni(rng);
      tau_t[p] = p % 11 == 4 ? 0.0 : p % 13 == 6 ? 1e-300 : p % 17 == 8 ? 4e-320 : 25.0 + 10.0 * uni(rng);
    }
    for (const auto& [name, kernel] : kernels) {
      Pose delta(pairs, -1.0);
      kernel(n, t.data(), tau_s.data(), tau_t.data(), delta.data());
      int p = 0;
      for (int u = 0; u < n; ++u) {
        for (int v = u + 1; v < n; ++v, ++p) {
          long double r2 = 0.0L;
          for (int k = 0; k < 3; ++k) r2 += std::pow(static_cast<long double>(t[k * n + u]) - t[k * n + v], 2);
          const long double expect = tau_t[p] > 0.0 ? tau_s[p] * std::sqrt(r2) / tau_t[p] : tau_s[p];
          ASSERT_FALSE(std::isnan(delta[p])) << name << " n " << n << " pair " << p;
          if (std::isinf(static_cast<double>(expect))) {
            EXPECT_TRUE(std::isinf(delta[p])) << name << " n " << n << " pair " << p;
          } else {
            ASSERT_NEAR(delta[p], static_cast<double>(expect), 4e-15 * static_cast<double>(std::fabs(expect)))
                << name << " n " << n << " pair " << p << " tau_t " << tau_t[p];
          }
        }
      }
    }
  }
}

TEST(RetargetStress, CoincidentJointsStayFinite) {
  const PairTable t = kata::retarget::build_pair_table({-1, 0, 1, 2});
  std::vector<double> delta(t.pairs, 1.0);
  const StressInstance in{4, t.pairs, t.u.data(), t.v.data(), t.priority.data(), delta.data()};
  Pose x(12, 0.0);  // every joint on the origin
  Pose g(12);
  const double f = kata::retarget::stress(in, x.data(), g.data());
  EXPECT_TRUE(std::isfinite(f));
  for (double gi : g) EXPECT_EQ(gi, 0.0);
  // Two coincident joints among spread ones: SPG must stay finite and decrease the stress.
  x = {0, 1, 1, 0.5, 0, 0, 0, 0.5, 0, 0, 0, 0};  // SoA: joints 1 and 2 both at (1, 0, 0)
  kata::retarget::SpgSolver solver(4);
  const auto r = solver.minimize(in, x.data(), kata::retarget::SpgOptions{});
  for (double xi : x) EXPECT_TRUE(std::isfinite(xi));
  EXPECT_LT(r.stress, r.stress_start);
}

// Curvature pairs kept from one solve to the next follow a rigid rotation of the point: solving
// a rotated problem with rotated pairs takes the same steps, rotated (the stress is invariant), so
// the result is the rotated result and the iteration count is the same; without rotating the
// pairs the steps differ.
TEST(RetargetSpg, KeptCurvaturePairsFollowARotation) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const int n = 12;
  const PairTable t = kata::retarget::build_pair_table(random_case(rng, n, 0.0).parents);
  std::vector<double> w(t.pairs), delta(t.pairs);
  for (int p = 0; p < t.pairs; ++p) {
    w[p] = 0.2 + std::fabs(uni(rng));
    delta[p] = 1.0 + uni(rng);
  }
  const StressInstance in{n, t.pairs, t.u.data(), t.v.data(), w.data(), delta.data()};
  Pose x(3 * n);  // SoA
  for (double& xi : x) xi = 2.0 * uni(rng);
  // An orthogonal r (row-major): rotation by 0.7 rad about a tilted axis.
  const double ax[3] = {0.48, 0.6, 0.64}, th = 0.7, c = std::cos(th), s = std::sin(th);
  double r[9];
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) r[3 * i + k] = (i == k ? c : 0.0) + (1 - c) * ax[i] * ax[k];
  r[1] -= s * ax[2], r[2] += s * ax[1], r[3] += s * ax[2], r[5] -= s * ax[0], r[6] -= s * ax[1], r[7] += s * ax[0];
  const auto rotate = [&](const Pose& a) {
    Pose b(a.size());
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < 3; ++i) b[i * n + j] = r[3 * i] * a[j] + r[3 * i + 1] * a[n + j] + r[3 * i + 2] * a[2 * n + j];
    return b;
  };
  kata::retarget::SpgOptions opt;
  opt.curvature_pairs = 5;
  opt.gradient_tolerance = 1e-9;
  kata::retarget::SpgSolver plain(n), turned(n), unturned(n);
  Pose a = x, b = x, e = x;
  plain.minimize(in, a.data(), opt);
  turned.minimize(in, b.data(), opt);
  unturned.minimize(in, e.data(), opt);
  ASSERT_EQ(turned.curvature_count(), 5);
  turned.rotate_curvature(r);
  // The next problem: a nearby start point (the optimum, disturbed), and the same rotated.
  for (int i = 0; i < 3 * n; ++i) a[i] += 0.05 * uni(rng);
  Pose a_turned = rotate(a), a_unturned = a_turned;
  opt.keep_curvature = true;
  {
    // One step each, from copies of the solvers' state: the rotated pairs give the rotated step.
    kata::retarget::SpgSolver p1 = plain, t1 = turned, u1 = unturned;
    kata::retarget::SpgOptions one = opt;
    one.max_iterations = 1;
    Pose pa = a, ta = a_turned, ua = a_unturned;
    p1.minimize(in, pa.data(), one);
    t1.minimize(in, ta.data(), one);
    u1.minimize(in, ua.data(), one);
    const Pose step_expect = rotate(pa);
    double worst_turned = 0.0, worst_unturned = 0.0;
    for (int i = 0; i < 3 * n; ++i) {
      worst_turned = std::max(worst_turned, std::fabs(ta[i] - step_expect[i]));
      worst_unturned = std::max(worst_unturned, std::fabs(ua[i] - step_expect[i]));
    }
    EXPECT_LT(worst_turned, 1e-12);
    EXPECT_GT(worst_unturned, 1e-6);
  }
  const auto first = plain.minimize(in, a.data(), opt);
  const auto second = turned.minimize(in, a_turned.data(), opt);
  const auto third = unturned.minimize(in, a_unturned.data(), opt);
  EXPECT_EQ(second.iterations, first.iterations);
  const Pose expect = rotate(a);
  // Equal to rounding, which the steps carry to ~1e-9 here (the stop is at a 1e-9 relative gradient).
  for (int i = 0; i < 3 * n; ++i) EXPECT_NEAR(a_turned[i], expect[i], 1e-7) << i;
  EXPECT_NEAR(second.stress, first.stress, 1e-12 * (1.0 + first.stress));
  // Pairs left unrotated describe another point's curvature: the first step goes elsewhere.
  EXPECT_NEAR(third.stress, first.stress, 1e-6 * (1.0 + first.stress));
}

// ---- SPG against an independent gradient descent ----

void expect_same_optimum(const std::vector<int>& parents, const Pose& teacher, const std::vector<double>& student_len,
                         const char* what) {
  const int n = static_cast<int>(parents.size());
  RetargetOptions opt;
  opt.restore_bone_lengths = false;
  opt.diagnostics = true;
  opt.solver.gradient_tolerance = 1e-12;
  opt.solver.max_iterations = 200000;
  Retargeter rt(parents, student_len, opt);
  Pose ghost(3 * n);
  const auto& rep = rt.retarget(teacher.data(), ghost.data());
  // The instance the retargeter built equals the paper's formulas evaluated independently.
  const Reference ref = reference_instance(parents, teacher, student_len);
  for (int p = 0; p < rt.table().pairs; ++p) {
    ASSERT_NEAR(rt.delta()[p], ref.delta[p], 1e-12 * (1.0 + ref.delta[p])) << what;
    ASSERT_DOUBLE_EQ(rt.weights()[p], ref.weight[p]) << what;
  }
  const Pose start(rt.fk_baseline(), rt.fk_baseline() + 3 * n);
  int gd_iterations = 0;
  const double gd = gradient_descent(ref, start, &gd_iterations);
  std::printf("  %s: stress FK %.6g -> SPG %.12g (%d it) | GD %.12g (%d it)\n", what, rep.stress_baseline, rep.stress,
              rep.iterations, gd, gd_iterations);
  EXPECT_NEAR(rep.stress, gd, 1e-6 * gd) << what << ": SPG " << rep.stress << " after " << rep.iterations
                                         << " iterations, GD " << gd;
  EXPECT_NEAR(reference_stress(ref, ghost, nullptr), rep.stress, 1e-9 * rep.stress) << what;
  // The real-time default tolerance (3e-5 relative gradient), cold: the same optimum to 1e-4.
  RetargetOptions fast;
  fast.restore_bone_lengths = false;
  Retargeter rt_fast(parents, student_len, fast);
  const auto& rep_fast = rt_fast.retarget(teacher.data(), ghost.data());
  std::printf("    default options: SPG %.12g (%d it, %d evaluations)\n", rep_fast.stress, rep_fast.iterations,
              rep_fast.evaluations);
  EXPECT_NEAR(rep_fast.stress, gd, 1e-4 * gd) << what;
  EXPECT_LT(rep.stress, rep.stress_baseline) << what;
}

TEST(RetargetSpg, SameStressAsGradientDescentOnRandomInstances) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 6; ++trial) {
    const RandomCase c = random_case(rng, 10 + 3 * trial, 0.3);
    expect_same_optimum(c.parents, c.teacher, c.student_len, ("random " + std::to_string(trial)).c_str());
  }
}

// Reduced CMU teacher frames and a student's reduced rest lengths.
struct CmuPair {
  kata::retarget::ReducedSkeleton teacher, student;
  kata::BvhClip teacher_clip;
  Pose frame(int f) const {
    Eigen::MatrixX3d w(teacher_clip.skeleton.joint_count(), 3);
    kata::world_positions(teacher_clip, f, w);
    Pose x(3 * teacher.source.size());
    for (size_t k = 0; k < teacher.source.size(); ++k)
      for (int c = 0; c < 3; ++c) x[3 * k + c] = w(teacher.source[k], c);
    return x;
  }
};

CmuPair cmu_pair(const std::string& teacher, const std::string& student) {
  CmuPair p;
  p.teacher_clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/" + teacher);
  const kata::BvhClip s = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/" + student);
  auto drop = kata::retarget::coincident_joints(p.teacher_clip.skeleton);
  const auto drop_s = kata::retarget::coincident_joints(s.skeleton);
  for (size_t j = 0; j < drop.size(); ++j) drop[j] = drop[j] || drop_s[j];
  p.teacher = kata::retarget::drop_joints(p.teacher_clip.skeleton, drop);
  p.student = kata::retarget::drop_joints(s.skeleton, drop);
  return p;
}

TEST(RetargetSpg, SameStressAsGradientDescentOnCmuFrames) {
  const CmuPair p = cmu_pair("05_02.bvh", "02_01.bvh");
  const auto len = kata::retarget::rest_bone_lengths(p.student.skeleton);
  for (int f : {150, 600, 1000}) {
    expect_same_optimum(p.student.skeleton.parents, p.frame(f), len, ("05_02 frame " + std::to_string(f)).c_str());
  }
  const CmuPair q = cmu_pair("09_01.bvh", "07_01.bvh");
  expect_same_optimum(q.student.skeleton.parents, q.frame(80),
                      kata::retarget::rest_bone_lengths(q.student.skeleton), "09_01 frame 80");
}

// ---- Retargeting ----

TEST(Retarget, SameSkeletonReturnsTheOriginalPose) {
  std::mt19937 rng(5);
  const RandomCase a = random_case(rng, 21, 0.0);
  // Pose b: the same tree and lengths, other directions.
  RandomCase b = random_case(rng, 21, 0.0);
  b.parents = a.parents;
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int j = 1; j < 21; ++j) {
    double d[3] = {normal(rng), normal(rng), normal(rng)};
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; ++k) b.teacher[3 * j + k] = b.teacher[3 * a.parents[j] + k] + a.teacher_len[j] * d[k] / len;
  }
  RetargetOptions opt;
  opt.solver.gradient_tolerance = 1e-10;
  opt.solver.max_iterations = 100000;
  // Without prediction the warm start is pose a itself, so the solver has to walk to pose b
  // (with prediction, on the same skeleton, the predicted start is already exact).
  opt.predict = false;
  Retargeter rt(a.parents, a.teacher_len, opt);
  Pose ghost(63);
  // Cold (from the FK baseline, which is the pose itself), then warm from a different pose.
  const auto& r1 = rt.retarget(a.teacher.data(), ghost.data());
  EXPECT_LT(r1.stress, 1e-20);
  const auto& r2 = rt.retarget(b.teacher.data(), ghost.data());
  EXPECT_TRUE(r2.warm);
  EXPECT_GT(r2.stress_start, 1.0);
  EXPECT_LT(r2.stress, 1e-12);
  // Up to rigid motion: every pairwise distance; and the alignment puts it on the teacher.
  for (int u = 0; u < 21; ++u)
    for (int v = u + 1; v < 21; ++v) EXPECT_NEAR(dist(ghost, u, v), dist(b.teacher, u, v), 1e-5);
  for (int i = 0; i < 63; ++i) EXPECT_NEAR(ghost[i], b.teacher[i], 1e-5);
  EXPECT_LT(r2.max_bone_error, 1e-12);
  // With prediction (the default) the same-skeleton warm start is exact.
  Retargeter predicted(a.parents, a.teacher_len);
  predicted.retarget(a.teacher.data(), ghost.data());
  EXPECT_LT(predicted.retarget(b.teacher.data(), ghost.data()).stress_start, 1e-20);
  for (int i = 0; i < 63; ++i) EXPECT_NEAR(ghost[i], b.teacher[i], 1e-9);
}

TEST(Retarget, RestoringStepGivesExactBoneLengthsOnRealPairs) {
  const CmuPair p = cmu_pair("05_02.bvh", "02_01.bvh");
  RetargetOptions opt;
  opt.diagnostics = true;
  Retargeter rt(p.student.skeleton, opt);
  const int n = rt.joint_count();
  Pose ghost(3 * n);
  double worst_solved = 0.0, worst = 0.0;
  for (int f = 1; f < p.teacher_clip.frame_count(); f += 4) {
    const Pose t = p.frame(f);
    const auto& r = rt.retarget(t.data(), ghost.data());
    worst_solved = std::max(worst_solved, r.max_bone_error_solved);
    worst = std::max(worst, r.max_bone_error);
    ASSERT_LE(r.stress, r.stress_baseline * (1 + 1e-9) + 1e-12) << "frame " << f;
    // The root stays on the teacher's root.
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(ghost[k], t[k], 1e-9);
  }
  EXPECT_GT(worst_solved, 0.01);  // the paper's objective alone stretches bones (issue: ~8%)
  EXPECT_LT(worst, 1e-9);         // the restoring step makes them exact
  const auto& len = rt.student_lengths();
  for (int j = 1; j < n; ++j) EXPECT_NEAR(dist(ghost, j, p.student.skeleton.parents[j]), len[j], 1e-9 * len[j]);
}

TEST(Retarget, NoAllocationPerFrame) {
  const CmuPair p = cmu_pair("05_02.bvh", "02_01.bvh");
  Retargeter rt(p.student.skeleton);
  std::vector<Pose> frames;
  for (int f = 1; f < 200; ++f) frames.push_back(p.frame(f));
  Pose ghost(3 * rt.joint_count());
  rt.retarget(frames[0].data(), ghost.data());
  const long before = kata::test::allocations();
  for (const Pose& t : frames) rt.retarget(t.data(), ghost.data());
  rt.reset();
  rt.retarget(frames[50].data(), ghost.data());  // a cold frame too
  kata::retarget::place_over_student(rt.joint_count(), frames[3].data(), ghost.data());
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under AddressSanitizer";
  EXPECT_EQ(kata::test::allocations() - before, 0);
  // The counter does see allocations (so the zero above means something).
  std::string probe(1000, 'x');
  probe += std::to_string(before);
  EXPECT_GT(kata::test::allocations() - before, 0) << probe.size();
}

// The placement's rotation from Horn's quaternion against the SVD's V U^T (Kabsch), which
// maximises trace(R H) independently: random point sets in 3-D, rotated and disturbed, of
// every spread from round to flat; and the cases it must refuse: a reflection (det H < 0) and
// nearly collinear points (the answer ill-defined), for which the SVD is taken instead.
TEST(Retarget, QuaternionPlacementMatchesTheSvd) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  int accepted = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 5 + trial % 17;
    const double flat = trial % 4 == 3 ? 0.05 : 1.0, noise = 0.02 * (trial % 5);
    Eigen::Matrix3d rot = Eigen::Quaterniond(uni(rng), uni(rng), uni(rng), uni(rng)).normalized().toRotationMatrix();
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    double bound = 0.0;
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3d a(30.0 * uni(rng), 30.0 * uni(rng), 30.0 * flat * uni(rng));
      const Eigen::Vector3d b = 1.1 * (rot * a) + Eigen::Vector3d(uni(rng), uni(rng), uni(rng)) * 30.0 * noise;
      h += a * b.transpose();
      bound += 0.5 * (a.squaredNorm() + b.squaredNorm());
    }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d kabsch = svd.matrixV() * svd.matrixU().transpose();
    double hr[9], r[9];
    for (int i = 0; i < 9; ++i) hr[i] = h(i / 3, i % 3);
    if (!(h.determinant() > 0.0)) {  // a flat, noisy set whose best fit is a reflection
      EXPECT_FALSE(kata::retarget::detail::proper_best_rotation(hr, bound, r)) << trial;
      continue;
    }
    if (!kata::retarget::detail::proper_best_rotation(hr, bound, r)) {
      // Refused only when the second singular value is small against the first.
      EXPECT_LT(svd.singularValues()[1] + svd.singularValues()[2], 2e-2 * svd.singularValues()[0]) << trial;
      continue;
    }
    ++accepted;
    Eigen::Matrix3d q;
    for (int i = 0; i < 9; ++i) q(i / 3, i % 3) = r[i];
    EXPECT_LT((q - kabsch).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
    EXPECT_LT((q.transpose() * q - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 4e-15) << trial;  // a few units in the last place
    EXPECT_NEAR(q.determinant(), 1.0, 4e-15) << trial;
  }
  std::printf("  quaternion placement: %d of 400 random sets answered (the rest refused: reflections, near rank 1)\n", accepted);
  EXPECT_GT(accepted, 380);
  // A reflection fits best: refused (det H < 0).
  double mirror[9] = {-2, 0, 0, 0, 1.5, 0, 0, 0, 1}, r[9] = {7, 7, 7, 7, 7, 7, 7, 7, 7};
  EXPECT_FALSE(kata::retarget::detail::proper_best_rotation(mirror, 10.0, r));
  EXPECT_EQ(r[0], 7.0);
  // Nearly collinear points (singular values 1, 1e-5, 1e-6): refused.
  double line[9] = {1, 0, 0, 0, 1e-5, 0, 0, 0, 1e-6};
  EXPECT_FALSE(kata::retarget::detail::proper_best_rotation(line, 1.0, r));
}

TEST(Retarget, PlaceOverStudentUndoesAYawAndATranslation) {
  std::mt19937 rng(9);
  const RandomCase c = random_case(rng, 15, 0.0);
  Pose moved = c.teacher;
  const double th = 1.1, ct = std::cos(th), st = std::sin(th);
  for (int j = 0; j < 15; ++j) {
    const double x = c.teacher[3 * j], z = c.teacher[3 * j + 2];
    moved[3 * j] = ct * x + st * z + 3.0;
    moved[3 * j + 1] = c.teacher[3 * j + 1] - 2.0;
    moved[3 * j + 2] = -st * x + ct * z + 0.5;
  }
  kata::retarget::place_over_student(15, c.teacher.data(), moved.data());
  for (int i = 0; i < 45; ++i) EXPECT_NEAR(moved[i], c.teacher[i], 1e-12);
}

// Largest per-frame joint move (CMU units) of a row-major posture sequence.
double largest_jump(const Pose& a, const Pose& b) {
  double worst = 0.0;
  for (size_t j = 0; j < a.size() / 3; ++j)
    worst = std::max(worst, std::sqrt(std::pow(a[3 * j] - b[3 * j], 2) + std::pow(a[3 * j + 1] - b[3 * j + 1], 2) +
                                      std::pow(a[3 * j + 2] - b[3 * j + 2], 2)));
  return worst;
}

TEST(Retarget, WarmStreamIsSmoothAndCheap) {
  // A walk and a dance (whose warm stream changes basin several times) on other subjects' bones:
  // the ghost's largest per-frame joint move stays close to the teacher's own largest move.
  for (const auto& files : {std::pair<const char*, const char*>{"02_01.bvh", "07_01.bvh"}, {"05_02.bvh", "02_01.bvh"}}) {
    const CmuPair p = cmu_pair(files.first, files.second);
    Retargeter rt(p.student.skeleton);
    Pose ghost(3 * rt.joint_count()), prev_ghost, prev_t;
    double ghost_jump = 0.0, teacher_jump = 0.0;
    long iterations = 0;
    int frames = 0;
    for (int f = 1; f < p.teacher_clip.frame_count(); ++f) {
      const Pose t = p.frame(f);
      iterations += rt.retarget(t.data(), ghost.data()).iterations;
      ++frames;
      if (!prev_ghost.empty()) {
        ghost_jump = std::max(ghost_jump, largest_jump(ghost, prev_ghost));
        teacher_jump = std::max(teacher_jump, largest_jump(t, prev_t));
      }
      prev_ghost = ghost;
      prev_t = t;
    }
    std::printf("  %s -> %s: largest joint jump ghost %.3f, teacher %.3f units; %.1f iterations per frame\n", files.first,
                files.second, ghost_jump, teacher_jump, static_cast<double>(iterations) / frames);
    EXPECT_LT(ghost_jump, 1.3 * teacher_jump) << files.first;  // no flips
    EXPECT_LT(static_cast<double>(iterations) / frames, 30.0) << files.first;
  }
}

// One Workspace for retargeters of two joint sets (the CMU set, 21 joints, and the GPD set, 16),
// frame by frame in turn, as a runtime worker runs its streams: every ghost and report equals
// the retargeters' own workspaces', bit for bit, basin checks included.
TEST(Retarget, OneWorkspaceForManyRetargetersChangesNoGhost) {
  const CmuPair a = cmu_pair("02_01.bvh", "07_01.bvh");
  const kata::BvhClip teacher = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/05_03.bvh");
  const kata::BvhClip student = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh");
  const auto sel = kata::retarget::select_joints(teacher.skeleton, student.skeleton, "gpd");
  const auto make_b = [&] {
    return Retargeter(sel.parents, kata::retarget::selected_rest_lengths(student.skeleton, sel), RetargetOptions{},
                      kata::retarget::selected_rest_directions(student.skeleton, sel));
  };
  Retargeter own_a(a.student.skeleton), shared_a(a.student.skeleton), own_b = make_b(), shared_b = make_b();
  ASSERT_NE(own_a.joint_count(), own_b.joint_count());
  Retargeter::Workspace ws;
  ws.fit(std::max(own_a.joint_count(), own_b.joint_count()));
  Pose g1(3 * own_a.joint_count()), g2(g1.size()), h1(3 * own_b.joint_count()), h2(h1.size()), tb(h1.size());
  Eigen::MatrixX3d w(teacher.skeleton.joint_count(), 3);
  const int frames = std::min(a.teacher_clip.frame_count(), teacher.frame_count());
  int checks = 0;
  for (int f = 1; f < std::min(frames, 400); ++f) {
    const Pose ta = a.frame(f);
    const kata::retarget::RetargetReport ra = own_a.retarget(ta.data(), g1.data());
    const kata::retarget::RetargetReport rs = shared_a.retarget(ta.data(), g2.data(), ws);
    ASSERT_EQ(g1, g2) << "frame " << f;
    ASSERT_EQ(ra.iterations, rs.iterations) << "frame " << f;
    ASSERT_EQ(ra.stress, rs.stress) << "frame " << f;
    checks += ra.cold_checked;
    kata::world_positions(teacher, f, w);
    kata::retarget::gather_positions(w, sel, tb.data());
    const kata::retarget::RetargetReport rb = own_b.retarget(tb.data(), h1.data());
    const kata::retarget::RetargetReport rt = shared_b.retarget(tb.data(), h2.data(), ws);
    ASSERT_EQ(h1, h2) << "frame " << f;
    ASSERT_EQ(rb.iterations, rt.iterations) << "frame " << f;
  }
  EXPECT_GT(checks, 20);  // the basin check's solve ran in the shared scratch too
}

}  // namespace

namespace {

// ---- Ghost BVH ----

TEST(RetargetGhostBvh, ForwardKinematicsOfTheWrittenClipReproducesTheGhost) {
  const kata::BvhClip teacher = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/05_03.bvh");
  const kata::BvhClip student = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/09_01.bvh");
  const auto sel = kata::retarget::select_joints(teacher.skeleton, student.skeleton, "cmu");
  Retargeter rt(sel.parents, kata::retarget::selected_rest_lengths(student.skeleton, sel), RetargetOptions{},
                kata::retarget::selected_rest_directions(student.skeleton, sel));
  kata::retarget::GhostBvh writer(teacher, student, sel);
  const int n = rt.joint_count();
  kata::BvhClip ghost_clip = student;
  ghost_clip.frame_time = teacher.frame_time;
  ghost_clip.motion.clear();
  std::vector<Pose> ghosts;
  Eigen::MatrixX3d w(teacher.skeleton.joint_count(), 3);
  Pose t(3 * n), g(3 * n);
  std::vector<double> row(static_cast<size_t>(student.channel_count));
  for (int f = 1; f < teacher.frame_count(); f += 3) {
    kata::world_positions(teacher, f, w);
    kata::retarget::gather_positions(w, sel, t.data());
    rt.retarget(t.data(), g.data());
    writer.motion_row(teacher, f, g.data(), row.data());
    ghost_clip.motion.insert(ghost_clip.motion.end(), row.begin(), row.end());
    ghosts.push_back(g);
  }
  // Through the file, as Blender would read it.
  const std::string path = kata::test::temp_path("ghost_test.bvh");
  kata::write_bvh(path, ghost_clip);
  const kata::BvhClip back = kata::load_bvh(path);
  ASSERT_EQ(back.frame_count(), static_cast<int>(ghosts.size()));
  double worst = 0.0, worst_angle_step = 0.0;
  for (int f = 0; f < back.frame_count(); ++f) {
    kata::world_positions(back, f, w);
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::fabs(w(sel.source[k], c) - ghosts[f][3 * k + c]));
    if (f > 0) {
      for (int i = 0; i < back.channel_count; ++i)
        worst_angle_step = std::max(worst_angle_step, std::fabs(back.frame(f)[i] - back.frame(f - 1)[i]));
    }
  }
  EXPECT_LT(worst, 1e-6);  // CMU units (1 unit = 5.6 cm)
  // Continuous curves: no 360-degree wraps or Euler-branch flips between frames 3/120 s apart.
  EXPECT_LT(worst_angle_step, 90.0);
  std::printf("  ghost BVH: max FK error %.3g units, largest channel step %.1f\n", worst, worst_angle_step);
}

}  // namespace
