#include "metric/align_pass.hpp"

#include <algorithm>
#include <cmath>

#include "common/cpu.hpp"
#include "metric/metric.hpp"

namespace kata::metric::detail {

namespace base {
void alignment_distances(const float* s, const float* rows, int m, int stride, float* out) {
  for (int j = 0; j < m; ++j) out[j] = std::sqrt(dist2f(s, rows + static_cast<size_t>(j) * stride, stride));
}
#include "metric/align_pass_kernel.inl"
}  // namespace base

void alignment_distances(const float* s, const float* rows, int m, int stride, float* out) {
  if (cpu_has_avx2()) return avx2::alignment_distances(s, rows, m, stride, out);
  base::alignment_distances(s, rows, m, stride, out);
}

int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop) {
  if (cpu_has_avx2()) return avx2::alignment_step(prev, cur, c, a, b, pk, k_max, jump, loop);
  return base::alignment_step(prev, cur, c, a, b, pk, k_max, jump, loop);
}

int alignment_rebase(double* cur, int a, int b) {
  if (cpu_has_avx2()) return avx2::alignment_rebase(cur, a, b);
  return base::alignment_rebase(cur, a, b);
}

}  // namespace kata::metric::detail
