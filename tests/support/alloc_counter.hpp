// Counts heap allocations (operator new in every form, and malloc/calloc/realloc, which Eigen and C
// code use), for the tests that prove a path allocates nothing. Link the test with
// kata_test_alloc (an object library: the replacement functions must be in the binary).
// Under AddressSanitizer or ThreadSanitizer, which own malloc, counting is off and kAllocCounting is false: such
// tests skip themselves.
#pragma once

// GCC says __SANITIZE_*__; clang answers __has_feature.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define KATA_SANITIZER_OWNS_MALLOC 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define KATA_SANITIZER_OWNS_MALLOC 1
#endif
#endif

namespace kata::test {
#if defined(KATA_SANITIZER_OWNS_MALLOC)
constexpr bool kAllocCounting = false;
#else
constexpr bool kAllocCounting = true;
#endif
// Allocations so far in this process, every thread (0 when counting is off).
long allocations();
// Convenience pair: arm_alloc_counter() remembers the count, disarm_alloc_counter() returns the
// allocations since (not nestable).
void arm_alloc_counter();
long disarm_alloc_counter();
}  // namespace kata::test
