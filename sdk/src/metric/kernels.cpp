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
        const float xi = xp[i];
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

double gather_normalise(const float* x, const int* perm, const float* a, const float* b, int n, float* xp) {
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const float y = (x[perm[k]] - a[k]) * b[k];
    xp[k] = y;
    sum += static_cast<double>(y) * y;
  }
  return sum;
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

double gather_normalise(const float* x, const int* perm, const float* a, const float* b, int n, float* xp) {
  if (cpu_has_avx2()) return avx2::gather_normalise(x, perm, a, b, n, xp);
  return base::gather_normalise(x, perm, a, b, n, xp);
}

}  // namespace kata::metric::detail
