// The re-localising alignment's pass over the whole practice section (docs/model/alignment.md): each student
// frame is compared with every teacher frame of the section, the largest per-frame cost of a
// clip lesson after the ghost (1,829 teacher frames in the default lesson). Kept apart from the
// scoring kernels: the pass is plain distances over contiguous rows, and its AVX2 form needs
// none of the projection's machinery.
#pragma once

#include <cstdint>

namespace kata::metric::detail {

// The live aligner's pass: the rows held in IEEE half precision, each divided by a power of two
// `scale` first (Reference::alignment_rows_half), which halves the bytes the pass reads from
// memory when a paced frame finds the caches cold (410 KB -> 205 KB for the default lesson).
// out[j] = scale * sqrt(sum over c of (s_scaled[c] - half_to_float(rows[j * stride + c]))^2), with
// s_scaled = s / scale (the caller's), for j < m; eight partial sums added in dist2f's order, no
// fused multiply-adds: equal bit for bit on every CPU. stride is a multiple of 8. Dispatches at
// run time (common/cpu.hpp), as do the two functions of the dynamic programme below.
void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out);

// IEEE binary16 conversions (round to nearest even; exact the other way), for machines without F16C.
uint16_t float_to_half(float f);
float half_to_float(uint16_t h);

// One frame of the alignment's dynamic programme over the section [a, b] (align.cpp says what
// the costs mean): cur[j] = c[j] + the least of `jump` and, for k <= k_max, prev[j - k] + pk[k]
// (j - k counted from the section's end when `loop`); then alignment_rebase. Dispatches.
int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop);
// Subtracts the least cur[j], j in [a, b], from all of them; returns its index (the first).
int alignment_rebase(double* cur, int a, int b);
// alignment_step's costs for the frames lo..hi of the section [a, b] only, not re-based (prev
// whole): equal bit for bit to alignment_step's there, so a step can be taken slice by slice
// and re-based once at the end. Dispatches.
void alignment_step_range(const double* prev, double* cur, const float* c, int a, int b, int lo, int hi,
                          const double* pk, int k_max, double jump, bool loop);

// The scorer's subtraction of a teacher's 16-bit row (Reference::subtract_projection): row[c] -=
// step * q[c] for c < n, a result within 0.51 steps taken as 0 (why: reference.cpp). Separate
// multiply and subtract: equal bit for bit on every CPU. Dispatches (AVX2 converts and compares
// 8 values an instruction where the baseline does 4: 0.15 us of a 6.4 us score otherwise).
void subtract_rows16(float* row, const int16_t* q, float step, int n);

namespace base {
void subtract_rows16(float* row, const int16_t* q, float step, int n);
void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out);
int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop);
int alignment_rebase(double* cur, int a, int b);
void alignment_step_range(const double* prev, double* cur, const float* c, int a, int b, int lo, int hi,
                          const double* pk, int k_max, double jump, bool loop);
}
namespace avx2 {
void subtract_rows16(float* row, const int16_t* q, float step, int n);
void alignment_distances_half(const float* s_scaled, const uint16_t* rows, int m, int stride, float scale, float* out);
int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop);
int alignment_rebase(double* cur, int a, int b);
void alignment_step_range(const double* prev, double* cur, const float* c, int a, int b, int lo, int hi,
                          const double* pk, int k_max, double jump, bool loop);
}

}  // namespace kata::metric::detail
