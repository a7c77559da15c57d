// The SPG iteration (spg.hpp), included by spg.cpp (baseline), spg_avx2.cpp (x86-64-v3) and
// spg_avx512.cpp (x86-64-v4) after their stress kernel: each translation unit compiles its own
// copy of the solver around its own kernel, so the solver's vector loops (dot products over the
// 3 x joints unknowns, the quasi-Newton recursion) use that unit's instruction set and the kernel
// is a direct call. Internal linkage on purpose (one copy per including translation unit).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "retarget/spg.hpp"

namespace kata::retarget {
namespace {  // NOLINT: one copy per including translation unit (different -march)

// Four double lanes (GCC/Clang vector extensions), lowered to the unit's instruction set. Never
// passed or returned by value (that would change the ABI between the units).
typedef double Lanes4 __attribute__((vector_size(32)));

// Sixteen partial sums in four independent chains: one serial chain of 3 x joints dependent
// additions (4 cycles each) was a large part of an SPG iteration, and the quasi-Newton
// recursion is a chain of dot products.
inline double dot(const double* a, const double* b, int n) {
  Lanes4 s0 = {}, s1 = {}, s2 = {}, s3 = {};
  int i = 0;
  for (; i + 16 <= n; i += 16) {
    Lanes4 a0, a1, a2, a3, b0, b1, b2, b3;
    std::memcpy(&a0, a + i, sizeof a0);
    std::memcpy(&a1, a + i + 4, sizeof a1);
    std::memcpy(&a2, a + i + 8, sizeof a2);
    std::memcpy(&a3, a + i + 12, sizeof a3);
    std::memcpy(&b0, b + i, sizeof b0);
    std::memcpy(&b1, b + i + 4, sizeof b1);
    std::memcpy(&b2, b + i + 8, sizeof b2);
    std::memcpy(&b3, b + i + 12, sizeof b3);
    s0 += a0 * b0;
    s1 += a1 * b1;
    s2 += a2 * b2;
    s3 += a3 * b3;
  }
  for (; i + 4 <= n; i += 4) {
    Lanes4 a0, b0;
    std::memcpy(&a0, a + i, sizeof a0);
    std::memcpy(&b0, b + i, sizeof b0);
    s0 += a0 * b0;
  }
  double t = 0.0;
  for (; i < n; ++i) t += a[i] * b[i];
  const Lanes4 s = (s0 + s1) + (s2 + s3);
  return ((s[0] + s[2]) + (s[1] + s[3])) + t;
}

// d = -H g, H the inverse-Hessian estimate of the held curvature pairs: the L-BFGS two-loop
// recursion (Nocedal & Wright, algorithm 7.4) over the ring, newest pair first, with the initial
// inverse Hessian gamma I, gamma = s.y / y.y of the newest pair.
inline void quasi_newton_direction(detail::SpgWork& w, const double* g, double* d) {
  constexpr int kRing = detail::SpgWork::kMaxCurvaturePairs;
  const int n = w.size;
  double alpha[kRing];
  for (int i = 0; i < n; ++i) d[i] = g[i];
  for (int k = 0, at = w.newest; k < w.pairs; ++k, at = (at + kRing - 1) % kRing) {
    const double* s = &w.s[static_cast<size_t>(at) * n];
    const double* y = &w.y[static_cast<size_t>(at) * n];
    const double a = w.rho[at] * dot(s, d, n);
    alpha[at] = a;
    for (int i = 0; i < n; ++i) d[i] -= a * y[i];
  }
  const double gamma = w.gamma;
  for (int i = 0; i < n; ++i) d[i] *= gamma;
  for (int k = 0, at = (w.newest + kRing - w.pairs + 1) % kRing; k < w.pairs; ++k, at = (at + 1) % kRing) {
    const double* s = &w.s[static_cast<size_t>(at) * n];
    const double* y = &w.y[static_cast<size_t>(at) * n];
    const double c = alpha[at] - w.rho[at] * dot(y, d, n);
    for (int i = 0; i < n; ++i) d[i] += c * s[i];
  }
  for (int i = 0; i < n; ++i) d[i] = -d[i];
}

// Minimises sigma from x with the kernel `Stress` (spg.hpp, SpgSolver::minimize).
template <double (*Stress)(const StressInstance&, const double*, double*)>
SpgResult spg_minimize(detail::SpgWork& w, const StressInstance& in, double* x, const SpgOptions& opt) {
  constexpr int kRing = detail::SpgWork::kMaxCurvaturePairs;
  const int n = w.size;
  const int memory = std::clamp(opt.memory, 1, static_cast<int>(w.history.size()));
  double* g = w.g.data();
  double* xn = w.xn.data();
  double* gn = w.gn.data();
  double* best = w.best.data();
  double* d = w.d.data();
  double* history = w.history.data();

  SpgResult r;
  double f = Stress(in, x, g);
  r.evaluations = 1;
  r.stress_start = f;
  double best_f = f;
  std::memcpy(best, x, sizeof(double) * n);
  double scale = 0.0;
  for (int p = 0; p < in.pairs; ++p) scale += in.weight[p] * in.delta[p] * in.delta[p];
  const double tolerance = opt.gradient_tolerance * std::sqrt(scale);
  for (int i = 0; i < memory; ++i) history[i] = f;
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
  const int curvature = std::clamp(opt.curvature_pairs, 0, kRing);
  if (!opt.keep_curvature || curvature == 0) w.pairs = 0;
  w.pairs = std::min(w.pairs, curvature);

  while (true) {
    if (gnorm <= tolerance) {
      r.converged = true;
      break;
    }
    if (r.iterations >= opt.max_iterations) break;
    // Direction d = -lambda g; g.d = -lambda |g|^2. With curvature pairs, the quasi-Newton
    // direction instead, when it descends.
    double gtd = -lambda * gnorm * gnorm;
    bool quasi_newton = false;
    if (w.pairs > 0) {
      quasi_newton_direction(w, g, d);
      const double qtd = dot(g, d, n);
      quasi_newton = qtd < 0.0;
      if (quasi_newton) gtd = qtd;
    }
    double fmax = history[0];
    for (int i = 1; i < memory; ++i) fmax = std::max(fmax, history[i]);
    double alpha = 1.0;
    double fn = 0.0;
    bool accepted = false;
    for (int trial = 0; trial < opt.max_backtracks; ++trial) {
      if (quasi_newton) {
        for (int i = 0; i < n; ++i) xn[i] = x[i] + alpha * d[i];
      } else {
        for (int i = 0; i < n; ++i) xn[i] = x[i] - alpha * lambda * g[i];
      }
      fn = Stress(in, xn, gn);
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
    // A pair enters the curvature memory only with positive curvature (s.y > 0; the stress is
    // not convex), so the inverse-Hessian estimate stays positive definite.
    if (curvature > 0 && sty > 1e-12 * sts) {
      w.newest = (w.newest + 1) % kRing;
      std::memcpy(&w.s[static_cast<size_t>(w.newest) * n], x, sizeof(double) * n);
      std::memcpy(&w.y[static_cast<size_t>(w.newest) * n], g, sizeof(double) * n);
      w.rho[w.newest] = 1.0 / sty;
      w.gamma = sty / dot(g, g, n);
      w.pairs = std::min(w.pairs + 1, curvature);
    }
    std::memcpy(x, xn, sizeof(double) * n);
    std::memcpy(g, gn, sizeof(double) * n);
    f = fn;
    gnorm = std::sqrt(dot(g, g, n));
    ++r.iterations;
    head = (head + 1) % memory;
    history[head] = f;
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

}  // namespace
}  // namespace kata::retarget
