// Weighted stress, its gradient and the non-monotone spectral gradient minimiser (see spg.hpp).
#include "retarget/spg.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/cpu.hpp"
#include "common/error.hpp"
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
      y(static_cast<size_t>(kRing) * padded) {
  if (joints < 1) throw Error(ErrorKind::kInvalidArgument, "SpgSolver: joints must be positive");
}

SpgSolver::SpgSolver(int joints) : work_(joints) {}

SpgResult detail::minimize_portable(SpgWork& work, const StressInstance& in, double* x, const SpgOptions& opt) {
  return spg_minimize<detail::stress_portable>(work, in, x, opt);
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

void SpgSolver::rotate_curvature(const double* r) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int n = work_.padded, joints = work_.size / 3;
  for (int k = 0, at = work_.newest; k < work_.pairs; ++k, at = (at + kRing - 1) % kRing) {
    for (double* v : {&work_.s[static_cast<size_t>(at) * n], &work_.y[static_cast<size_t>(at) * n]}) {
      for (int j = 0; j < joints; ++j) {
        const double a = v[j], b = v[joints + j], c = v[2 * joints + j];
        v[j] = r[0] * a + r[1] * b + r[2] * c;
        v[joints + j] = r[3] * a + r[4] * b + r[5] * c;
        v[2 * joints + j] = r[6] * a + r[7] * b + r[8] * c;
      }
    }
  }
  // The products s_i.y_j and y_i.y_j are invariant under an orthogonal map.
}

}  // namespace kata::retarget
