#include "metric/align_pass.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/cpu.hpp"

namespace kata::metric::detail {

uint16_t float_to_half(float f) {
  uint32_t x = 0;
  std::memcpy(&x, &f, sizeof x);
  const auto sign = static_cast<uint16_t>((x >> 16) & 0x8000u);
  x &= 0x7fffffffu;
  if (x > 0x7f800000u) return static_cast<uint16_t>(sign | 0x7e00u);  // NaN
  if (x >= 0x477ff000u) return static_cast<uint16_t>(sign | 0x7c00u);  // rounds beyond 65504: infinity
  if (x < 0x38800000u) {  // below 2^-14: a subnormal half, a multiple of 2^-24 (exact scaling)
    const float a = std::fabs(f) * 16777216.0f;
    return static_cast<uint16_t>(sign | static_cast<uint16_t>(std::nearbyint(a)));
  }
  uint32_t h = ((((x >> 23) - 112u) << 10) | ((x & 0x7fffffu) >> 13));
  const uint32_t rest = x & 0x1fffu;
  if (rest > 0x1000u || (rest == 0x1000u && (h & 1u))) ++h;  // a carry into the exponent is right
  return static_cast<uint16_t>(sign | h);
}

float half_to_float(uint16_t h) {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
  float f = 0.0f;
  if (e == 0) {
    f = std::ldexp(static_cast<float>(m), -24);  // zero and subnormals: exact
    if (sign) f = -f;
    return f;
  }
  const uint32_t bits = sign | (e == 31 ? (0xffu << 23) | (m << 13) : ((e + 112u) << 23) | (m << 13));
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

namespace base {
void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out) {
  for (int j = 0; j < m; ++j) {
    const uint16_t* r = rows + static_cast<size_t>(j) * stride;
    float acc[8] = {};
    for (int c = 0; c < stride; c += 8)
      for (int l = 0; l < 8; ++l) {
        const float e = s_scaled[c + l] - half_to_float(r[c + l]);
        acc[l] += e * e;
      }
    out[j] = scale * std::sqrt(((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])));
  }
}

#include "metric/align_pass_kernel.inl"
}  // namespace base

void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out) {
  if (cpu_has_avx2()) return avx2::alignment_distances_half(s_scaled, rows, m, stride, scale, out);
  base::alignment_distances_half(s_scaled, rows, m, stride, scale, out);
}

int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop) {
  if (cpu_has_avx2()) return avx2::alignment_step(prev, cur, c, a, b, pk, k_max, jump, loop);
  return base::alignment_step(prev, cur, c, a, b, pk, k_max, jump, loop);
}

void alignment_step_range(const double* prev, double* cur, const float* c, int a, int b, int lo, int hi,
                          const double* pk, int k_max, double jump, bool loop) {
  if (cpu_has_avx2()) return avx2::alignment_step_range(prev, cur, c, a, b, lo, hi, pk, k_max, jump, loop);
  base::alignment_step_range(prev, cur, c, a, b, lo, hi, pk, k_max, jump, loop);
}

void subtract_rows16(float* row, const int16_t* q, float step, int n) {
  if (cpu_has_avx2()) return avx2::subtract_rows16(row, q, step, n);
  base::subtract_rows16(row, q, step, n);
}

int alignment_rebase(double* cur, int a, int b) {
  if (cpu_has_avx2()) return avx2::alignment_rebase(cur, a, b);
  return base::alignment_rebase(cur, a, b);
}

}  // namespace kata::metric::detail
