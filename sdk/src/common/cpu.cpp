#include "common/cpu.hpp"

#include <cstdlib>

namespace kata {

namespace {
bool detect_avx2() noexcept {
  if (const char* off = std::getenv("KATA_NO_AVX2"); off && off[0] == '1') return false;
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}
}  // namespace

bool cpu_has_avx2() noexcept {
  static const bool has = detect_avx2();
  return has;
}

}  // namespace kata
