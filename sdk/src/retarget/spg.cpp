// Weighted stress, its gradient and the non-monotone spectral gradient minimiser (see spg.hpp).
#include "retarget/spg.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/cpu.hpp"
#include "common/error.hpp"
#include "retarget/stress_kernel.hpp"

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

double stress_scale(const StressInstance& in) {
  double s = 0.0;
  for (int p = 0; p < in.pairs; ++p) s += in.weight[p] * in.delta[p] * in.delta[p];
  return std::sqrt(s);
}

SpgSolver::SpgSolver(int joints)
    : size_(3 * joints), g_(size_), xn_(size_), gn_(size_), best_(size_), history_(64) {
  if (joints < 1) throw Error(ErrorKind::kInvalidArgument, "SpgSolver: joints must be positive");
}

namespace {
// Four partial sums: one serial chain of 3 x joints dependent additions (4 cycles each) was a
// large part of an SPG iteration; four chains run side by side and vectorise.
double dot(const double* a, const double* b, int n) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
}
}  // namespace

SpgResult SpgSolver::minimize(const StressInstance& in, double* x, const SpgOptions& opt) {
  if (3 * in.joints != size_) throw Error(ErrorKind::kInvalidArgument, "SpgSolver: joint count mismatch");
  if (in.pairs != in.joints * (in.joints - 1) / 2) {
    throw Error(ErrorKind::kInvalidArgument, "SpgSolver: the instance must hold every pair, in lexicographic order");
  }
  const int n = size_;
  const int memory = std::clamp(opt.memory, 1, static_cast<int>(history_.size()));
  double* g = g_.data();
  double* xn = xn_.data();
  double* gn = gn_.data();
  double* best = best_.data();

  SpgResult r;
  double f = stress(in, x, g);
  r.evaluations = 1;
  r.stress_start = f;
  double best_f = f;
  std::memcpy(best, x, sizeof(double) * n);
  const double tolerance = opt.gradient_tolerance * stress_scale(in);
  for (int i = 0; i < memory; ++i) history_[i] = f;
  int head = 0;

  double gnorm = std::sqrt(dot(g, g, n));
  double lambda = opt.initial_step;
  if (!(lambda > 0.0)) {
    double ginf = 0.0;
    for (int i = 0; i < n; ++i) ginf = std::max(ginf, std::fabs(g[i]));
    lambda = ginf > 0.0 ? 1.0 / ginf : 1.0;
  }
  lambda = std::clamp(lambda, opt.step_min, opt.step_max);
  double best_gnorm = gnorm;

  while (true) {
    if (gnorm <= tolerance) {
      r.converged = true;
      break;
    }
    if (r.iterations >= opt.max_iterations) break;
    // Direction d = -lambda g; g.d = -lambda |g|^2.
    const double gtd = -lambda * gnorm * gnorm;
    double fmax = history_[0];
    for (int i = 1; i < memory; ++i) fmax = std::max(fmax, history_[i]);
    double alpha = 1.0;
    double fn = 0.0;
    bool accepted = false;
    for (int trial = 0; trial < opt.max_backtracks; ++trial) {
      for (int i = 0; i < n; ++i) xn[i] = x[i] - alpha * lambda * g[i];
      fn = stress(in, xn, gn);
      ++r.evaluations;
      if (fn <= fmax + opt.gamma * alpha * gtd) {
        accepted = true;
        break;
      }
      // Safeguarded quadratic interpolation (SPG2), else halve.
      const double denom = fn - f - alpha * gtd;
      const double a_tmp = denom > 0.0 ? -0.5 * alpha * alpha * gtd / denom : -1.0;
      alpha = (a_tmp >= 0.1 && a_tmp <= 0.9 * alpha) ? a_tmp : 0.5 * alpha;
    }
    if (!accepted) break;  // no decrease possible at this precision: x is as good as it gets
    // Spectral (Barzilai-Borwein) step from s = xn - x, y = gn - g. x and g are overwritten
    // below, so s and y go through them (x <- s, g <- y) and the sums reuse dot().
    for (int i = 0; i < n; ++i) {
      x[i] = xn[i] - x[i];
      g[i] = gn[i] - g[i];
    }
    const double sts = dot(x, x, n), sty = dot(x, g, n);
    lambda = sty <= 0.0 ? opt.step_max : std::clamp(sts / sty, opt.step_min, opt.step_max);
    std::memcpy(x, xn, sizeof(double) * n);
    std::memcpy(g, gn, sizeof(double) * n);
    f = fn;
    gnorm = std::sqrt(dot(g, g, n));
    ++r.iterations;
    head = (head + 1) % memory;
    history_[head] = f;
    if (f < best_f) {
      best_f = f;
      best_gnorm = gnorm;
      std::memcpy(best, x, sizeof(double) * n);
    }
  }
  // The non-monotone search may end above the best point seen: return the best.
  if (best_f < f) {
    std::memcpy(x, best, sizeof(double) * n);
    f = best_f;
    gnorm = best_gnorm;
  }
  r.stress = f;
  r.gradient_norm = gnorm;
  r.last_step = lambda;
  return r;
}

}  // namespace kata::retarget
