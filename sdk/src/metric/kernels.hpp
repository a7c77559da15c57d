// Projection kernels of the scorer: the only hot loops of scoring. Plain C++ types only (no
// Eigen). Written once over xsimd (kernels_kernel.inl) and compiled three times: the baseline
// (SSE4.2 on x86-64-v2, NEON on aarch64), AVX2+FMA (x86-64-v3) and AVX-512 (x86-64-v4), each in
// its own translation unit; the functions below dispatch at run time (common/cpu.hpp).
#pragma once

#include <cstddef>
#include <cstdint>

namespace kata::metric::detail {

// Columns per chunk of the blocked W (a chunk's accumulators must fit 8 vector registers on AVX2).
constexpr int kChunk = 64;
// Frames projected together by the batched kernel (each W row is loaded once for all of them on
// AVX-512; the 16-register ISAs pass over W once per 4 of them).
constexpr int kBatch = 8;

// W in the scorer's layout. Rows (feature dimensions) are permuted so that the dimensions of
// one part group (see parts.hpp) are contiguous: group g owns rows [group_begin[g],
// group_begin[g+1]), and row k multiplies input element perm[k] (the input stays in feature
// order: one index load per row is cheaper than gathering the input into row order). Columns
// are split into chunks of kChunk (the last one narrower); chunk c
// holds columns [c*kChunk, c*kChunk + width_c) row-major and unpadded (row stride width_c),
// starting at data + rows * c * kChunk. Unpadded rows keep the bytes streamed per frame at
// exactly rows x rank values, the limit of a memory-bound product.
//
// Values are 16-bit integers with one scale per column: W[k, c] = data[k, c] *
// column_scale[c], the scale max_k |W[k, c]| / 32767, so every weight is within half a step
// (2^-16 of its column's largest) of the model's float. Half the bytes of float W: the product is
// bound by the bytes it reads (from L2 when hot, from memory when a paced frame finds the caches
// cold), and the kernels convert in registers. Each output column is multiplied by its scale
// once, after the last row.
//
// The AVX-512 kernels read the same W packed two columns to a 32-bit word (`pairs`, built by
// Metric at load when the CPU runs them; null otherwise, and those kernels then read `data`). Per
// chunk of width w, h = pair_words(w) words per row (chunk c starts at pairs + rows * c * kChunk
// / 2; pair_index places a word): word k holds column k in its low half and column k + h in its
// high half (0 when k + h = w). A chunk is two blocks: words 0..15 of every row (16 a row), then
// words 16..h-1 (h - 16 a row), so that with `pairs` 64-byte aligned the first 16 words of a row
// are one aligned cache line (rows of 25 words, rank 50, make nearly every 64-byte load span two
// lines; the blocks made the 8-frame batch 3% faster). Decoding: the low column's integer is the
// low half; the high column's weight in steps is float(int32(word)) / 2^16, i.e. the high half
// plus the low half's bits / 2^16, and pack_pair chose the high integer against those bits, so
// both are within half a step (plus the float rounding of a 32-bit conversion, 2^-9 step at
// most) of the model's float. The 16 words after W (kPairPadding) are read, never used. Why: on a core
// whose 512-bit conversions share the multiply-add ports, one byte shuffle and two conversions
// decode 32 columns where two widenings and two conversions decode them from 16-bit integers (5
// vector operations per 32 columns instead of 6), the same bytes per row. The weights differ from
// `data`'s by up to a step, so each ISA is exact to its own W (Metric::weights()).
struct BlockedW {
  const int16_t* data = nullptr;
  const uint32_t* pairs = nullptr;      // the AVX-512 kernels' copy of W (above), or null
  const float* column_scale = nullptr;  // rank floats
  int rows = 0;
  int rank = 0;
  int out_stride = 0;  // floats per output row of V: rank rounded up to a multiple of 8
  int groups = 0;
  const int* group_begin = nullptr;  // groups + 1 entries
  const int* perm = nullptr;         // rows entries: the input element row k multiplies
};

// Words per row of a pair-packed chunk of `width` columns, and 32-bit words of a whole W
// followed by kPairPadding words the AVX-512 kernels may read (whole 16-word vectors past a
// narrow chunk's last row; the lanes they feed are never stored).
constexpr int pair_words(int width) { return (width + 1) / 2; }
constexpr int kPairPadding = 16;
constexpr size_t pair_words_total(int rows, int rank) {
  return static_cast<size_t>(rows) *
             (static_cast<size_t>(rank / kChunk) * (kChunk / 2) + static_cast<size_t>(pair_words(rank % kChunk))) +
         kPairPadding;
}
// Index, from its chunk's start, of word j of row k in a chunk of h words per row (kernels.hpp BlockedW).
constexpr size_t pair_index(int rows, int h, int k, int j) {
  return j < 16 ? static_cast<size_t>(k) * static_cast<size_t>(h < 16 ? h : 16) + static_cast<size_t>(j)
                : static_cast<size_t>(rows) * 16 + static_cast<size_t>(k) * static_cast<size_t>(h - 16) +
                      static_cast<size_t>(j - 16);
}
// One word from two weights in steps of their columns (|.| <= 32767): the low column rounded to
// its integer, the high one's integer chosen against the low half's bits (the closest decoded value).
uint32_t pack_pair(double low_steps, double high_steps);
// The weights, in steps, the AVX-512 kernels apply for a word (exact: the kernels' own conversions).
float pair_low(uint32_t word);
float pair_high(uint32_t word);
// `pairs` (pair_words_total(rows, rank) words) from W in steps laid out as BlockedW::data.
void pack_pairs(const double* steps, int rows, int rank, uint32_t* pairs);
// Weight (in steps) of row k, column c (c < rank) as the pair-packed W holds it.
float paired_weight(const uint32_t* pairs, int rows, int rank, int k, int c);

// V (groups x out_stride floats, padding columns written as 0) = for each group g, the partial
// product (sum over its rows k of xn[perm[k]] * data[k, :]) * column_scale. xn: rows floats in
// feature order.
void project_groups(const BlockedW& w, const float* xp, float* v);
// The same for n <= kBatch vectors at once: xp[f], v[f] for f < n.
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
// How per-group products combine into output rows: output row r is the sum over k in
// [row_begin[r], row_begin[r+1]) of weight[k] * V_{group[k]}.
struct Combine {
  int rows = 0;
  const int* row_begin = nullptr;  // rows + 1 entries
  const int* group = nullptr;
  const float* weight = nullptr;
};
// out (c.rows x stride floats) = the combination above of v (groups x stride), times `scale`.
// stride is a multiple of 8.
void combine(const Combine& c, const float* v, int stride, float scale, float* out);

// a . b over n floats (n a multiple of 8), in double: eight lanes summed pairwise, the same
// rounding on every ISA (also declared in metric.hpp, where the scorer finds it).
double dot(const float* a, const float* b, int n);

// xn[i] = (x[i] - a[i]) * b[i] for i < n; returns the sum of xn[i]^2 (accumulated in double).
double normalise(const float* x, const float* a, const float* b, int n, float* xn);

// The implementations behind the dispatching functions above. avx2:: and avx512:: may only be
// called when cpu_has_avx2() / cpu_has_avx512() (on other CPU families they forward to base::).
// Within one implementation project_groups_batch equals project_groups bit for bit; across
// implementations results differ by float summation order and fused multiply-adds only.
namespace base {
double dot(const float* a, const float* b, int n);
void project_groups(const BlockedW& w, const float* xp, float* v);
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
double normalise(const float* x, const float* a, const float* b, int n, float* xn);
void combine(const Combine& c, const float* v, int stride, float scale, float* out);
}  // namespace base
namespace avx2 {
double dot(const float* a, const float* b, int n);
void project_groups(const BlockedW& w, const float* xp, float* v);
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
double normalise(const float* x, const float* a, const float* b, int n, float* xn);
void combine(const Combine& c, const float* v, int stride, float scale, float* out);
}  // namespace avx2
namespace avx512 {
double dot(const float* a, const float* b, int n);
void project_groups(const BlockedW& w, const float* xp, float* v);
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n);
double normalise(const float* x, const float* a, const float* b, int n, float* xn);
void combine(const Combine& c, const float* v, int stride, float scale, float* out);
}  // namespace avx512

}  // namespace kata::metric::detail
