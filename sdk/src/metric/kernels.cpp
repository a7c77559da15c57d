// Baseline (x86-64-v2) projection kernels and the run-time dispatch to the AVX2+FMA ones.
#include "metric/kernels.hpp"

#include "common/cpu.hpp"

namespace kata::metric::detail {

namespace base {

void project_groups(const BlockedW& w, const float* xp, float* v) {
  for (int c0 = 0; c0 < w.rank; c0 += kChunk) {
    const int width = w.rank - c0 < kChunk ? w.rank - c0 : kChunk;
    const float* rows = w.data + static_cast<ptrdiff_t>(w.rows) * c0;
    for (int g = 0; g < w.groups; ++g) {
      // The accumulator row lives in L1; the compiler vectorises the column loop (SSE).
      float acc[kChunk] = {};
      for (int i = w.group_begin[g]; i < w.group_begin[g + 1]; ++i) {
        const float xi = xp[w.perm[i]];
        const float* row = rows + static_cast<ptrdiff_t>(i) * width;
        for (int c = 0; c < width; ++c) acc[c] += row[c] * xi;
      }
      float* out = v + static_cast<ptrdiff_t>(g) * w.out_stride + c0;
      const int padded = (width + 7) / 8 * 8;
      for (int c = 0; c < padded; ++c) out[c] = c < width ? acc[c] : 0.0f;
    }
  }
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  // The baseline has no register blocking to share; one frame after another.
  for (int f = 0; f < n; ++f) base::project_groups(w, xp[f], v[f]);
}

double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  // Eight independent partial sums: one serial double chain would cost n x add latency.
  double acc[8] = {};
  int i = 0;
  for (; i + 8 <= n; i += 8)
    for (int l = 0; l < 8; ++l) {
      const float y = (x[i + l] - a[i + l]) * b[i + l];
      xn[i + l] = y;
      acc[l] += static_cast<double>(y) * y;
    }
  double sum = ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
  for (; i < n; ++i) {
    const float y = (x[i] - a[i]) * b[i];
    xn[i] = y;
    sum += static_cast<double>(y) * y;
  }
  return sum;
}

void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  for (int r = 0; r < c.rows; ++r) {
    float* o = out + static_cast<ptrdiff_t>(r) * stride;
    for (int i = 0; i < stride; ++i) o[i] = 0.0f;
    for (int k = c.row_begin[r]; k < c.row_begin[r + 1]; ++k) {
      const float wk = c.weight[k] * scale;
      const float* vg = v + static_cast<ptrdiff_t>(c.group[k]) * stride;
      for (int i = 0; i < stride; ++i) o[i] += wk * vg[i];
    }
  }
}

}  // namespace base

void project_groups(const BlockedW& w, const float* xp, float* v) {
  if (cpu_has_avx2()) return avx2::project_groups(w, xp, v);
  base::project_groups(w, xp, v);
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  if (cpu_has_avx2()) return avx2::project_groups_batch(w, xp, v, n);
  base::project_groups_batch(w, xp, v, n);
}

void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  if (cpu_has_avx2()) return avx2::combine(c, v, stride, scale, out);
  base::combine(c, v, stride, scale, out);
}

double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  if (cpu_has_avx2()) return avx2::normalise(x, a, b, n, xn);
  return base::normalise(x, a, b, n, xn);
}

}  // namespace kata::metric::detail
