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

// a.b over n doubles, n a multiple of 8 (the solver's buffers are padded with zeros to one:
// SpgWork::padded), in eight partial sums: one serial chain of 3 x joints dependent additions
// (4 cycles each) was a large part of an SPG iteration.
inline double dot(const double* a, const double* b, int n) {
  Lanes4 s0 = {}, s1 = {};
  for (int i = 0; i < n; i += 8) {
    Lanes4 a0, a1, b0, b1;
    std::memcpy(&a0, a + i, sizeof a0);
    std::memcpy(&a1, a + i + 4, sizeof a1);
    std::memcpy(&b0, b + i, sizeof b0);
    std::memcpy(&b1, b + i + 4, sizeof b1);
    s0 += a0 * b0;
    s1 += a1 * b1;
  }
  const Lanes4 t = s0 + s1;
  return (t[0] + t[2]) + (t[1] + t[3]);
}

// d = -H g, H the inverse-Hessian estimate of the held curvature pairs in the compact form of
// Byrd, Nocedal and Schnabel (1994, theorem 2.2) with H0 = gamma I, gamma = s.y / y.y of the
// newest pair: H g = gamma g + S p + gamma Y q, q = -R^-1 S^T g,
// p = R^-T ((D + gamma Y^T Y) R^-1 S^T g - gamma Y^T g), R the upper triangle of S^T Y (pairs
// oldest first), D its diagonal. The same direction as the two-loop recursion, but its 2m dot
// products with g are independent of each other (the recursion chains them: each waits for the
// previous update of the direction), and S^T Y, Y^T Y are kept as pairs arrive.
inline void quasi_newton_direction(detail::SpgWork& w, const double* g, double* d) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int n = w.padded, m = w.pairs;
  int slot[kRing];  // chronological: slot[0] the oldest pair
  for (int i = 0; i < m; ++i) slot[i] = (w.newest + kRing - (m - 1 - i)) % kRing;
  double a[kRing], b[kRing], q[kRing], p[kRing];
  for (int i = 0; i < m; ++i) {
    a[i] = dot(&w.s[static_cast<size_t>(slot[i]) * n], g, n);
    b[i] = dot(&w.y[static_cast<size_t>(slot[i]) * n], g, n);
  }
  const double gamma = w.gamma;
  for (int i = m - 1; i >= 0; --i) {  // R q = -a
    double t = -a[i];
    for (int j = i + 1; j < m; ++j) t -= w.sy[slot[i]][slot[j]] * q[j];
    q[i] = t * w.rho[slot[i]];
  }
  for (int i = 0; i < m; ++i) {  // R^T p = -(D + gamma Y^T Y) q - gamma b
    double t = -w.sy[slot[i]][slot[i]] * q[i] - gamma * b[i];
    for (int j = 0; j < m; ++j) t -= gamma * w.yy[slot[i]][slot[j]] * q[j];
    for (int j = 0; j < i; ++j) t -= w.sy[slot[j]][slot[i]] * p[j];
    p[i] = t * w.rho[slot[i]];
  }
  for (int k = 0; k < n; ++k) d[k] = -gamma * g[k];
  for (int i = 0; i < m; ++i) {
    const double* s = &w.s[static_cast<size_t>(slot[i]) * n];
    const double* y = &w.y[static_cast<size_t>(slot[i]) * n];
    const double ps = p[i], qy = gamma * q[i];
    for (int k = 0; k < n; ++k) d[k] -= ps * s[k] + qy * y[k];
  }
}

// Makes the pair in the ring slot after the newest (written there by the caller; never a held
// slot: the ring has one more slot than pairs are held) the newest, dropping the oldest when
// `limit` are held, with its products with the other held pairs: s_i.y (older s_i) and y_i.y.
inline void add_curvature_pair(detail::SpgWork& w, double sty, double yty, int limit) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int n = w.padded;
  const int held = std::min(w.pairs, limit - 1);  // the older pairs that stay
  const int slot = (w.newest + 1) % kRing;
  const double* y = &w.y[static_cast<size_t>(slot) * n];
  for (int i = 0; i < held; ++i) {
    const int other = (w.newest + kRing - i) % kRing;
    w.sy[other][slot] = dot(&w.s[static_cast<size_t>(other) * n], y, n);
    const double yy = dot(&w.y[static_cast<size_t>(other) * n], y, n);
    w.yy[other][slot] = yy;
    w.yy[slot][other] = yy;
  }
  w.sy[slot][slot] = sty;
  w.rho[slot] = 1.0 / sty;  // the triangular solves multiply (a division is a long latency in their chain)
  w.yy[slot][slot] = yty;
  w.gamma = sty / yty;
  w.newest = slot;
  w.pairs = held + 1;
}

// Applies the orthogonal 3 x 3 map r (row-major) to every joint's (x, y, z) of every held
// curvature pair (SpgSolver::rotate_curvature). The products s_i.y_j and y_i.y_j do not change.
inline void rotate_pairs(detail::SpgWork& w, const double* r) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int n = w.padded, joints = w.size / 3;
  for (int k = 0, at = w.newest; k < w.pairs; ++k, at = (at + kRing - 1) % kRing) {
    for (double* v : {&w.s[static_cast<size_t>(at) * n], &w.y[static_cast<size_t>(at) * n]}) {
      double* vx = v;
      double* vy = v + joints;
      double* vz = v + 2 * joints;
#pragma omp simd
      for (int j = 0; j < joints; ++j) {
        const double a = vx[j], b = vy[j], c = vz[j];
        vx[j] = r[0] * a + r[1] * b + r[2] * c;
        vy[j] = r[3] * a + r[4] * b + r[5] * c;
        vz[j] = r[6] * a + r[7] * b + r[8] * c;
      }
    }
  }
}

// Minimises sigma from x with the kernel `Stress` (spg.hpp, SpgSolver::minimize). The iterate
// and gradient live in the padded work buffers and change places with the trial point by pointer
// swaps; the best point is copied only when a non-monotone step leaves it.
template <double (*Stress)(const StressInstance&, const double*, double*)>
SpgResult spg_minimize(detail::SpgWork& w, const StressInstance& in, double* x_out, const SpgOptions& opt) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int n = w.padded;
  const int memory = std::clamp(opt.memory, 1, static_cast<int>(w.history.size()));
  double* x = w.x.data();
  double* g = w.g.data();
  double* xn = w.xn.data();
  double* gn = w.gn.data();
  double* best = w.best.data();
  double* d = w.d.data();
  double* history = w.history.data();
  std::memcpy(x, x_out, sizeof(double) * w.size);  // the padding stays 0 in every buffer

  SpgResult r;
  double f = Stress(in, x, g);
  r.evaluations = 1;
  r.stress_start = f;
  double best_f = f;
  bool best_is_x = true;  // else the best point is in `best`
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
  const int curvature = std::clamp(opt.curvature_pairs, 0, static_cast<int>(detail::SpgWork::kMaxCurvaturePairs));
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
    // s = xn - x and y = gn - g, written straight into the ring's next slot (committed as a
    // curvature pair below, or overwritten next time), with the Barzilai-Borwein sums.
    const int slot = (w.newest + 1) % kRing;
    double* s = &w.s[static_cast<size_t>(slot) * n];
    double* y = &w.y[static_cast<size_t>(slot) * n];
    for (int i = 0; i < n; ++i) {
      s[i] = xn[i] - x[i];
      y[i] = gn[i] - g[i];
    }
    const double sts = dot(s, s, n), sty = dot(s, y, n);
    lambda = sty <= 0.0 ? opt.step_max : std::clamp(sts / sty, opt.step_min, opt.step_max);
    // A pair enters the curvature memory only with positive curvature (s.y > 0; the stress is
    // not convex), so the inverse-Hessian estimate stays positive definite.
    if (curvature > 0 && sty > 1e-12 * sts) add_curvature_pair(w, sty, dot(y, y, n), curvature);
    if (!(fn < best_f) && best_is_x) {
      std::memcpy(best, x, sizeof(double) * n);  // a non-monotone step leaves the best point
      best_is_x = false;
    }
    std::swap(x, xn);
    std::swap(g, gn);
    f = fn;
    gnorm = std::sqrt(dot(g, g, n));
    ++r.iterations;
    head = (head + 1) % memory;
    history[head] = f;
    if (f < best_f) {
      best_f = f;
      best_gnorm = gnorm;
      best_is_x = true;
    }
  }
  // The non-monotone search may end above the best point seen: return the best.
  std::memcpy(x_out, best_is_x ? x : best, sizeof(double) * w.size);
  if (!best_is_x) {
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
