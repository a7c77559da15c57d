// Helpers shared by the GPD test files: running each fast kernel, naming dims, tolerances.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "common/cpu.hpp"
#include "gpd/gpd.hpp"
#include "gpd/gpd_detail.hpp"

namespace gpd_test {

using namespace kata::gpd;

// One of the float32 implementations of the static blocks.
enum class Path { kBaseline, kAvx2 };

// The paths this machine can run: the baseline always, AVX2 when the CPU has it (and
// KATA_NO_AVX2 is not set).
inline std::vector<Path> fast_paths() {
  std::vector<Path> paths{Path::kBaseline};
  if (detail::avx2::compiled() && kata::cpu_has_avx2()) paths.push_back(Path::kAvx2);
  return paths;
}

inline const char* path_name(Path p) { return p == Path::kAvx2 ? "avx2" : "baseline"; }

// Static blocks through one given kernel; returns the kernel's report of the largest magnitude
// it wrote.
inline uint32_t run_fast(Path p, const float* local, float hip, GeometryState& state, float* out) {
  if (p == Path::kAvx2) return detail::avx2::static_features(local, hip, state, out);
  return detail::sse4::static_features(local, hip, state, out);
}

// Block offsets in spec order (blocks 1..9 -> index 0..8).
inline const int kBlockOffsets[9] = {kOffsetJc, kOffsetJJd, kOffsetJJo, kOffsetJLd, kOffsetLLa,
                                     kOffsetJPd, kOffsetLPa, kOffsetPPa, kOffsetJk};

// Index 0..8 of the block holding dim d.
inline int block_index(int d) {
  int b = 0;
  while (b + 1 < 9 && d >= kBlockOffsets[b + 1]) ++b;
  return b;
}

// Name of the block holding dim d, for failure messages.
inline std::string block_of(int d) {
  static const char* names[] = {"Jc", "JJd", "JJo", "JLd", "LLa", "JPd", "LPa", "PPa", "Jk"};
  const int b = block_index(d);
  return std::string(names[b]) + "[" + std::to_string(d - kBlockOffsets[b]) + "] (dim " + std::to_string(d) + ")";
}

// True for the arccos blocks (LLa, LPa, PPa).
inline bool is_angle_dim(int d) {
  return (d >= kOffsetLLa && d < kOffsetJPd) || (d >= kOffsetLPa && d < kOffsetJk);
}

// Tolerance of a float32 value against the double reference (spec section 7 and the brief):
// 1e-5 in general; an arccos near 0 or pi amplifies the float rounding of its argument
// (d acos = dx / sin), so there the spec allows 1e-3.
inline double tolerance(int d, double reference) {
  if (is_angle_dim(d) && std::sin(reference) < 0.05) return 1e-3;
  return 1e-5;
}

}  // namespace gpd_test
