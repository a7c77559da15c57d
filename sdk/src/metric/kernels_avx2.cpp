// AVX2+FMA projection kernels (compiled with -march=x86-64-v3 by kata_avx2_sources; called only
// after kata::cpu_has_avx2()). On other CPU families this TU forwards to the baseline.
#include <cstddef>

#include "metric/kernels.hpp"

#if defined(__AVX2__) && defined(__FMA__)
#include <xsimd/xsimd.hpp>

namespace kata::metric::detail::avx2 {

using Arch = xsimd::fma3<xsimd::avx2>;

#include "metric/kernels_kernel.inl"

}  // namespace kata::metric::detail::avx2

#else  // not an x86 build: the dispatcher never calls these.

namespace kata::metric::detail::avx2 {
void project_groups(const BlockedW& w, const float* xp, float* v) { base::project_groups(w, xp, v); }
void project_groups_batch(const BlockedW& w, const float* const* xp, float* const* v, int n) {
  base::project_groups_batch(w, xp, v, n);
}
double normalise(const float* x, const float* a, const float* b, int n, float* xn) {
  return base::normalise(x, a, b, n, xn);
}
double dot(const float* a, const float* b, int n) { return base::dot(a, b, n); }
void combine(const Combine& c, const float* v, int stride, float scale, float* out) {
  base::combine(c, v, stride, scale, out);
}
}  // namespace kata::metric::detail::avx2

#endif
