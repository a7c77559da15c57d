// Replaces the global operator new/delete of test_io to count allocations. In its own
// translation unit so the compiler cannot inline new/delete pairs into a false
// -Wmismatched-new-delete. Eigen's fixed-size types never touch the heap, so counting
// operator new covers the FK code; heap Eigen matrices would go through malloc uncounted.
#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<long> g_new_calls{0};
}

long test_new_calls() { return g_new_calls.load(); }

void* operator new(std::size_t n) {
  ++g_new_calls;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return ::operator new(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
