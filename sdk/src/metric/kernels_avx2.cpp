// AVX2+FMA projection kernels (compiled with -march=x86-64-v3; called only after
// kata::cpu_has_avx2()). Intrinsics only: no Eigen or other inline library code in this TU.
#include <immintrin.h>

#include <cstdint>

#include "metric/kernels.hpp"

namespace kata::metric::detail::avx2 {

namespace {

// Lane mask selecting the first `n` (0..8) floats of a ymm load.
__m256i lane_mask(int n) {
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), lanes);
}

// One group of one chunk: NV full vectors of 8 columns, plus a masked tail vector when kTail.
// Rows are processed two at a time into two accumulator sets where registers allow, so the
// FMA latency chain does not limit throughput.
template <int NV, bool kTail>
void group_chunk(const float* rows, int stride, const float* xp, int begin, int end, __m256i tail_mask, float* out) {
  constexpr int kAcc = NV + (kTail ? 1 : 0);
  __m256 acc[kAcc > 0 ? kAcc : 1];
  for (int v = 0; v < kAcc; ++v) acc[v] = _mm256_setzero_ps();
  for (int i = begin; i < end; ++i) {
    const __m256 xi = _mm256_broadcast_ss(xp + i);
    const float* row = rows + static_cast<ptrdiff_t>(i) * stride;
    for (int v = 0; v < NV; ++v) acc[v] = _mm256_fmadd_ps(_mm256_loadu_ps(row + 8 * v), xi, acc[v]);
    if constexpr (kTail) acc[NV] = _mm256_fmadd_ps(_mm256_maskload_ps(row + 8 * NV, tail_mask), xi, acc[NV]);
  }
  for (int v = 0; v < kAcc; ++v) _mm256_storeu_ps(out + 8 * v, acc[v]);
}

using GroupFn = void (*)(const float*, int, const float*, int, int, __m256i, float*);

template <int NV>
GroupFn pick_nv(bool tail) {
  return tail ? &group_chunk<NV, true> : &group_chunk<NV, false>;
}

GroupFn pick(int nv, bool tail) {
  switch (nv) {
    case 0: return pick_nv<0>(tail);
    case 1: return pick_nv<1>(tail);
    case 2: return pick_nv<2>(tail);
    case 3: return pick_nv<3>(tail);
    case 4: return pick_nv<4>(tail);
    case 5: return pick_nv<5>(tail);
    case 6: return pick_nv<6>(tail);
    case 7: return pick_nv<7>(tail);
    default: return pick_nv<8>(false);  // nv == 8 only for a full 64-column chunk
  }
}

// F frames, one slab of up to 16 columns (two vectors, masked by m0/m1) of one group's rows.
template <int F>
void slab(const float* rows, int stride, const float* const* xp, int begin, int end, __m256i m0, __m256i m1,
          float* const* out, int col) {
  __m256 a0[F], a1[F];
  for (int f = 0; f < F; ++f) a0[f] = a1[f] = _mm256_setzero_ps();
  for (int i = begin; i < end; ++i) {
    const float* row = rows + static_cast<ptrdiff_t>(i) * stride;
    const __m256 w0 = _mm256_maskload_ps(row, m0);
    const __m256 w1 = _mm256_maskload_ps(row + 8, m1);
    for (int f = 0; f < F; ++f) {
      const __m256 xi = _mm256_broadcast_ss(xp[f] + i);
      a0[f] = _mm256_fmadd_ps(w0, xi, a0[f]);
      a1[f] = _mm256_fmadd_ps(w1, xi, a1[f]);
    }
  }
  for (int f = 0; f < F; ++f) {
    _mm256_storeu_ps(out[f] + col, a0[f]);
    _mm256_storeu_ps(out[f] + col + 8, a1[f]);
  }
}

// The same for full slabs: plain loads (a masked load costs more on some cores).
template <int F>
void slab_full(const float* rows, int stride, const float* const* xp, int begin, int end, float* const* out, int col) {
  __m256 a0[F], a1[F];
  for (int f = 0; f < F; ++f) a0[f] = a1[f] = _mm256_setzero_ps();
  for (int i = begin; i < end; ++i) {
    const float* row = rows + static_cast<ptrdiff_t>(i) * stride;
    const __m256 w0 = _mm256_loadu_ps(row);
    const __m256 w1 = _mm256_loadu_ps(row + 8);
    for (int f = 0; f < F; ++f) {
      const __m256 xi = _mm256_broadcast_ss(xp[f] + i);
      a0[f] = _mm256_fmadd_ps(w0, xi, a0[f]);
      a1[f] = _mm256_fmadd_ps(w1, xi, a1[f]);
    }
  }
  for (int f = 0; f < F; ++f) {
    _mm256_storeu_ps(out[f] + col, a0[f]);
    _mm256_storeu_ps(out[f] + col + 8, a1[f]);
  }
}

template <int F>
void batch(const BlockedW& w, const float* const* xp, float* const* v) {
  float* out[F];
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const float* rows = w.data + static_cast<ptrdiff_t>(w.rows) * c0;
    for (int g = 0; g < w.groups; ++g) {
      const int begin = w.group_begin[g], end = w.group_begin[g + 1];
      for (int f = 0; f < F; ++f) out[f] = v[f] + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
      for (int s = 0; s < width; s += 16) {
        const int n = width - s;
        if (n >= 16) {
          slab_full<F>(rows + s, width, xp, begin, end, out, s);
        } else if (n > 8) {
          // The second vector's masked lanes are zeros and land inside out_stride (a multiple of 8).
          slab<F>(rows + s, width, xp, begin, end, lane_mask(8), lane_mask(n - 8), out, s);
        } else {
          // One (masked) vector: its 16-wide slab would store past out_stride, so it goes
          // through a scratch pair and only the first 8 lanes are copied out.
          alignas(32) float scratch[F][16];
          float* sp[F];
          for (int f = 0; f < F; ++f) sp[f] = scratch[f];
          slab<F>(rows + s, width, xp, begin, end, lane_mask(n), lane_mask(0), sp, 0);
          for (int f = 0; f < F; ++f) _mm256_storeu_ps(out[f] + s, _mm256_load_ps(scratch[f]));
        }
      }
    }
  }
}

}  // namespace

void project_groups(const BlockedW& w, const float* xp, float* v) {
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const GroupFn fn = pick(width / 8, width % 8 != 0);
    const __m256i mask = lane_mask(width % 8);
    const float* rows = w.data + static_cast<ptrdiff_t>(w.rows) * c0;
    for (int g = 0; g < w.groups; ++g)
      fn(rows, width, xp, w.group_begin[g], w.group_begin[g + 1], mask, v + static_cast<ptrdiff_t>(g) * w.out_stride + c0);
  }
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  switch (n) {
    case 1: avx2::project_groups(w, xp[0], v[0]); break;
    case 2: batch<2>(w, xp, v); break;
    case 3: batch<3>(w, xp, v); break;
    case 4: batch<4>(w, xp, v); break;
    default: break;
  }
}

double gather_normalise(const float* x, const int* perm, const float* a, const float* b, int n, float* xp) {
  __m256d s0 = _mm256_setzero_pd(), s1 = _mm256_setzero_pd();
  int k = 0;
  for (; k + 8 <= n; k += 8) {
    const __m256i idx = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(perm + k));
    const __m256 g = _mm256_i32gather_ps(x, idx, 4);
    const __m256 y = _mm256_mul_ps(_mm256_sub_ps(g, _mm256_loadu_ps(a + k)), _mm256_loadu_ps(b + k));
    _mm256_storeu_ps(xp + k, y);
    const __m256d lo = _mm256_cvtps_pd(_mm256_castps256_ps128(y));
    const __m256d hi = _mm256_cvtps_pd(_mm256_extractf128_ps(y, 1));
    s0 = _mm256_fmadd_pd(lo, lo, s0);
    s1 = _mm256_fmadd_pd(hi, hi, s1);
  }
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, _mm256_add_pd(s0, s1));
  double sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  for (; k < n; ++k) {
    const float y = (x[perm[k]] - a[k]) * b[k];
    xp[k] = y;
    sum += static_cast<double>(y) * y;
  }
  return sum;
}

}  // namespace kata::metric::detail::avx2
