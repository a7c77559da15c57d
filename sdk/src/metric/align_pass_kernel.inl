// The alignment's per-frame loops (align_pass.hpp), and the scorer's subtraction of a teacher's
// 16-bit rows, written once as plain loops and compiled in each instruction set's translation
// unit (align_pass.cpp, align_pass_avx2.cpp), where they vectorise. Only exact operations (min) and additions in a fixed order, no
// fused multiply-adds (align_pass_avx2.cpp is built with -ffp-contract=off): every CPU gives the
// same costs bit for bit. Included inside the implementation's namespace.

int alignment_rebase(double* cur, int a, int b) {
  int best = a;
  for (int j = a + 1; j <= b; ++j)
    if (cur[j] < cur[best]) best = j;
  const double base = cur[best];
  for (int j = a; j <= b; ++j) cur[j] -= base;
  return best;
}

int alignment_step(const double* prev, double* cur, const float* c, int a, int b, const double* pk, int k_max,
                   double jump, bool loop) {
  const int n = b - a + 1;
  for (int j = a; j <= b; ++j) cur[j] = jump;
  for (int k = 0; k <= k_max; ++k) {
    const double p = pk[k];
    for (int j = a + k; j <= b; ++j) cur[j] = std::min(cur[j], prev[j - k] + p);
    if (loop)  // the section's end is followed by its start
      for (int j = a; j < a + k; ++j) cur[j] = std::min(cur[j], prev[j - k + n] + p);
  }
  for (int j = a; j <= b; ++j) cur[j] += c[j];
  return alignment_rebase(cur, a, b);
}

void alignment_step_range(const double* prev, double* cur, const float* c, int a, int b, int lo, int hi,
                          const double* pk, int k_max, double jump, bool loop) {
  const int n = b - a + 1;
  for (int j = lo; j <= hi; ++j) cur[j] = jump;
  for (int k = 0; k <= k_max; ++k) {
    const double p = pk[k];
    for (int j = std::max(lo, a + k); j <= hi; ++j) cur[j] = std::min(cur[j], prev[j - k] + p);
    if (loop)  // the section's end is followed by its start
      for (int j = lo; j <= std::min(hi, a + k - 1); ++j) cur[j] = std::min(cur[j], prev[j - k + n] + p);
  }
  for (int j = lo; j <= hi; ++j) cur[j] += c[j];
}

void subtract_rows16(float* row, const int16_t* q, float step, int n) {
  const float none = 0.51f * step;
  for (int c = 0; c < n; ++c) {
    const float d = row[c] - step * static_cast<float>(q[c]);
    row[c] = d <= none && d >= -none ? 0.0f : d;  // (no library call in an AVX2 unit)
  }
}
