// GPD v1 static blocks, baseline kernel: xsimd on the build's baseline instruction set (SSE4.2 for
// the x86-64-v2 build, NEON on aarch64).
#include <cstdint>

#include <xsimd/xsimd.hpp>

#include "gpd/gpd_detail.hpp"

namespace kata::gpd::detail::sse4 {

// The widest instruction set the baseline compile flags allow (SSE4.2 on x86-64-v2, NEON on
// aarch64; xsimd's default architecture).
using Arch = xsimd::default_arch;
// SSE has no lane permute with a run-time index: compactions go through index tables.
#define KATA_GPD_PERMUTE 0

#include "gpd/gpd_kernel.inl"
#undef KATA_GPD_PERMUTE

}  // namespace kata::gpd::detail::sse4
