// The stress kernel compiled for x86-64-v3 (AVX2 + FMA): 4 pairs per instruction instead of 2.
// Called only after kata::cpu_has_avx2() (spg.cpp). (A variant with a float reciprocal
// square-root estimate and Newton steps instead of the square root and division was slower here:
// docs/performance.md.)
#include "retarget/stress_kernel.hpp"
#include "retarget/spg_solver.inl"

namespace kata::retarget {

// Same contract as stress() (spg.hpp).
double detail::stress_avx2(const StressInstance& in, const double* x, double* grad) { return stress_kernel(in, x, grad); }

void detail::targets_avx2(int n, const double* t, const double* tau_s, const double* tau_t, double* delta) {
  targets_kernel(n, t, tau_s, tau_t, delta);
}

void detail::rotate_pairs_avx2(SpgWork& work, const double* r) { rotate_pairs(work, r); }

SpgResult detail::minimize_avx2(SpgWork& work, const StressInstance& in, double* x, const SpgOptions& opt) {
  return spg_minimize(work, in, x, opt, detail::stress_avx2);
}

}  // namespace kata::retarget
