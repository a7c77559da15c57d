// Run-time CPU feature checks for kernels built above the x86-64-v2 baseline.
#pragma once

namespace kata {

// True when the CPU runs AVX2 + FMA code (x86-64-v3 kernels). Cached after the first call;
// [any thread]. Setting the environment variable KATA_NO_AVX2=1 forces the baseline path
// (used by tests to check both paths on one machine).
bool cpu_has_avx2() noexcept;

}  // namespace kata
