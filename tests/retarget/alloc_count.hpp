// Heap allocation counter for test_retarget (operator new and malloc; see alloc_count.cpp).
#pragma once

namespace kata_test {
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kRetargetAllocCounting = false;  // AddressSanitizer owns malloc: no counting
#else
constexpr bool kRetargetAllocCounting = true;
#endif
// Allocations so far in this process (0 when counting is off).
long retarget_allocations();
}  // namespace kata_test
