// Weighted stress, its gradient and the non-monotone spectral gradient minimiser (see spg.hpp).
#include "retarget/spg.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/cpu.hpp"
#include "common/error.hpp"
#include "retarget/stress_kernel.hpp"

namespace kata::retarget {

// The AVX2 + FMA build of the kernel (spg_avx2.cpp), for CPUs that have it.
double stress_avx2(const StressInstance& in, const double* x, double* grad);

double stress(const StressInstance& in, const double* x, double* grad) {
  static const bool avx2 = cpu_has_avx2();
  return avx2 ? stress_avx2(in, x, grad) : stress_kernel(in, x, grad);
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
double dot(const double* a, const double* b, int n) {
  double s = 0.0;
  for (int i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
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
    // Spectral (Barzilai-Borwein) step from s = xn - x, y = gn - g.
    double sts = 0.0, sty = 0.0;
    for (int i = 0; i < n; ++i) {
      const double s = xn[i] - x[i];
      const double y = gn[i] - g[i];
      sts += s * s;
      sty += s * y;
    }
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
