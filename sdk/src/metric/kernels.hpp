// Projection kernels of the scorer: the only hot loops of scoring. Plain C++ types only (no
// Eigen): the AVX2 variants live in their own translation unit compiled for x86-64-v3.
#pragma once

#include <cstddef>

namespace kata::metric::detail {

// Columns per chunk of the blocked W (a chunk's accumulators must fit the 16 ymm registers).
constexpr int kChunk = 64;
// Frames projected together by the batched kernel (each W row is loaded once for all of them).
constexpr int kBatch = 4;

// W in the scorer's layout. Rows (feature dimensions) are permuted so that the dimensions of
// one part group (see parts.hpp) are contiguous: group g owns rows [group_begin[g],
// group_begin[g+1]). Columns are split into chunks of kChunk (the last one narrower); chunk c
// holds columns [c*kChunk, c*kChunk + width_c) row-major and unpadded (row stride width_c),
// starting at data + rows * c * kChunk. Unpadded rows keep the bytes streamed per frame at
// exactly rows x rank floats, the limit of a memory-bound product.
struct BlockedW {
  const float* data = nullptr;
  int rows = 0;
  int rank = 0;
  int out_stride = 0;  // floats per output row of V: rank rounded up to a multiple of 8
  int groups = 0;
  const int* group_begin = nullptr;  // groups + 1 entries
};

// V (groups x out_stride floats, padding columns written as 0) = for each group g, the partial
// product W_g^T xp_g over its rows. xp: rows floats in the permuted order.
void project_groups(const BlockedW& w, const float* xp, float* v);
// The same for n <= kBatch vectors at once: xp[f], v[f] for f < n.
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
// xp[k] = (x[perm[k]] - a[k]) * b[k] for k < n; returns sum of xp[k]^2 (accumulated in double).
double gather_normalise(const float* x, const int* perm, const float* a, const float* b, int n, float* xp);

// The baseline (x86-64-v2) and AVX2+FMA implementations behind the dispatching functions above.
namespace base {
void project_groups(const BlockedW& w, const float* xp, float* v);
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
double gather_normalise(const float* x, const int* perm, const float* a, const float* b, int n, float* xp);
}  // namespace base
namespace avx2 {
void project_groups(const BlockedW& w, const float* xp, float* v);
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
double gather_normalise(const float* x, const int* perm, const float* a, const float* b, int n, float* xp);
}  // namespace avx2

}  // namespace kata::metric::detail
