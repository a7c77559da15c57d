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

// Eight double lanes (GCC/Clang vector extensions), never passed or returned by value across
// units (that would change the ABI between them). With AVX-512 one native 512-bit vector; else
// two 4-lane vectors (lowered to two 256-bit or four 128-bit registers): a 64-byte vector type
// in a unit without AVX-512 went through the stack at every load (the AVX2 solve 2.5x slower).
#if defined(__AVX512F__)
typedef double Lanes8 __attribute__((vector_size(64)));
inline void load(Lanes8& v, const double* p) { std::memcpy(&v, p, sizeof v); }
inline void store(double* p, const Lanes8& v) { std::memcpy(p, &v, sizeof v); }
// The sum of a dot product's eight partial sums, in a fixed order.
inline double reduce(const Lanes8& s) {
  const double t0 = s[0] + s[4], t1 = s[1] + s[5], t2 = s[2] + s[6], t3 = s[3] + s[7];
  return (t0 + t2) + (t1 + t3);
}
#else
typedef double Lanes4 __attribute__((vector_size(32)));
struct Lanes8 {
  Lanes4 lo, hi;
};
inline Lanes8 operator*(const Lanes8& a, const Lanes8& b) { return {a.lo * b.lo, a.hi * b.hi}; }
inline Lanes8 operator*(double a, const Lanes8& b) { return {a * b.lo, a * b.hi}; }
inline Lanes8 operator+(const Lanes8& a, const Lanes8& b) { return {a.lo + b.lo, a.hi + b.hi}; }
inline Lanes8 operator-(const Lanes8& a, const Lanes8& b) { return {a.lo - b.lo, a.hi - b.hi}; }
inline Lanes8& operator+=(Lanes8& a, const Lanes8& b) {
  a.lo += b.lo;
  a.hi += b.hi;
  return a;
}
inline Lanes8& operator-=(Lanes8& a, const Lanes8& b) {
  a.lo -= b.lo;
  a.hi -= b.hi;
  return a;
}
inline void load(Lanes8& v, const double* p) {
  std::memcpy(&v.lo, p, sizeof v.lo);
  std::memcpy(&v.hi, p + 4, sizeof v.hi);
}
inline void store(double* p, const Lanes8& v) {
  std::memcpy(p, &v.lo, sizeof v.lo);
  std::memcpy(p + 4, &v.hi, sizeof v.hi);
}
inline double reduce(const Lanes8& s) {
  const Lanes4 t = s.lo + s.hi;
  return (t[0] + t[2]) + (t[1] + t[3]);
}
#endif

// a.b over n doubles, n a multiple of 8 (the solver's buffers are padded with zeros to one:
// SpgWork::padded), in eight partial sums: one serial chain of 3 x joints dependent additions
// (4 cycles each) was a large part of an SPG iteration.
inline double dot(const double* a, const double* b, int n) {
  Lanes8 s = {};
  for (int i = 0; i < n; i += 8) {
    Lanes8 va, vb;
    load(va, a + i);
    load(vb, b + i);
    s += va * vb;
  }
  return reduce(s);
}

// sum_p w_p d_p^2 in eight partial sums (one chain of 210 dependent additions was about a tenth
// of a warm solve).
inline double weighted_square_sum(const double* w, const double* d, int count) {
  Lanes8 s = {};
  int p = 0;
  for (; p + 8 <= count; p += 8) {
    Lanes8 vw, vd;
    load(vw, w + p);
    load(vd, d + p);
    s += vw * vd * vd;
  }
  double tail = 0.0;
  for (; p < count; ++p) tail += w[p] * d[p] * d[p];
  return reduce(s) + tail;
}

// out[i] = a_i.g for i < M and out[M + i] = b_i.g, in one pass over g (the same partial sums
// as dot(), so the same values): the quasi-Newton direction's 2M products with the gradient.
template <int M>
inline void dots_with(const double* const* a, const double* const* b, const double* g, int n, double* out) {
  Lanes8 sa[M == 0 ? 1 : M] = {}, sb[M == 0 ? 1 : M] = {};
  for (int k = 0; k < n; k += 8) {
    Lanes8 vg;
    load(vg, g + k);
    for (int i = 0; i < M; ++i) {
      Lanes8 va, vb;
      load(va, a[i] + k);
      load(vb, b[i] + k);
      sa[i] += va * vg;
      sb[i] += vb * vg;
    }
  }
  for (int i = 0; i < M; ++i) {
    out[i] = reduce(sa[i]);
    out[M + i] = reduce(sb[i]);
  }
}

// d = -gamma g - sum_i (p_i s_i + gq_i y_i) and returns g.d, in one pass (the same arithmetic,
// element by element and in the same order, as one pass per term and a dot() after).
template <int M>
inline double combine(const double* const* s, const double* const* y, const double* p, const double* gq, double gamma,
                      const double* g, double* d, int n) {
  Lanes8 acc = {};
  for (int k = 0; k < n; k += 8) {
    Lanes8 vg;
    load(vg, g + k);
    Lanes8 vd = -gamma * vg;
    for (int i = 0; i < M; ++i) {
      Lanes8 vs, vy;
      load(vs, s[i] + k);
      load(vy, y[i] + k);
      vd -= p[i] * vs + gq[i] * vy;
    }
    store(d + k, vd);
    acc += vg * vd;
  }
  return reduce(acc);
}

// After an accepted step: s = xn - x and y = gn - g written, and in the same pass s.s, s.y, y.y,
// gn.gn and, for the H older pairs (so, yo) that stay held, so_i.y and yo_i.y: out[0 .. 3] then
// out[4 + i] = so_i.y, out[4 + H + i] = yo_i.y (the same partial sums as dot()).
template <int H>
inline void step_products(const double* x, const double* xn, const double* g, const double* gn, double* s, double* y,
                          const double* const* so, const double* const* yo, int n, double* out) {
  Lanes8 ss = {}, sy = {}, yy = {}, gg = {};
  Lanes8 osy[H == 0 ? 1 : H] = {}, oyy[H == 0 ? 1 : H] = {};
  for (int k = 0; k < n; k += 8) {
    Lanes8 vx, vxn, vg, vgn;
    load(vx, x + k);
    load(vxn, xn + k);
    load(vg, g + k);
    load(vgn, gn + k);
    const Lanes8 vs = vxn - vx, vy = vgn - vg;
    store(s + k, vs);
    store(y + k, vy);
    ss += vs * vs;
    sy += vs * vy;
    yy += vy * vy;
    gg += vgn * vgn;
    for (int i = 0; i < H; ++i) {
      Lanes8 a, b;
      load(a, so[i] + k);
      load(b, yo[i] + k);
      osy[i] += a * vy;
      oyy[i] += b * vy;
    }
  }
  out[0] = reduce(ss);
  out[1] = reduce(sy);
  out[2] = reduce(yy);
  out[3] = reduce(gg);
  for (int i = 0; i < H; ++i) {
    out[4 + i] = reduce(osy[i]);
    out[4 + H + i] = reduce(oyy[i]);
  }
}

// The fused passes for a run-time count 0 .. kMaxCurvaturePairs (unrolled per count, so the
// partial sums stay in registers).
// The same three computations one product per pass (the arithmetic of each value is the same),
// for units without AVX-512: their 16 vector registers cannot hold the fused passes' 2 x pairs
// accumulators of 8 doubles, and on AVX2 the fused passes measured the same as these (5.11-5.21
// against 5.25-5.30 us per warm CMU-21 frame), so the portable and NEON builds keep these.
inline void dots_with_unfused(int m, const double* const* a, const double* const* b, const double* g, int n, double* out) {
  for (int i = 0; i < m; ++i) {
    out[i] = dot(a[i], g, n);
    out[m + i] = dot(b[i], g, n);
  }
}
inline double combine_unfused(int m, const double* const* s, const double* const* y, const double* p, const double* gq,
                              double gamma, const double* g, double* d, int n) {
  for (int k = 0; k < n; ++k) d[k] = -gamma * g[k];
  for (int i = 0; i < m; ++i) {
    const double* si = s[i];
    const double* yi = y[i];
    const double pi = p[i], gqi = gq[i];
    for (int k = 0; k < n; ++k) d[k] -= pi * si[k] + gqi * yi[k];
  }
  return dot(g, d, n);
}
inline void step_products_unfused(int h, const double* x, const double* xn, const double* g, const double* gn, double* s,
                                  double* y, const double* const* so, const double* const* yo, int n, double* out) {
  for (int k = 0; k < n; ++k) {
    s[k] = xn[k] - x[k];
    y[k] = gn[k] - g[k];
  }
  out[0] = dot(s, s, n);
  out[1] = dot(s, y, n);
  out[2] = dot(y, y, n);
  out[3] = dot(gn, gn, n);
  for (int i = 0; i < h; ++i) {
    out[4 + i] = dot(so[i], y, n);
    out[4 + h + i] = dot(yo[i], y, n);
  }
}
#if defined(__AVX512F__)
constexpr bool kFusedPasses = true;
#else
constexpr bool kFusedPasses = false;
#endif

static_assert(detail::SpgWork::kMaxCurvaturePairs == 8, "with_count covers 0 .. 8 pairs");
template <template <int> class F, class... Args>
auto with_count(int m, Args... args) {
  switch (m) {
    case 0: return F<0>::run(args...);
    case 1: return F<1>::run(args...);
    case 2: return F<2>::run(args...);
    case 3: return F<3>::run(args...);
    case 4: return F<4>::run(args...);
    case 5: return F<5>::run(args...);
    case 6: return F<6>::run(args...);
    case 7: return F<7>::run(args...);
    default: return F<8>::run(args...);
  }
}
template <int M>
struct DotsWith {
  static int run(const double* const* a, const double* const* b, const double* g, int n, double* out) {
    dots_with<M>(a, b, g, n, out);
    return 0;
  }
};
template <int M>
struct Combine {
  static double run(const double* const* s, const double* const* y, const double* p, const double* gq, double gamma,
                    const double* g, double* d, int n) {
    return combine<M>(s, y, p, gq, gamma, g, d, n);
  }
};
template <int H>
struct StepProducts {
  static int run(const double* x, const double* xn, const double* g, const double* gn, double* s, double* y,
                 const double* const* so, const double* const* yo, int n, double* out) {
    step_products<H>(x, xn, g, gn, s, y, so, yo, n, out);
    return 0;
  }
};

// d = -H g, H the inverse-Hessian estimate of the held curvature pairs in the compact form of
// Byrd, Nocedal and Schnabel (1994, theorem 2.2) with H0 = gamma I, gamma = s.y / y.y of the
// newest pair: H g = gamma g + S p + gamma Y q, q = -R^-1 S^T g,
// p = R^-T ((D + gamma Y^T Y) R^-1 S^T g - gamma Y^T g), R the upper triangle of S^T Y (pairs
// oldest first), D its diagonal. The same direction as the two-loop recursion, but its 2m dot
// products with g are independent of each other (the recursion chains them: each waits for the
// previous update of the direction), and S^T Y, Y^T Y are kept as pairs arrive.
inline double quasi_newton_direction(detail::SpgWork& w, const double* g, double* d) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int n = w.padded, m = w.pairs;
  int slot[kRing];  // chronological: slot[0] the oldest pair
  const double* sv[kRing];
  const double* yv[kRing];
  for (int i = 0; i < m; ++i) {
    slot[i] = (w.newest + kRing - (m - 1 - i)) % kRing;
    sv[i] = &w.s[static_cast<size_t>(slot[i]) * n];
    yv[i] = &w.y[static_cast<size_t>(slot[i]) * n];
  }
  double ab[2 * kRing];  // a_i = s_i.g, then b_i = y_i.g
  if (kFusedPasses) {
    with_count<DotsWith>(m, sv, yv, g, n, ab);
  } else {
    dots_with_unfused(m, sv, yv, g, n, ab);
  }
  const double* a = ab;
  const double* b = ab + m;
  double q[kRing], p[kRing], gq[kRing];
  const double gamma = w.gamma;
  for (int i = m - 1; i >= 0; --i) {  // R q = -a; the newest q[i + 1] last (the chain between the q is then one step)
    double t = -a[i];
    for (int j = m - 1; j > i; --j) t -= w.sy[slot[i]][slot[j]] * q[j];
    q[i] = t * w.rho[slot[i]];
  }
  for (int i = 0; i < m; ++i) {  // R^T p = -(D + gamma Y^T Y) q - gamma b
    double t = -w.sy[slot[i]][slot[i]] * q[i] - gamma * b[i];
    for (int j = 0; j < m; ++j) t -= gamma * w.yy[slot[i]][slot[j]] * q[j];
    for (int j = 0; j < i; ++j) t -= w.sy[slot[j]][slot[i]] * p[j];
    p[i] = t * w.rho[slot[i]];
  }
  for (int i = 0; i < m; ++i) gq[i] = gamma * q[i];
  // d = -gamma g - S p - gamma Y q, and g.d
  if (!kFusedPasses) return combine_unfused(m, sv, yv, p, gq, gamma, g, d, n);
  return with_count<Combine>(m, sv, yv, p, gq, gamma, g, d, n);
}

// Makes the pair in the ring slot after the newest (written there by the caller; never a held
// slot: the ring has one more slot than pairs are held) the newest, dropping the oldest when
// `limit` are held, with its products with the other held pairs: s_i.y (older s_i) and y_i.y,
// computed by step_products() for the held_after_add() newest pairs.
inline int held_after_add(const detail::SpgWork& w, int limit) { return std::min(w.pairs, limit - 1); }
inline void add_curvature_pair(detail::SpgWork& w, double sty, double yty, const double* products, int limit) {
  constexpr int kRing = detail::SpgWork::kRing;
  const int held = held_after_add(w, limit);  // the older pairs that stay
  const int slot = (w.newest + 1) % kRing;
  for (int i = 0; i < held; ++i) {
    const int other = (w.newest + kRing - i) % kRing;
    w.sy[other][slot] = products[i];
    const double yy = products[held + i];
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
template <class Kernel>
SpgResult spg_minimize(detail::SpgWork& w, const StressInstance& in, double* x_out, const SpgOptions& opt,
                       const Kernel& Stress) {
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
  const double scale = weighted_square_sum(in.weight, in.delta, in.pairs);
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
      const double qtd = quasi_newton_direction(w, g, d);
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
    // curvature pair below, or overwritten next time), with the Barzilai-Borwein sums, |gn|^2
    // and the products with the pairs that stay if this one is added: one pass.
    const int slot = (w.newest + 1) % kRing;
    double* s = &w.s[static_cast<size_t>(slot) * n];
    double* y = &w.y[static_cast<size_t>(slot) * n];
    const int held = curvature > 0 ? held_after_add(w, curvature) : 0;
    const double* so[kRing] = {};
    const double* yo[kRing] = {};
    for (int i = 0; i < held; ++i) {
      const int other = (w.newest + kRing - i) % kRing;
      so[i] = &w.s[static_cast<size_t>(other) * n];
      yo[i] = &w.y[static_cast<size_t>(other) * n];
    }
    double products[4 + 2 * kRing];
    if (kFusedPasses) {
      with_count<StepProducts>(held, x, xn, g, gn, s, y, so, yo, n, products);
    } else {
      step_products_unfused(held, x, xn, g, gn, s, y, so, yo, n, products);
    }
    const double sts = products[0], sty = products[1];
    lambda = sty <= 0.0 ? opt.step_max : std::clamp(sts / sty, opt.step_min, opt.step_max);
    // A pair enters the curvature memory only with positive curvature (s.y > 0; the stress is
    // not convex), so the inverse-Hessian estimate stays positive definite.
    if (curvature > 0 && sty > 1e-12 * sts) add_curvature_pair(w, sty, products[2], products + 4, curvature);
    if (!(fn < best_f) && best_is_x) {
      std::memcpy(best, x, sizeof(double) * n);  // a non-monotone step leaves the best point
      best_is_x = false;
    }
    std::swap(x, xn);
    std::swap(g, gn);
    f = fn;
    gnorm = std::sqrt(products[3]);
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
