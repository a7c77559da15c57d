// Run-time dispatch of the projection kernels to the widest instruction set the CPU runs.
#include "metric/kernels.hpp"

#include "common/cpu.hpp"

namespace kata::metric::detail {

void project_groups(const BlockedW& w, const float* xp, float* v) {
  if (cpu_has_avx512()) return avx512::project_groups(w, xp, v);
  if (cpu_has_avx2()) return avx2::project_groups(w, xp, v);
  base::project_groups(w, xp, v);
}

void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  if (cpu_has_avx512()) return avx512::project_groups_batch(w, xp, v, n);
  if (cpu_has_avx2()) return avx2::project_groups_batch(w, xp, v, n);
  base::project_groups_batch(w, xp, v, n);
}

void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  if (cpu_has_avx512()) return avx512::combine(c, v, stride, scale, out);
  if (cpu_has_avx2()) return avx2::combine(c, v, stride, scale, out);
  base::combine(c, v, stride, scale, out);
}

double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  if (cpu_has_avx512()) return avx512::normalise(x, a, b, n, xn);
  if (cpu_has_avx2()) return avx2::normalise(x, a, b, n, xn);
  return base::normalise(x, a, b, n, xn);
}

}  // namespace kata::metric::detail
