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
  const __m512d tiny = _mm512_set1_pd(1e-300);
  const __m512d half = _mm512_set1_pd(0.5), three_halves = _mm512_set1_pd(1.5);
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
      // s = 0 (coincident joints): inv is finite (1e150), r = 0 and c dx = 0, a valid subgradient.
      const __m512d sc = _mm512_maskz_max_pd(kAll, s, tiny);
      const __m512d half_s = _mm512_mul_pd(half, sc);
      __m512d inv = _mm512_maskz_rsqrt14_pd(kAll, sc);  // relative error < 2^-14; two Newton steps: < 2^-52
      inv = _mm512_mul_pd(inv, _mm512_fnmadd_pd(half_s, _mm512_mul_pd(inv, inv), three_halves));
      inv = _mm512_mul_pd(inv, _mm512_fnmadd_pd(half_s, _mm512_mul_pd(inv, inv), three_halves));
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

void detail::targets_avx512(int n, const double* t, const double* tau_s, const double* tau_t, double* delta) {
  targets_kernel(n, t, tau_s, tau_t, delta);
}

void detail::rotate_pairs_avx512(SpgWork& work, const double* r) { rotate_pairs(work, r); }

SpgResult detail::minimize_avx512(SpgWork& work, const StressInstance& in, double* x, const SpgOptions& opt) {
  return spg_minimize<detail::stress_avx512>(work, in, x, opt);
}

}  // namespace kata::retarget
