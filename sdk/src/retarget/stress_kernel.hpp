// The stress + gradient kernel, included by spg.cpp (baseline x86-64-v2) and spg_avx2.cpp
// (x86-64-v3: AVX2 + FMA, chosen at run time). Internal linkage on purpose: each translation unit
// keeps its own copy, compiled for its own instruction set.
#pragma once

#include <cmath>
#include <cstring>

#include "retarget/spg.hpp"

namespace kata::retarget {
namespace {  // NOLINT: one copy per including translation unit (different -march)

inline double stress_kernel(const StressInstance& in, const double* x, double* grad) {
  // Complete pair list in lexicographic order: row u holds pairs (u, u+1 .. n-1) contiguously,
  // so with SoA positions the inner loop runs over contiguous v (no gathers) and vectorises.
  const int n = in.joints;
  const double* px = x;
  const double* py = x + n;
  const double* pz = x + 2 * n;
  double* gx = grad;
  double* gy = grad ? grad + n : nullptr;
  double* gz = grad ? grad + 2 * n : nullptr;
  if (grad) std::memset(grad, 0, sizeof(double) * 3 * static_cast<size_t>(n));
  double f = 0.0;
  int row = 0;  // index of pair (u, u + 1)
  for (int u = 0; u + 1 < n; ++u) {
    const double xu = px[u], yu = py[u], zu = pz[u];
    const double* w = in.weight + row;  // w[v - u - 1] is pair (u, v)
    const double* dl = in.delta + row;
    double sx = 0.0, sy = 0.0, sz = 0.0;
    if (grad) {
#pragma omp simd reduction(+ : f, sx, sy, sz)
      for (int v = u + 1; v < n; ++v) {
        const double dx = xu - px[v], dy = yu - py[v], dz = zu - pz[v];
        const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
        const double e = r - dl[v - u - 1];
        const double we = w[v - u - 1] * e;
        f += we * e;
        // d sigma / d x_u = w (r - delta) (x_u - x_v) / r, undefined at r = 0. Dividing by
        // r + 1e-300 (= r for any r > 1e-284) keeps it branch-free, so the loop vectorises, and
        // finite: at r = 0, c is finite and dx = dy = dz = 0, so the pair adds 0 (a valid
        // subgradient choice); near 0, |c dx| <= w |e|.
        const double c = we / (r + 1e-300);
        sx += c * dx;
        sy += c * dy;
        sz += c * dz;
        gx[v] -= c * dx;
        gy[v] -= c * dy;
        gz[v] -= c * dz;
      }
      gx[u] += sx;
      gy[u] += sy;
      gz[u] += sz;
    } else {
#pragma omp simd reduction(+ : f)
      for (int v = u + 1; v < n; ++v) {
        const double dx = xu - px[v], dy = yu - py[v], dz = zu - pz[v];
        const double e = std::sqrt(dx * dx + dy * dy + dz * dz) - dl[v - u - 1];
        f += w[v - u - 1] * e * e;
      }
    }
    row += n - 1 - u;
  }
  return 0.5 * f;
}

// delta_p = tau_student_p |t_u - t_v| / tau_teacher_p for every pair, row by row over SoA teacher
// positions (contiguous reads; the rows vectorise). A teacher path of zero length (degenerate
// bones) carries no shape: the pair keeps the student's tau.
inline void targets_kernel(int n, const double* teacher_soa, const double* tau_student, const double* tau_teacher,
                           double* delta) {
  const double* tx = teacher_soa;
  const double* ty = tx + n;
  const double* tz = ty + n;
  int row = 0;
  for (int u = 0; u + 1 < n; ++u) {
    const double xu = tx[u], yu = ty[u], zu = tz[u];
    const int len = n - 1 - u;
#pragma omp simd
    for (int i = 0; i < len; ++i) {
      const int v = u + 1 + i;
      const double dx = xu - tx[v], dy = yu - ty[v], dz = zu - tz[v];
      const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
      const double tt = tau_teacher[row + i];
      delta[row + i] = tt > 0.0 ? tau_student[row + i] * dist / tt : tau_student[row + i];
    }
    row += len;
  }
}

}  // namespace
}  // namespace kata::retarget
