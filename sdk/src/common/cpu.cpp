#include "common/cpu.hpp"

#include <cstdlib>

namespace kata {

namespace {
bool switched_off(const char* variable) noexcept {
  const char* off = std::getenv(variable);
  return off && off[0] == '1';
}

bool detect_avx2() noexcept {
  if (switched_off("KATA_NO_AVX2")) return false;
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

bool detect_avx512() noexcept {
  if (!cpu_has_avx2() || switched_off("KATA_NO_AVX512")) return false;
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
         __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
         __builtin_cpu_supports("avx512vl");
#else
  return false;
#endif
}
}  // namespace

bool cpu_has_avx2() noexcept {
  static const bool has = detect_avx2();
  return has;
}

bool cpu_has_avx512() noexcept {
  static const bool has = detect_avx512();
  return has;
}

}  // namespace kata
