// The anchor for scoring: a plain Eigen W^T x built for this machine's best instruction
// set (-march=native), in its own shared library so that none of its Eigen instantiations can be
// merged with the baseline-ISA ones of kata_bench (inline symbols stay hidden in the .so).
#include "eigen_native.hpp"

#include <cstddef>
#include <cstdint>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <Eigen/Core>

namespace kata_bench {

void eigen_native_wtx(const float* w, int rows, int cols, const float* x, float* y) {
  const Eigen::Map<const Eigen::MatrixXf> wm(w, rows, cols);
  const Eigen::Map<const Eigen::VectorXf> xv(x, rows);
  Eigen::Map<Eigen::VectorXf> yv(y, cols);
  yv.noalias() = wm.transpose() * xv;
}

}  // namespace kata_bench

namespace kata_bench {

// Not shipped: what a half-precision W would buy (the "reduced precision" option,
// measured before it is built). W row-major rows x cols in IEEE fp16, fp32 accumulation; the
// conversion (vcvtph2ps) is the compiler's, for this machine.
void fp16_wtx(const uint16_t* w, int rows, int cols, const float* x, float* y) {
#if defined(__AVX512F__) && defined(__AVX512BW__)
  // 4 x 16 columns; the last vector's lanes past `cols` masked off on load.
  __m512 acc[4] = {_mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps(), _mm512_setzero_ps()};
  const int nv = (cols + 15) / 16;
  const __mmask16 tail = static_cast<__mmask16>((1u << (cols - 16 * (nv - 1))) - 1u);
  for (int i = 0; i < rows; ++i) {
    const __m512 xi = _mm512_set1_ps(x[i]);
    const uint16_t* row = w + static_cast<ptrdiff_t>(i) * cols;
    for (int v = 0; v < 4; ++v) {
      if (v >= nv) break;
      const __mmask16 m = v + 1 == nv ? tail : static_cast<__mmask16>(0xFFFF);
      const __m256i h = _mm256_maskz_loadu_epi16(m, row + 16 * v);
      acc[v] = _mm512_fmadd_ps(_mm512_maskz_cvtph_ps(0xFFFF, h), xi, acc[v]);
    }
  }
  alignas(64) float out[64];
  for (int v = 0; v < 4; ++v) _mm512_store_ps(out + 16 * v, acc[v]);
  for (int c = 0; c < cols; ++c) y[c] = out[c];
#else
  constexpr int kMaxCols = 64;
  float acc[kMaxCols] = {};
  for (int i = 0; i < rows; ++i) {
    const float xi = x[i];
    const _Float16* row = reinterpret_cast<const _Float16*>(w) + static_cast<ptrdiff_t>(i) * cols;
    for (int c = 0; c < cols; ++c) acc[c] += static_cast<float>(row[c]) * xi;
  }
  for (int c = 0; c < cols; ++c) y[c] = acc[c];
#endif
}

void fp32_wtx_rowmajor(const float* w, int rows, int cols, const float* x, float* y) {
  constexpr int kMaxCols = 64;
  float acc[kMaxCols] = {};
  for (int i = 0; i < rows; ++i) {
    const float xi = x[i];
    const float* row = w + static_cast<ptrdiff_t>(i) * cols;
    for (int c = 0; c < cols; ++c) acc[c] += row[c] * xi;
  }
  for (int c = 0; c < cols; ++c) y[c] = acc[c];
}

}  // namespace kata_bench
