// GPD v1 static blocks, AVX2+FMA kernel (compiled with -march=x86-64-v3 by kata_avx2_sources;
// called only after kata::cpu_has_avx2()).
#include <cstdint>

#include "gpd/gpd_detail.hpp"

#if defined(__AVX2__) && defined(__FMA__)
#include <xsimd/xsimd.hpp>

namespace kata::gpd::detail::avx2 {

using Arch = xsimd::fma3<xsimd::avx2>;
// Compactions and the JJo interleave use AVX2 lane permutes.
#define KATA_GPD_PERMUTE 1

#include "gpd/gpd_kernel.inl"
#undef KATA_GPD_PERMUTE

bool compiled() noexcept { return true; }

}  // namespace kata::gpd::detail::avx2

#else  // not an x86 build: no AVX2 kernel; the dispatcher never calls it.

namespace kata::gpd::detail::avx2 {

bool compiled() noexcept { return false; }

uint32_t static_features(const float* local, float hip_height, GeometryState& state, float* out) noexcept {
  return sse4::static_features(local, hip_height, state, out);
}

uint32_t largest_magnitude_bits(const float* v, int n) noexcept { return sse4::largest_magnitude_bits(v, n); }

}  // namespace kata::gpd::detail::avx2

#endif
