// GPD v1 static blocks, baseline kernel: xsimd on SSE4.2 (the x86-64-v2 build baseline).
#include <cstdint>

#include <xsimd/xsimd.hpp>

#include "gpd/gpd_detail.hpp"

namespace kata::gpd::detail::sse4 {

// The widest instruction set the baseline compile flags allow (SSE2 is part of x86-64).
#if defined(__SSE4_2__)
using Arch = xsimd::sse4_2;
#else
using Arch = xsimd::sse2;
#endif
// SSE has no lane permute with a run-time index: compactions go through index tables.
#define KATA_GPD_PERMUTE 0

#include "gpd/gpd_kernel.inl"
#undef KATA_GPD_PERMUTE

}  // namespace kata::gpd::detail::sse4
