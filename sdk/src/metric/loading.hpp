// What loading a long teacher (docs/model/alignment.md) is built from: work started beside the calling thread,
// and transparent huge pages for the large arrays it is loaded into (its BVH text and motion, its
// Reference's rows). Each first touch of a 4 KB page costs a page fault; filling 200 MB that way
// took 600-750 ms on the 2-core VM the figures come from (about 12 us a fault,
// docs/model/alignment.md "Loading"), against 18 ms with 2 MB pages, and made up a third of a
// long teacher's load. (Here and not in common/ because only these loaders use it.)
#pragma once

#include <cstddef>
#include <cstdint>
#include <future>
#include <memory>
#include <system_error>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace kata {

// f() started on a thread of its own; where no thread can be started (a process at its thread
// limit), left to run in the caller's get() instead: the same result, only not beside the caller.
template <class F>
std::future<void> start_beside(F&& f) {
  try {
    return std::async(std::launch::async, std::forward<F>(f));
  } catch (const std::system_error&) {
    return std::async(std::launch::deferred, std::forward<F>(f));
  }
}

// Advises the kernel to back the 2 MB-aligned part of [p, p + bytes) with huge pages. Call it
// before the memory is first written (after reserve(), before resize()): pages already touched
// stay 4 KB. A hint only: without Linux, or with transparent huge pages set to "never", nothing
// changes, and a range under 2 MB is left alone.
inline void advise_huge_pages(const void* p, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHuge = uintptr_t{2} << 20;
  const uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHuge - 1);
  if (p && end > begin) (void)::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

// An array of n trivially constructible values, left uninitialised and advised huge pages: its
// pages are first touched (and cleared by the kernel) where it is first written, e.g. on the
// thread that fills it, not by a zero fill in the thread that sizes it. Every element must be
// written before it is read.
template <class T>
class LargeArray {
 public:
  LargeArray() = default;
  explicit LargeArray(size_t n) : p_(new T[n]), n_(n) { advise_huge_pages(p_.get(), n * sizeof(T)); }
  T* data() { return p_.get(); }
  const T* data() const { return p_.get(); }
  size_t size() const { return n_; }
  T& operator[](size_t i) { return p_[i]; }
  const T& operator[](size_t i) const { return p_[i]; }

 private:
  std::unique_ptr<T[]> p_;
  size_t n_ = 0;
};

}  // namespace kata
