// The alignment pass for AVX2 (compiled with -march=x86-64-v3 by kata_avx2_sources; called only
// after kata::cpu_has_avx2()). Eight teacher rows at a time: one 8-lane accumulator per row
// (lane l sums the elements c + l, as dist2f does), then the eight accumulators reduced together
// by two rounds of horizontal adds, which add lanes in dist2f's order ((0+1)+(2+3))+((4+5)+(6+7)),
// and one vector square root for the eight rows. Separate multiply and add, never fused, so the
// distances equal the baseline's bit for bit and the alignment places a student identically on
// every CPU. The dynamic programme's loops (align_pass_kernel.inl) are compiled here too.
#include "metric/align_pass.hpp"

#include <algorithm>
#include <cstddef>

#if defined(__AVX2__)
#include <immintrin.h>

namespace kata::metric::detail::avx2 {

namespace {
// Rows 0-7's eight-lane accumulators -> their eight sums, lanes added as dist2f adds them.
inline __m256 row_sums(const __m256* acc) {
  // Round 1: [r0: 0+1, 2+3 | r1: 0+1, 2+3 || r0: 4+5, 6+7 | r1: 4+5, 6+7] for row pairs.
  const __m256 h01 = _mm256_hadd_ps(acc[0], acc[1]), h23 = _mm256_hadd_ps(acc[2], acc[3]);
  const __m256 h45 = _mm256_hadd_ps(acc[4], acc[5]), h67 = _mm256_hadd_ps(acc[6], acc[7]);
  // Round 2: lanes 0-3 hold rows 0-3's (0+1)+(2+3), lanes 4-7 their (4+5)+(6+7); likewise 4-7.
  const __m256 q0 = _mm256_hadd_ps(h01, h23), q1 = _mm256_hadd_ps(h45, h67);
  return _mm256_add_ps(_mm256_permute2f128_ps(q0, q1, 0x20), _mm256_permute2f128_ps(q0, q1, 0x31));
}

// Eight rows' distances (rows r[0..7], any addresses), as dist2f computes each.
inline __m256 eight_rows(const float* s_scaled, const uint16_t* const* r, int stride, __m256 k) {
  __m256 acc[8];
  for (int i = 0; i < 8; ++i) acc[i] = _mm256_setzero_ps();
  for (int c = 0; c < stride; c += 8) {
    const __m256 x = _mm256_loadu_ps(s_scaled + c);
    for (int i = 0; i < 8; ++i) {
      const __m128i h = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r[i] + c));
      const __m256 e = _mm256_sub_ps(x, _mm256_cvtph_ps(h));
      acc[i] = _mm256_add_ps(acc[i], _mm256_mul_ps(e, e));
    }
  }
  return _mm256_mul_ps(k, _mm256_sqrt_ps(row_sums(acc)));
}
}  // namespace

void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out) {
  const __m256 k = _mm256_set1_ps(scale);
  const uint16_t* r[8];
  int j = 0;
  for (; j + 8 <= m; j += 8) {
    for (int i = 0; i < 8; ++i) r[i] = rows + static_cast<size_t>(j + i) * stride;
    _mm256_storeu_ps(out + j, eight_rows(s_scaled, r, stride, k));
  }
  // The last 1-7 rows through the same eight-row kernel (the spare lanes repeat the last row; each
  // lane's sum is its own row's, so the figures are those of a full group): the baseline's
  // software half conversion, one row at a time, cost 4 % of a frame's push here (the window's
  // length is rarely a multiple of eight).
  if (j < m) {
    for (int i = 0; i < 8; ++i) r[i] = rows + static_cast<size_t>(std::min(j + i, m - 1)) * stride;
    alignas(32) float last[8];
    _mm256_store_ps(last, eight_rows(s_scaled, r, stride, k));
    for (int i = 0; j + i < m; ++i) out[j + i] = last[i];
  }
}

#include "metric/align_pass_kernel.inl"

}  // namespace kata::metric::detail::avx2

#else  // not an x86 build: the dispatcher never calls this.

namespace kata::metric::detail::avx2 {
void subtract_rows16(float* row, const int16_t* q, float step, int n) { base::subtract_rows16(row, q, step, n); }
void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out) {
  base::alignment_distances_half(s_scaled, rows, m, stride, scale, out);
}
int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop) {
  return base::alignment_step(prev, cur, c, a, b, pk, k_max, jump, loop);
}
int alignment_rebase(double* cur, int a, int b) { return base::alignment_rebase(cur, a, b); }
void alignment_step_range(const double* prev, double* cur, const float* c, int a, int b, int lo, int hi,
                          const double* pk, int k_max, double jump, bool loop) {
  base::alignment_step_range(prev, cur, c, a, b, lo, hi, pk, k_max, jump, loop);
}
}  // namespace kata::metric::detail::avx2

#endif
