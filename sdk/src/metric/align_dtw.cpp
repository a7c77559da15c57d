#include "metric/align_dtw.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

#include "common/error.hpp"

namespace kata::metric {

std::vector<int> subsequence_dtw(const Reference& ref, const float* s, int n) {
  if (n < 1 || !s) throw Error(ErrorKind::kInvalidArgument, "dtw: no student frames");
  if (ref.kind() != ReferenceKind::kClip) return std::vector<int>(static_cast<size_t>(n), 0);
  const int m = ref.frames(), stride = ref.metric().stride();
  // from: 0 diagonal, 1 vertical (same teacher frame, next student frame), 2 horizontal.
  std::vector<uint8_t> from(static_cast<size_t>(n) * m);
  std::vector<double> prev(static_cast<size_t>(m)), cur(static_cast<size_t>(m));
  auto cost = [&](int i, int j) {
    return std::sqrt(detail::dist2(s + static_cast<size_t>(i) * stride, ref.alignment_projection(j), stride));
  };
  for (int j = 0; j < m; ++j) cur[j] = cost(0, j), from[j] = 1;
  for (int i = 1; i < n; ++i) {
    std::swap(prev, cur);
    uint8_t* f = from.data() + static_cast<size_t>(i) * m;
    for (int j = 0; j < m; ++j) {
      double best = prev[j];
      uint8_t step = 1;
      if (j > 0 && prev[j - 1] <= best) best = prev[j - 1], step = 0;
      if (j > 0 && cur[j - 1] < best) best = cur[j - 1], step = 2;
      cur[j] = best + cost(i, j);
      f[j] = step;
    }
  }
  int j = 0;
  for (int k = 1; k < m; ++k)
    if (cur[k] < cur[j]) j = k;
  std::vector<int> match(static_cast<size_t>(n), -1);
  for (int i = n - 1; i >= 0;) {
    if (match[i] < 0) match[i] = j;  // the last teacher frame paired with student frame i
    const uint8_t step = from[static_cast<size_t>(i) * m + j];
    if (i == 0 && step == 1) break;
    if (step == 0) --i, --j;
    else if (step == 1) --i;
    else --j;
    if (j < 0) break;
  }
  for (int i = 1; i < n; ++i)
    if (match[i] < 0) match[i] = match[i - 1];
  return match;
}

}  // namespace kata::metric
