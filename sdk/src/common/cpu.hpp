// Run-time CPU feature checks for kernels built above the x86-64-v2 baseline.
#pragma once

namespace kata {

// True when the CPU runs AVX2 + FMA code (x86-64-v3 kernels). Cached after the first call;
// [any thread]. Setting the environment variable KATA_NO_AVX2=1 forces the baseline path
// (used by tests to check both paths on one machine); it also switches AVX-512 off.
bool cpu_has_avx2() noexcept;

// True when the CPU runs x86-64-v4 code (AVX-512 F, BW, CD, DQ, VL) and AVX2 is on. Cached;
// [any thread]. KATA_NO_AVX512=1 forces the AVX2 (or baseline) path. Always false off x86.
bool cpu_has_avx512() noexcept;

}  // namespace kata
