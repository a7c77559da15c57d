// GPD v1 internals shared by the reference implementation, the SIMD kernels and the tests:
// compile-time layout tables (spec sections 3 and 4) and the per-ISA kernel entry points.
// Not part of the public SDK surface.
#pragma once

#include <cstdint>

#include "gpd/gpd.hpp"

namespace kata::gpd::detail {

// Number of features in each block (spec section 4).
constexpr int kPairCount = kJoints * (kJoints - 1) / 2;   // JJd / JJo: 120
constexpr int kJLCount = kLines * (kJoints - 2);           // JLd: 420
constexpr int kLLCount = kLines * (kLines - 1) / 2;        // LLa: 435
constexpr int kJPCount = kPlanes * (kJoints - 3);          // JPd: 65
constexpr int kLPCount = kPlanes * (kLines - 3);           // LPa: 135 (3 lines per plane skipped)
constexpr int kPPCount = kPlanes * (kPlanes - 1) / 2;      // PPa: 10

// GPD skeleton parents (spec section 1) and the end sites in the order of section 3.
inline constexpr int8_t kParent[kJoints] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};
inline constexpr int8_t kEndSites[5] = {3, 6, 9, 12, 15};

// Every index table the kernels need, built once at compile time. Plain C arrays (not
// std::array) so that the AVX2 and baseline kernels index them without calling any shared
// inline function (see the ODR note in gpd_kernel.inl).
struct LayoutTables {
  int8_t line[kLines][2];        // spec section 3 lines, directed [0] -> [1]
  int8_t plane[kPlanes][3];      // spec section 3 planes (J1, J2, J3)
  int16_t pair_base[kJoints];    // JJ block: index of pair (i, i+1); pairs (i, j>i) follow contiguously
  int16_t line_pair_base[kLines];  // LLa block: index of pair (l, l+1); (l, m>l) follow contiguously
  int16_t line_pair[kLines];     // JJ pair index of each line's (first, second) joints (first < second)
  int16_t jl_src[kJLCount];      // JLd entry -> l * 16 + k (a [30][16] table of all joints per line)
  int16_t jp_src[kJPCount];      // JPd entry -> p * 16 + k (a [5][16] table)
  int16_t lp_src[kLPCount];      // LPa entry -> p * 32 + l (a [5][32] table)
  int8_t pp[kPPCount][2];        // PPa plane pairs (p, q), p < q
};

// Builds the tables by walking the spec's enumeration rules literally.
constexpr LayoutTables make_layout_tables() {
  LayoutTables t{};
  for (int c = 1; c < kJoints; ++c) {  // 0..14: bones parent -> child, by child index
    t.line[c - 1][0] = kParent[c];
    t.line[c - 1][1] = static_cast<int8_t>(c);
  }
  for (int e = 0; e < 5; ++e) {  // 15..19: grandparent -> end site
    t.line[15 + e][0] = kParent[kParent[kEndSites[e]]];
    t.line[15 + e][1] = kEndSites[e];
  }
  int l = 20;  // 20..29: end-site pairs, lexicographic
  for (int a = 0; a < 5; ++a) {
    for (int b = a + 1; b < 5; ++b, ++l) {
      t.line[l][0] = kEndSites[a];
      t.line[l][1] = kEndSites[b];
    }
  }
  for (int p = 0; p < kPlanes; ++p) {  // (grandparent, parent, end site) of each end site
    t.plane[p][2] = kEndSites[p];
    t.plane[p][1] = kParent[kEndSites[p]];
    t.plane[p][0] = kParent[kParent[kEndSites[p]]];
  }
  int base = 0;
  for (int i = 0; i < kJoints; ++i) {
    t.pair_base[i] = static_cast<int16_t>(base);
    base += kJoints - 1 - i;
  }
  base = 0;
  for (int i = 0; i < kLines; ++i) {
    t.line_pair_base[i] = static_cast<int16_t>(base);
    base += kLines - 1 - i;
  }
  for (int li = 0; li < kLines; ++li) {
    const int a = t.line[li][0], b = t.line[li][1];
    if (a >= b) throw "every line must run from a lower to a higher joint index";
    t.line_pair[li] = static_cast<int16_t>(t.pair_base[a] + (b - a - 1));
  }
  int n = 0;
  for (int li = 0; li < kLines; ++li) {
    for (int k = 0; k < kJoints; ++k) {
      if (k != t.line[li][0] && k != t.line[li][1]) t.jl_src[n++] = static_cast<int16_t>(li * 16 + k);
    }
  }
  // A skip rule that produced another count than the spec's is a compile error (throw is not
  // a constant expression); overcounting already fails on the out-of-bounds write.
  if (n != kJLCount) throw "JLd count";
  n = 0;
  for (int p = 0; p < kPlanes; ++p) {
    for (int k = 0; k < kJoints; ++k) {
      if (k != t.plane[p][0] && k != t.plane[p][1] && k != t.plane[p][2]) {
        t.jp_src[n++] = static_cast<int16_t>(p * 16 + k);
      }
    }
  }
  if (n != kJPCount) throw "JPd count";
  n = 0;
  for (int p = 0; p < kPlanes; ++p) {
    for (int li = 0; li < kLines; ++li) {
      bool a_in = false, b_in = false;
      for (int v = 0; v < 3; ++v) {
        a_in = a_in || t.line[li][0] == t.plane[p][v];
        b_in = b_in || t.line[li][1] == t.plane[p][v];
      }
      if (!(a_in && b_in)) t.lp_src[n++] = static_cast<int16_t>(p * 32 + li);
    }
  }
  if (n != kLPCount) throw "LPa count";
  n = 0;
  for (int p = 0; p < kPlanes; ++p) {
    for (int q = p + 1; q < kPlanes; ++q, ++n) {
      t.pp[n][0] = static_cast<int8_t>(p);
      t.pp[n][1] = static_cast<int8_t>(q);
    }
  }
  return t;
}

// The tables, evaluated by the compiler.
inline constexpr LayoutTables kLayout = make_layout_tables();

// Compaction of a skip block with 8-lane permutes (the AVX2 kernel): a row of the full table
// (16 joints or 32 lines, as 8-lane batches) becomes `Out` output batches; lane j of output
// batch k is lane idx[k][j] of input batch k, or of input batch k+1 where next[k][j] is -1.
// Possible because a row skips at most 3 entries, so output lane 8k+j reads input 8k+j..8k+j+3.
template <int Rows, int Out>
struct PermuteTable {
  int32_t idx[Rows][Out][8];
  int32_t next[Rows][Out][8];
};

// Builds the permute table of a skip block from its source table (row r's entries read
// r * row_in + s; row_out entries per row).
template <int Rows, int Out>
constexpr PermuteTable<Rows, Out> make_permute_table(const int16_t* src, int row_in, int row_out) {
  PermuteTable<Rows, Out> t{};
  for (int r = 0; r < Rows; ++r) {
    for (int k = 0; k < Out; ++k) {
      for (int j = 0; j < 8; ++j) {
        const int o = 8 * k + j;
        if (o >= row_out) continue;  // lanes past the row: don't care (overwritten by the next row)
        const int s = src[r * row_out + o] - r * row_in;
        if (s < 8 * k || s >= 8 * (k + 2) || (s >= 8 * (k + 1) && 8 * (k + 1) >= row_in)) throw "not a 2-batch window";
        t.idx[r][k][j] = s & 7;
        t.next[r][k][j] = s >= 8 * (k + 1) ? -1 : 0;
      }
    }
  }
  return t;
}

inline constexpr PermuteTable<kLines, 2> kJLPermute = make_permute_table<kLines, 2>(kLayout.jl_src, 16, kJoints - 2);
inline constexpr PermuteTable<kPlanes, 2> kJPPermute = make_permute_table<kPlanes, 2>(kLayout.jp_src, 16, kJoints - 3);
inline constexpr PermuteTable<kPlanes, 4> kLPPermute = make_permute_table<kPlanes, 4>(kLayout.lp_src, 32, kLines - 3);

// Which lanes of a full skip-block row are features (0x7fffffff: the sign-clearing mask of the
// kernels' largest-magnitude tracking) and which compaction drops (0): per line the joints that
// are not its endpoints (JLd), per plane the joints that are not its vertices (JPd).
template <int Rows>
struct FeatureLanes {
  alignas(64) uint32_t mask[Rows][16];
};
constexpr FeatureLanes<kLines> make_jl_feature_lanes() {
  FeatureLanes<kLines> t{};
  for (int n = 0; n < kJLCount; ++n) t.mask[kLayout.jl_src[n] / 16][kLayout.jl_src[n] % 16] = 0x7fffffffu;
  return t;
}
constexpr FeatureLanes<kPlanes> make_jp_feature_lanes() {
  FeatureLanes<kPlanes> t{};
  for (int n = 0; n < kJPCount; ++n) t.mask[kLayout.jp_src[n] / 16][kLayout.jp_src[n] % 16] = 0x7fffffffu;
  return t;
}
inline constexpr FeatureLanes<kLines> kJLFeatureLanes = make_jl_feature_lanes();
inline constexpr FeatureLanes<kPlanes> kJPFeatureLanes = make_jp_feature_lanes();

static_assert(kLayout.pair_base[kJoints - 1] == kPairCount, "JJ pair count");
static_assert(kLayout.line_pair_base[kLines - 1] == kLLCount, "LLa pair count");
static_assert(kOffsetJJd == kJcDims && kOffsetJJo == kOffsetJJd + kPairCount &&
                  kOffsetJLd == kOffsetJJo + 3 * kPairCount && kOffsetLLa == kOffsetJLd + kJLCount &&
                  kOffsetJPd == kOffsetLLa + kLLCount && kOffsetLPa == kOffsetJPd + kJPCount &&
                  kOffsetPPa == kOffsetLPa + kLPCount && kOffsetJk == kOffsetPPa + kPPCount &&
                  kStaticDims == kOffsetJk && kDims == kStaticDims + kKineticDims,
              "block offsets (spec section 4)");

// Blocks 1..8 in plain double precision, written directly from the spec's text: the second,
// independent implementation the tests check the fast kernels against. Same contract as
// gpd::static_features (reads and updates the plane-normal memory in `state`).
void static_features_reference(const float* local, float hip_height, GeometryState& state, double* out);
// The same from double local positions (tests: golden vectors without float32 input rounding).
void static_features_reference(const double* local, double hip_height, GeometryState& state, double* out);

// Largest |local coordinate| (body heights) the float32 kernels take; gpd::static_features
// sends frames beyond it to the reference (squares of 1e19 overflow float32).
constexpr float kFastPathExtent = 1e15f;

// The float32 SIMD kernels behind gpd::static_features. Each lives in its own namespace (and
// translation unit) so that no inline function is shared between the two instruction sets.
namespace sse4 {
// Baseline kernel (x86-64-v2: SSE4.2). Runs on every supported CPU.
// Returns largest_magnitude_bits(out, kStaticDims), tracked as the kernel writes (gpd.hpp).
uint32_t static_features(const float* local, float hip_height, GeometryState& state, float* out) noexcept;
uint32_t largest_magnitude_bits(const float* v, int n) noexcept;
}  // namespace sse4
namespace avx2 {
// True when this build contains the AVX2+FMA kernel (x86 builds).
bool compiled() noexcept;
// AVX2+FMA kernel (x86-64-v3). Call only when kata::cpu_has_avx2() and compiled().
uint32_t static_features(const float* local, float hip_height, GeometryState& state, float* out) noexcept;
uint32_t largest_magnitude_bits(const float* v, int n) noexcept;
}  // namespace avx2

}  // namespace kata::gpd::detail
