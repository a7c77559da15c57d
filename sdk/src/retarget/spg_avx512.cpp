// The stress kernel compiled for x86-64-v4 (AVX-512; called only after kata::cpu_has_avx512(),
// spg.cpp): 8 pairs per instruction, row tails through masks, and 1/r from the 14-bit
// reciprocal square-root estimate refined by two Newton steps (no square root or division, so
// the divider no longer bounds the kernel). Results equal the portable kernel's to a few units
// in the last place, not bit for bit. Off x86 this TU forwards to the portable kernel.
#include "retarget/stress_kernel.hpp"
#include "retarget/spg_solver.inl"

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace kata::retarget {

#if defined(__AVX512F__)
namespace {
// The full-mask (maskz, mask 0xFF) forms of these intrinsics: GCC 12's unmasked ones pass
// _mm512_undefined_pd() and trip -Wmaybe-uninitialized (GCC bug 105593).
constexpr __mmask8 kAll = 0xFF;

// 1 / sqrt(max(s, 1e-300)) from the 14-bit estimate and two Newton steps (relative error
// < 2^-52). s = 0 (coincident joints, padding lanes) gives a finite 1e150, so s * inv = 0.
inline __m512d inverse_sqrt(__m512d s) {
  const __m512d sc = _mm512_maskz_max_pd(kAll, s, _mm512_set1_pd(1e-300));
  const __m512d half_s = _mm512_mul_pd(_mm512_set1_pd(0.5), sc);
  const __m512d three_halves = _mm512_set1_pd(1.5);
  __m512d inv = _mm512_maskz_rsqrt14_pd(kAll, sc);
  inv = _mm512_mul_pd(inv, _mm512_fnmadd_pd(half_s, _mm512_mul_pd(inv, inv), three_halves));
  return _mm512_mul_pd(inv, _mm512_fnmadd_pd(half_s, _mm512_mul_pd(inv, inv), three_halves));
}

inline double horizontal_sum(__m512d v) {
  const __m256d quad = _mm256_add_pd(_mm512_maskz_extractf64x4_pd(kAll, v, 0), _mm512_maskz_extractf64x4_pd(kAll, v, 1));
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(quad), _mm256_extractf128_pd(quad, 1));
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}
}  // namespace
#endif

// Same contract as stress() (spg.hpp).
double detail::stress_avx512(const StressInstance& in, const double* x, double* grad) {
#if defined(__AVX512F__)
  if (!grad) return stress_kernel(in, x, grad);
  const int n = in.joints;
  const double* px = x;
  const double* py = x + n;
  const double* pz = x + 2 * n;
  double* gx = grad;
  double* gy = grad + n;
  double* gz = grad + 2 * n;
  std::memset(grad, 0, sizeof(double) * 3 * static_cast<size_t>(n));
  __m512d fsum = _mm512_setzero_pd();
  int row = 0;
  for (int u = 0; u + 1 < n; ++u) {
    // Row u: pairs (u, u+1 .. n-1), contiguous in SoA positions, weights and targets.
    const int len = n - 1 - u;
    const __m512d xu = _mm512_set1_pd(px[u]), yu = _mm512_set1_pd(py[u]), zu = _mm512_set1_pd(pz[u]);
    const double* w = in.weight + row;
    const double* dl = in.delta + row;
    const int v0 = u + 1;
    __m512d sx = _mm512_setzero_pd(), sy = _mm512_setzero_pd(), sz = _mm512_setzero_pd();
    for (int i = 0; i < len; i += 8) {
      // Lanes past the row load weight 0 and target 0, so they add nothing; stores are masked.
      const int left = len - i;
      const __mmask8 mask = left >= 8 ? __mmask8(0xFF) : __mmask8((1u << left) - 1u);
      const __m512d dx = _mm512_sub_pd(xu, _mm512_maskz_loadu_pd(mask, px + v0 + i));
      const __m512d dy = _mm512_sub_pd(yu, _mm512_maskz_loadu_pd(mask, py + v0 + i));
      const __m512d dz = _mm512_sub_pd(zu, _mm512_maskz_loadu_pd(mask, pz + v0 + i));
      const __m512d wv = _mm512_maskz_loadu_pd(mask, w + i);
      const __m512d dv = _mm512_maskz_loadu_pd(mask, dl + i);
      const __m512d s = _mm512_fmadd_pd(dx, dx, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dz, dz)));
      const __m512d inv = inverse_sqrt(s);
      const __m512d e = _mm512_fmsub_pd(s, inv, dv);  // r - delta, r = s / sqrt(s)
      const __m512d we = _mm512_mul_pd(wv, e);
      fsum = _mm512_fmadd_pd(we, e, fsum);
      const __m512d c = _mm512_mul_pd(we, inv);
      sx = _mm512_fmadd_pd(c, dx, sx);
      sy = _mm512_fmadd_pd(c, dy, sy);
      sz = _mm512_fmadd_pd(c, dz, sz);
      _mm512_mask_storeu_pd(gx + v0 + i, mask, _mm512_fnmadd_pd(c, dx, _mm512_maskz_loadu_pd(mask, gx + v0 + i)));
      _mm512_mask_storeu_pd(gy + v0 + i, mask, _mm512_fnmadd_pd(c, dy, _mm512_maskz_loadu_pd(mask, gy + v0 + i)));
      _mm512_mask_storeu_pd(gz + v0 + i, mask, _mm512_fnmadd_pd(c, dz, _mm512_maskz_loadu_pd(mask, gz + v0 + i)));
    }
    gx[u] += horizontal_sum(sx);
    gy[u] += horizontal_sum(sy);
    gz[u] += horizontal_sum(sz);
    row += len;
  }
  return 0.5 * horizontal_sum(fsum);
#else
  return stress_kernel(in, x, grad);
#endif
}

// Same contract as stress() over the blocked layout (spg.hpp, BlockedPairs). Per step the lanes
// hold 8 pairs (8I + l, 8J + (l + k) mod 8): side A's positions and gradient stay in their lanes
// for the whole block row I; side B's positions are one unaligned load from the doubled copy at
// offset k, and its gradient accumulator is rotated by one lane after every step (frame k -> k + 1),
// so after the 8 steps of a block pair it is back in joint order. No horizontal sum except the
// stress's own, no gradient scatter (the row kernel's masked read-modify-writes of the gradient
// overlap the previous row's stores by one lane and wait for them).
double detail::stress_blocked_avx512(BlockedPairs& blocked, const double* x, double* grad) {
#if defined(__AVX512F__)
  const int n = blocked.joints, blocks = blocked.blocks;
  double* doubled = blocked.doubled();  // per block: x[16], y[16], z[16]
  double* acc = blocked.gradient();     // per block: gx[8], gy[8], gz[8]
  for (int b = 0; b < blocks; ++b) {
    const int left = n - 8 * b;
    const __mmask8 mask = left >= 8 ? __mmask8(0xFF) : __mmask8((1u << left) - 1u);
    for (int k = 0; k < 3; ++k) {
      const __m512d v = _mm512_maskz_loadu_pd(mask, x + k * n + 8 * b);
      double* dst = doubled + 48 * b + 16 * k;
      _mm512_store_pd(dst, v);
      _mm512_store_pd(dst + 8, v);
      _mm512_store_pd(acc + 24 * b + 8 * k, _mm512_setzero_pd());
    }
  }
  const double* wv = blocked.weight();
  const double* dv = blocked.delta();
  __m512d fsum = _mm512_setzero_pd();
  // One step: the 8 pairs of lanes (a_l, b_l), b's positions given; adds to ga, subtracts from gb.
  const auto step = [&](__m512d ax, __m512d ay, __m512d az, __m512d bx, __m512d by, __m512d bz, __m512d& gax,
                        __m512d& gay, __m512d& gaz, __m512d& gbx, __m512d& gby, __m512d& gbz) {
    const __m512d dx = _mm512_sub_pd(ax, bx), dy = _mm512_sub_pd(ay, by), dz = _mm512_sub_pd(az, bz);
    const __m512d w = _mm512_load_pd(wv), delta = _mm512_load_pd(dv);
    wv += 8;
    dv += 8;
    const __m512d s = _mm512_fmadd_pd(dx, dx, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dz, dz)));
    const __m512d inv = inverse_sqrt(s);
    const __m512d e = _mm512_fmsub_pd(s, inv, delta);  // r - delta, r = s / sqrt(s)
    const __m512d we = _mm512_mul_pd(w, e);
    fsum = _mm512_fmadd_pd(we, e, fsum);
    const __m512d c = _mm512_mul_pd(we, inv);
    gax = _mm512_fmadd_pd(c, dx, gax);
    gay = _mm512_fmadd_pd(c, dy, gay);
    gaz = _mm512_fmadd_pd(c, dz, gaz);
    gbx = _mm512_fnmadd_pd(c, dx, gbx);
    gby = _mm512_fnmadd_pd(c, dy, gby);
    gbz = _mm512_fnmadd_pd(c, dz, gbz);
  };
  // Lane l <- lane l + 1: the accumulator of side B from step k's frame to step k + 1's.
  const auto rotate = [](__m512d v) { return _mm512_castsi512_pd(_mm512_maskz_alignr_epi64(kAll, _mm512_castpd_si512(v), _mm512_castpd_si512(v), 1)); };
  for (int bi = 0; bi < blocks; ++bi) {
    const double* a = doubled + 48 * bi;
    const __m512d ax = _mm512_load_pd(a), ay = _mm512_load_pd(a + 16), az = _mm512_load_pd(a + 32);
    double* ga = acc + 24 * bi;
    __m512d gax = _mm512_load_pd(ga), gay = _mm512_load_pd(ga + 8), gaz = _mm512_load_pd(ga + 16);
    {
      // Within the block: k = 1 .. 4, B's accumulator starting in frame 1 and ending in frame 5.
      __m512d gbx = _mm512_setzero_pd(), gby = _mm512_setzero_pd(), gbz = _mm512_setzero_pd();
      for (int k = 1; k <= 4; ++k) {
        step(ax, ay, az, _mm512_loadu_pd(a + k), _mm512_loadu_pd(a + 16 + k), _mm512_loadu_pd(a + 32 + k), gax, gay, gaz,
             gbx, gby, gbz);
        gbx = rotate(gbx);
        gby = rotate(gby);
        gbz = rotate(gbz);
      }
      // Frame 5 -> 8 = 0 (joint order): three lanes more.
      const auto rotate3 = [](__m512d v) { return _mm512_castsi512_pd(_mm512_maskz_alignr_epi64(kAll, _mm512_castpd_si512(v), _mm512_castpd_si512(v), 3)); };
      gax = _mm512_add_pd(gax, rotate3(gbx));
      gay = _mm512_add_pd(gay, rotate3(gby));
      gaz = _mm512_add_pd(gaz, rotate3(gbz));
    }
    for (int bj = bi + 1; bj < blocks; ++bj) {
      const double* b = doubled + 48 * bj;
      double* gb = acc + 24 * bj;
      __m512d gbx = _mm512_load_pd(gb), gby = _mm512_load_pd(gb + 8), gbz = _mm512_load_pd(gb + 16);
      for (int k = 0; k < 8; ++k) {
        step(ax, ay, az, _mm512_loadu_pd(b + k), _mm512_loadu_pd(b + 16 + k), _mm512_loadu_pd(b + 32 + k), gax, gay, gaz,
             gbx, gby, gbz);
        gbx = rotate(gbx);
        gby = rotate(gby);
        gbz = rotate(gbz);
      }
      _mm512_store_pd(gb, gbx);
      _mm512_store_pd(gb + 8, gby);
      _mm512_store_pd(gb + 16, gbz);
    }
    // Block bi is complete (later rows only add to blocks after it).
    const int left = n - 8 * bi;
    const __mmask8 mask = left >= 8 ? __mmask8(0xFF) : __mmask8((1u << left) - 1u);
    _mm512_mask_storeu_pd(grad + 8 * bi, mask, gax);
    _mm512_mask_storeu_pd(grad + n + 8 * bi, mask, gay);
    _mm512_mask_storeu_pd(grad + 2 * n + 8 * bi, mask, gaz);
  }
  return 0.5 * horizontal_sum(fsum);
#else
  // Off x86 (never dispatched there): the same lanes, one at a time.
  const int n = blocked.joints;
  std::memset(grad, 0, sizeof(double) * 3 * static_cast<size_t>(n));
  const double* wv = blocked.weight();
  const double* dv = blocked.delta();
  double f = 0.0;
  const auto lane = [&](int a, int b) {
    if (a < n && b < n && *wv != 0.0) {
      double d[3], s = 0.0;
      for (int k = 0; k < 3; ++k) {
        d[k] = x[k * n + a] - x[k * n + b];
        s += d[k] * d[k];
      }
      const double r = std::sqrt(s), e = r - *dv, we = *wv * e, c = we / (r + 1e-300);
      f += we * e;
      for (int k = 0; k < 3; ++k) {
        grad[k * n + a] += c * d[k];
        grad[k * n + b] -= c * d[k];
      }
    }
    ++wv;
    ++dv;
  };
  for (int bi = 0; bi < blocked.blocks; ++bi) {
    for (int k = 1; k <= 4; ++k)
      for (int l = 0; l < 8; ++l) lane(8 * bi + l, 8 * bi + (l + k) % 8);
    for (int bj = bi + 1; bj < blocked.blocks; ++bj)
      for (int k = 0; k < 8; ++k)
        for (int l = 0; l < 8; ++l) lane(8 * bi + l, 8 * bj + (l + k) % 8);
  }
  return 0.5 * f;
#endif
}

// Same contract as targets_portable (spg.hpp); |t_u - t_v| from the refined reciprocal square
// root and 1 / tau_teacher from the 14-bit reciprocal estimate refined by two Newton steps (the
// square root and the division of every pair were most of this kernel, on the divider). A lane
// whose tau_teacher is below 1e-290 but positive takes the division (its reciprocal could
// overflow).
void detail::targets_avx512(int n, const double* t, const double* tau_s, const double* tau_t, double* delta) {
#if defined(__AVX512F__)
  const double* tx = t;
  const double* ty = tx + n;
  const double* tz = ty + n;
  const __m512d smallest = _mm512_set1_pd(1e-290), zero = _mm512_setzero_pd();
  const __m512d two = _mm512_set1_pd(2.0);
  int row = 0;
  for (int u = 0; u + 1 < n; ++u) {
    const int len = n - 1 - u, v0 = u + 1;
    const __m512d xu = _mm512_set1_pd(tx[u]), yu = _mm512_set1_pd(ty[u]), zu = _mm512_set1_pd(tz[u]);
    for (int i = 0; i < len; i += 8) {
      const int left = len - i;
      const __mmask8 mask = left >= 8 ? __mmask8(0xFF) : __mmask8((1u << left) - 1u);
      const __m512d dx = _mm512_sub_pd(xu, _mm512_maskz_loadu_pd(mask, tx + v0 + i));
      const __m512d dy = _mm512_sub_pd(yu, _mm512_maskz_loadu_pd(mask, ty + v0 + i));
      const __m512d dz = _mm512_sub_pd(zu, _mm512_maskz_loadu_pd(mask, tz + v0 + i));
      const __m512d s = _mm512_fmadd_pd(dx, dx, _mm512_fmadd_pd(dy, dy, _mm512_mul_pd(dz, dz)));
      const __m512d inv = inverse_sqrt(s);
      const __m512d dist = _mm512_mul_pd(s, inv);
      const __m512d ts = _mm512_maskz_loadu_pd(mask, tau_s + row + i);
      const __m512d tt = _mm512_maskz_loadu_pd(mask, tau_t + row + i);
      const __mmask8 positive = _mm512_cmp_pd_mask(tt, zero, _CMP_GT_OQ);
      const __mmask8 normal = _mm512_cmp_pd_mask(tt, smallest, _CMP_GE_OQ);
      const __m512d tt_safe = _mm512_mask_blend_pd(normal, _mm512_set1_pd(1.0), tt);
      __m512d rcp = _mm512_maskz_rcp14_pd(kAll, tt_safe);  // relative error < 2^-14; two Newton steps: < 2^-52
      rcp = _mm512_mul_pd(rcp, _mm512_fnmadd_pd(tt_safe, rcp, two));
      rcp = _mm512_mul_pd(rcp, _mm512_fnmadd_pd(tt_safe, rcp, two));
      __m512d value = _mm512_mul_pd(_mm512_mul_pd(ts, dist), rcp);
      if (positive & ~normal & mask) value = _mm512_mask_div_pd(value, positive & ~normal, _mm512_mul_pd(ts, dist), tt);
      _mm512_mask_storeu_pd(delta + row + i, mask, _mm512_mask_blend_pd(positive, ts, value));
    }
    row += len;
  }
#else
  targets_kernel(n, t, tau_s, tau_t, delta);
#endif
}

void detail::rotate_pairs_avx512(SpgWork& work, const double* r) { rotate_pairs(work, r); }

// BlockedPairs::gather with 8-lane gathers (the scalar loop was 5% of a warm frame).
void detail::gather_blocked_avx512(BlockedPairs& blocked, const StressInstance& in) {
#if defined(__AVX512F__)
  double* w = blocked.weight();
  double* d = blocked.delta();
  const __m256i none = _mm256_set1_epi32(-1);
  for (int i = 0; i < blocked.steps * 8; i += 8) {
    const __m256i index = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(blocked.pair.data() + i));
    const __mmask8 valid = _mm256_cmpgt_epi32_mask(index, none);
    _mm512_store_pd(w + i, _mm512_mask_i32gather_pd(_mm512_setzero_pd(), valid, index, in.weight, 8));
    _mm512_store_pd(d + i, _mm512_mask_i32gather_pd(_mm512_setzero_pd(), valid, index, in.delta, 8));
  }
#else
  blocked.gather(in);
#endif
}

SpgResult detail::minimize_avx512(SpgWork& work, const StressInstance& in, double* x, const SpgOptions& opt) {
#if defined(__AVX512F__)
  // The instance in the blocked kernel's order, once per solve (about 300 lanes).
  BlockedPairs& blocked = work.blocked;
  gather_blocked_avx512(blocked, in);
  return spg_minimize(work, in, x, opt, [&blocked](const StressInstance&, const double* point, double* grad) {
    return stress_blocked_avx512(blocked, point, grad);
  });
#else
  return spg_minimize(work, in, x, opt, stress_avx512);
#endif
}

}  // namespace kata::retarget
