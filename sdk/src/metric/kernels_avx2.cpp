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
void group_chunk(const float* rows, int stride, const float* xp, const int* perm, int begin, int end, __m256i tail_mask,
                 float* out) {
  constexpr int kAcc = NV + (kTail ? 1 : 0);
  __m256 acc[kAcc > 0 ? kAcc : 1];
  for (int v = 0; v < kAcc; ++v) acc[v] = _mm256_setzero_ps();
  for (int i = begin; i < end; ++i) {
    const __m256 xi = _mm256_broadcast_ss(xp + perm[i]);
    const float* row = rows + static_cast<ptrdiff_t>(i) * stride;
    for (int v = 0; v < NV; ++v) acc[v] = _mm256_fmadd_ps(_mm256_loadu_ps(row + 8 * v), xi, acc[v]);
    if constexpr (kTail) acc[NV] = _mm256_fmadd_ps(_mm256_maskload_ps(row + 8 * NV, tail_mask), xi, acc[NV]);
  }
  for (int v = 0; v < kAcc; ++v) _mm256_storeu_ps(out + 8 * v, acc[v]);
}

using GroupFn = void (*)(const float*, int, const float*, const int*, int, int, __m256i, float*);

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

// Rows per tile of the batched kernel: a tile of W (64 x r floats, 12.8 KB at r = 50) stays in
// L1 while every column slab of every frame passes over it, so W streams from L2 once per batch.
constexpr int kTile = 64;

// F frames x NV vectors of 8 columns (lanes past the slab masked to 0) over rows [begin, end),
// accumulated into out[f] + col (which holds the running sums).
template <int F, int NV, bool kMasked>
void slab(const float* rows, int stride, const float* const* xp, const int* perm, int begin, int end,
          const __m256i* masks, float* const* out, int col) {
  __m256 acc[F][NV];
  for (int f = 0; f < F; ++f)
    for (int v = 0; v < NV; ++v) acc[f][v] = _mm256_loadu_ps(out[f] + col + 8 * v);
  for (int i = begin; i < end; ++i) {
    const float* row = rows + static_cast<ptrdiff_t>(i) * stride + col;
    __m256 w[NV];
    for (int v = 0; v < NV; ++v) w[v] = kMasked ? _mm256_maskload_ps(row + 8 * v, masks[v]) : _mm256_loadu_ps(row + 8 * v);
    const int src = perm[i];
    for (int f = 0; f < F; ++f) {
      const __m256 xi = _mm256_broadcast_ss(xp[f] + src);
      for (int v = 0; v < NV; ++v) acc[f][v] = _mm256_fmadd_ps(w[v], xi, acc[f][v]);
    }
  }
  for (int f = 0; f < F; ++f)
    for (int v = 0; v < NV; ++v) _mm256_storeu_ps(out[f] + col + 8 * v, acc[f][v]);
}

template <int F>
void batch(const BlockedW& w, const float* const* xp, float* const* v) {
  float* out[F];
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const int padded = (width + 7) / 8 * 8;
    const float* rows = w.data + static_cast<ptrdiff_t>(w.rows) * c0;
    for (int g = 0; g < w.groups; ++g) {
      for (int f = 0; f < F; ++f) {
        out[f] = v[f] + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
        for (int c = 0; c < padded; c += 8) _mm256_storeu_ps(out[f] + c, _mm256_setzero_ps());
      }
      for (int t0 = w.group_begin[g]; t0 < w.group_begin[g + 1]; t0 += kTile) {
        const int t1 = t0 + kTile < w.group_begin[g + 1] ? t0 + kTile : w.group_begin[g + 1];
        int s = 0;
        for (; s + 16 <= width; s += 16) slab<F, 2, false>(rows, width, xp, w.perm, t0, t1, nullptr, out, s);
        const int n = width - s;  // 0..15 columns left
        if (n > 8) {
          const __m256i m[2] = {lane_mask(8), lane_mask(n - 8)};
          slab<F, 2, true>(rows, width, xp, w.perm, t0, t1, m, out, s);
        } else if (n > 0) {
          const __m256i m[1] = {lane_mask(n)};
          slab<F, 1, true>(rows, width, xp, w.perm, t0, t1, m, out, s);
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
      fn(rows, width, xp, w.perm, w.group_begin[g], w.group_begin[g + 1], mask,
         v + static_cast<ptrdiff_t>(g) * w.out_stride + c0);
  }
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  switch (n) {
    case 1: avx2::project_groups(w, xp[0], v[0]); break;
    // Two frames gain nothing over the single-frame kernel (4 loads per 4 FMAs in a 16-column
    // slab, measured slower), so they take it twice.
    case 2:
      avx2::project_groups(w, xp[0], v[0]);
      avx2::project_groups(w, xp[1], v[1]);
      break;
    case 3: batch<3>(w, xp, v); break;
    case 4: batch<4>(w, xp, v); break;
    default: break;
  }
}

namespace {
// One output row held in NV registers while its weighted groups are added in.
template <int NV>
void combine_rows(const Combine& c, const float* v, int stride, float scale, float* out) {
  for (int r = 0; r < c.rows; ++r) {
    __m256 acc[NV];
    for (int i = 0; i < NV; ++i) acc[i] = _mm256_setzero_ps();
    for (int k = c.row_begin[r]; k < c.row_begin[r + 1]; ++k) {
      const __m256 wk = _mm256_set1_ps(c.weight[k] * scale);
      const float* vg = v + static_cast<ptrdiff_t>(c.group[k]) * stride;
      for (int i = 0; i < NV; ++i) acc[i] = _mm256_fmadd_ps(wk, _mm256_loadu_ps(vg + 8 * i), acc[i]);
    }
    for (int i = 0; i < NV; ++i) _mm256_storeu_ps(out + static_cast<ptrdiff_t>(r) * stride + 8 * i, acc[i]);
  }
}
}  // namespace

void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  switch (stride / 8) {
    case 1: return combine_rows<1>(c, v, stride, scale, out);
    case 2: return combine_rows<2>(c, v, stride, scale, out);
    case 3: return combine_rows<3>(c, v, stride, scale, out);
    case 4: return combine_rows<4>(c, v, stride, scale, out);
    case 5: return combine_rows<5>(c, v, stride, scale, out);
    case 6: return combine_rows<6>(c, v, stride, scale, out);
    case 7: return combine_rows<7>(c, v, stride, scale, out);
    case 8: return combine_rows<8>(c, v, stride, scale, out);
    default: break;
  }
  // Wider than 64 columns: 8 columns at a time, the sum kept in a register.
  for (int r = 0; r < c.rows; ++r)
    for (int i = 0; i < stride; i += 8) {
      __m256 acc = _mm256_setzero_ps();
      for (int k = c.row_begin[r]; k < c.row_begin[r + 1]; ++k)
        acc = _mm256_fmadd_ps(_mm256_set1_ps(c.weight[k] * scale),
                              _mm256_loadu_ps(v + static_cast<ptrdiff_t>(c.group[k]) * stride + i), acc);
      _mm256_storeu_ps(out + static_cast<ptrdiff_t>(r) * stride + i, acc);
    }
}

double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  __m256d s0 = _mm256_setzero_pd(), s1 = _mm256_setzero_pd();
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 y = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(x + i), _mm256_loadu_ps(a + i)), _mm256_loadu_ps(b + i));
    _mm256_storeu_ps(xn + i, y);
    const __m256d lo = _mm256_cvtps_pd(_mm256_castps256_ps128(y));
    const __m256d hi = _mm256_cvtps_pd(_mm256_extractf128_ps(y, 1));
    s0 = _mm256_fmadd_pd(lo, lo, s0);
    s1 = _mm256_fmadd_pd(hi, hi, s1);
  }
  alignas(32) double lanes[4];
  _mm256_store_pd(lanes, _mm256_add_pd(s0, s1));
  double sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  for (; i < n; ++i) {
    const float y = (x[i] - a[i]) * b[i];
    xn[i] = y;
    sum += static_cast<double>(y) * y;
  }
  return sum;
}

}  // namespace kata::metric::detail::avx2
