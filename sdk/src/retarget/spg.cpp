// Weighted stress, its gradient and the non-monotone spectral gradient minimiser (see spg.hpp).
#include "retarget/spg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "common/cpu.hpp"
#include "common/error.hpp"
#include "retarget/distance.hpp"
#include "retarget/stress_kernel.hpp"
#include "retarget/spg_solver.inl"

namespace kata::retarget {

double detail::stress_portable(const StressInstance& in, const double* x, double* grad) {
  return stress_kernel(in, x, grad);
}

double stress(const StressInstance& in, const double* x, double* grad) {
  // The kernels built for x86-64-v4 (spg_avx512.cpp) and x86-64-v3 (spg_avx2.cpp), when the CPU has them.
  static const auto kernel = cpu_has_avx512() ? detail::stress_avx512
                             : cpu_has_avx2() ? detail::stress_avx2
                                              : detail::stress_portable;
  return kernel(in, x, grad);
}

void detail::targets_portable(int n, const double* t, const double* tau_s, const double* tau_t, double* delta) {
  targets_kernel(n, t, tau_s, tau_t, delta);
}

void detail::targets(int n, const double* t, const double* tau_s, const double* tau_t, double* delta) {
  static const auto kernel = cpu_has_avx512() ? detail::targets_avx512
                             : cpu_has_avx2() ? detail::targets_avx2
                                              : detail::targets_portable;
  kernel(n, t, tau_s, tau_t, delta);
}

double stress_scale(const StressInstance& in) {
  double s = 0.0;
  for (int p = 0; p < in.pairs; ++p) s += in.weight[p] * in.delta[p] * in.delta[p];
  return std::sqrt(s);
}

detail::SpgWork::SpgWork(int joints)
    : size(3 * joints),
      padded((3 * joints + 7) / 8 * 8),
      x(padded),
      g(padded),
      xn(padded),
      gn(padded),
      best(padded),
      d(padded),
      history(64),
      s(static_cast<size_t>(kRing) * padded),
      y(static_cast<size_t>(kRing) * padded),
      blocked(joints) {
  if (joints < 1) throw Error(ErrorKind::kInvalidArgument, "SpgSolver: joints must be positive");
}

detail::BlockedPairs::BlockedPairs(int n)
    : joints(n), blocks((n + kLanes - 1) / kLanes), steps(4 * blocks + 4 * blocks * (blocks - 1)) {
  pair.assign(static_cast<size_t>(steps) * kLanes, -1);
  int step = 0;
  const auto lane_pair = [&](int a, int b) { return a < n && b < n ? pair_index(n, a, b) : -1; };
  for (int bi = 0; bi < blocks; ++bi) {
    for (int k = 1; k <= 4; ++k, ++step)
      for (int l = 0; l < (k == 4 ? 4 : kLanes); ++l)
        pair[static_cast<size_t>(step) * kLanes + l] = lane_pair(bi * kLanes + l, bi * kLanes + (l + k) % kLanes);
    for (int bj = bi + 1; bj < blocks; ++bj)
      for (int k = 0; k < kLanes; ++k, ++step)
        for (int l = 0; l < kLanes; ++l)
          pair[static_cast<size_t>(step) * kLanes + l] = lane_pair(bi * kLanes + l, bj * kLanes + (l + k) % kLanes);
  }
  // + 8: room to align the start on 64 bytes.
  storage_.assign(2 * lanes() + (48 + 24) * static_cast<size_t>(blocks) + 8, 0.0);
}

double* detail::BlockedPairs::aligned() {
  const auto base = reinterpret_cast<std::uintptr_t>(storage_.data());
  return storage_.data() + (64 - base % 64) % 64 / sizeof(double);
}

void detail::BlockedPairs::gather(const StressInstance& in) {
  double* w = weight();
  double* d = delta();
  for (size_t i = 0; i < lanes(); ++i) {
    const int p = pair[i];
    w[i] = p >= 0 ? in.weight[p] : 0.0;
    d[i] = p >= 0 ? in.delta[p] : 0.0;
  }
}

SpgSolver::SpgSolver(int joints) : work_(joints) {}

SpgResult detail::minimize_portable(SpgWork& work, const StressInstance& in, double* x, const SpgOptions& opt) {
  return spg_minimize(work, in, x, opt, detail::stress_portable);
}

SpgResult SpgSolver::minimize(const StressInstance& in, double* x, const SpgOptions& opt) {
  if (3 * in.joints != work_.size) throw Error(ErrorKind::kInvalidArgument, "SpgSolver: joint count mismatch");
  if (in.pairs != in.joints * (in.joints - 1) / 2) {
    throw Error(ErrorKind::kInvalidArgument, "SpgSolver: the instance must hold every pair, in lexicographic order");
  }
  static const auto solve = cpu_has_avx512() ? detail::minimize_avx512
                            : cpu_has_avx2() ? detail::minimize_avx2
                                             : detail::minimize_portable;
  return solve(work_, in, x, opt);
}

SpgResult SpgSolver::minimize(const StressInstance& in, double* x, const SpgOptions& opt, SpgScratch& scratch,
                              bool with_pairs) {
  detail::SpgWork& w = work_;
  // Sized for this solver (never below it: history's length is the line search's memory bound,
  // so it is exactly the solver's); zero-filled when the joint count changes (padding reads 0).
  if (scratch.size != w.size) {
    const auto fit = [](std::vector<double>& v, std::size_t n) { v.assign(std::max(v.size(), n), 0.0); };
    for (std::vector<double>* v : {&scratch.x, &scratch.g, &scratch.xn, &scratch.gn, &scratch.best, &scratch.d})
      fit(*v, static_cast<std::size_t>(w.padded));
    scratch.history.assign(w.history.size(), 0.0);
    fit(scratch.s, w.s.size());
    fit(scratch.y, w.y.size());
    fit(scratch.blocked, w.blocked.storage_size());
    scratch.size = w.size;
  }
  const auto exchange = [&] {
    w.x.swap(scratch.x);
    w.g.swap(scratch.g);
    w.xn.swap(scratch.xn);
    w.gn.swap(scratch.gn);
    w.best.swap(scratch.best);
    w.d.swap(scratch.d);
    w.history.swap(scratch.history);
    w.blocked.swap_storage(scratch.blocked);
    if (with_pairs) {
      w.s.swap(scratch.s);
      w.y.swap(scratch.y);
    }
  };
  exchange();
  SpgResult r;
  try {
    r = minimize(in, x, opt);
  } catch (...) {
    exchange();
    throw;
  }
  exchange();
  return r;
}

void detail::rotate_pairs_portable(SpgWork& work, const double* r) { rotate_pairs(work, r); }

void SpgSolver::rotate_curvature(const double* r) {
  static const auto rotate = cpu_has_avx512() ? detail::rotate_pairs_avx512
                             : cpu_has_avx2() ? detail::rotate_pairs_avx2
                                              : detail::rotate_pairs_portable;
  rotate(work_, r);
}

}  // namespace kata::retarget
