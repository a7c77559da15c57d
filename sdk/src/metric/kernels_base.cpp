// Baseline projection kernels: xsimd on the build's baseline instruction set (SSE4.2 for the
// x86-64-v2 build, NEON on aarch64; xsimd's default architecture).
#include <cstddef>

#include <xsimd/xsimd.hpp>

#include "metric/kernels.hpp"

namespace kata::metric::detail::base {

using Arch = xsimd::default_arch;

#include "metric/kernels_kernel.inl"

}  // namespace kata::metric::detail::base
