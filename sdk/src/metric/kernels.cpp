// Run-time dispatch of the projection kernels to the widest instruction set the CPU runs.
#include "metric/kernels.hpp"

#include <algorithm>
#include <cmath>

#include "common/cpu.hpp"

namespace kata::metric::detail {

void project_groups(const BlockedW& w, const float* xp, float* v) {
  if (cpu_has_avx512()) return avx512::project_groups(w, xp, v);
  if (cpu_has_avx2()) return avx2::project_groups(w, xp, v);
  base::project_groups(w, xp, v);
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  if (cpu_has_avx512()) return avx512::project_groups_batch(w, xp, v, n);
  if (cpu_has_avx2()) return avx2::project_groups_batch(w, xp, v, n);
  base::project_groups_batch(w, xp, v, n);
}

void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  if (cpu_has_avx512()) return avx512::combine(c, v, stride, scale, out);
  if (cpu_has_avx2()) return avx2::combine(c, v, stride, scale, out);
  base::combine(c, v, stride, scale, out);
}

// (metric.hpp) The projection rows' dot products, on the widest ISA: bit-identical on every one.
double dot(const float* a, const float* b, int n) {
  if (cpu_has_avx512()) return avx512::dot(a, b, n);
  if (cpu_has_avx2()) return avx2::dot(a, b, n);
  return base::dot(a, b, n);
}

double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  if (cpu_has_avx512()) return avx512::normalise(x, a, b, n, xn);
  if (cpu_has_avx2()) return avx2::normalise(x, a, b, n, xn);
  return base::normalise(x, a, b, n, xn);
}

// ---------------------------------------------------------------------------------------------
// The pair-packed W of the AVX-512 kernels (kernels.hpp BlockedW). Plain C++: float(int32) here
// rounds as the kernels' vcvtdq2ps does (to nearest, the default rounding mode).

float pair_low(uint32_t word) { return static_cast<float>(static_cast<int16_t>(word & 0xFFFFu)); }

float pair_high(uint32_t word) { return static_cast<float>(static_cast<int32_t>(word)) / 65536.0f; }

uint32_t pack_pair(double low_steps, double high_steps) {
  const uint32_t low = static_cast<uint16_t>(static_cast<int16_t>(std::clamp(std::nearbyint(low_steps), -32767.0, 32767.0)));
  // The word converts to high x 2^16 + low's bits (as an unsigned 16-bit value): the high integer
  // is taken low / 2^16 below the target, then the closest of its neighbours after the conversion's
  // own rounding (which moves a word above 2^24 by up to 2^7, 2^-9 step).
  const double first = std::nearbyint(high_steps - static_cast<double>(low) / 65536.0);
  uint32_t best = 0;
  double best_error = 0.0;
  for (double high = first - 1.0; high <= first + 1.0; high += 1.0) {
    const double clamped = std::clamp(high, -32768.0, 32767.0);
    const uint32_t word = (static_cast<uint32_t>(static_cast<int32_t>(clamped)) << 16) | low;
    const double error = std::abs(static_cast<double>(pair_high(word)) - high_steps);
    if (high == first - 1.0 || error < best_error) {
      best = word;
      best_error = error;
    }
  }
  return best;
}

void pack_pairs(const double* steps, int rows, int rank, uint32_t* pairs) {
  for (int c0 = 0; c0 < rank; c0 += kChunk) {
    const int width = std::min(kChunk, rank - c0);
    const int h = pair_words(width);
    const double* src = steps + static_cast<size_t>(rows) * c0;
    uint32_t* dst = pairs + static_cast<size_t>(rows) * (c0 / 2);
    for (int k = 0; k < rows; ++k)
      for (int j = 0; j < h; ++j) {
        const double* row = src + static_cast<size_t>(k) * width;
        dst[pair_index(rows, h, k, j)] = pack_pair(row[j], j + h < width ? row[j + h] : 0.0);
      }
  }
}

float paired_weight(const uint32_t* pairs, int rows, int rank, int k, int c) {
  const int c0 = c / kChunk * kChunk;
  const int h = pair_words(std::min(kChunk, rank - c0));
  const int j = c - c0;
  const uint32_t word = pairs[static_cast<size_t>(rows) * (c0 / 2) + pair_index(rows, h, k, j < h ? j : j - h)];
  return j < h ? pair_low(word) : pair_high(word);
}

}  // namespace kata::metric::detail
