#include "metric/align.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.hpp"

namespace kata::metric {

Aligner::Aligner(std::shared_ptr<const Reference> reference, AlignmentOptions options)
    : reference_(std::move(reference)), options_(options) {
  if (!reference_) throw Error(ErrorKind::kInvalidArgument, "scorer: null reference");
  if (!(options_.window > 0.0) || !(options_.max_rate > 0.0) || !(options_.step_penalty >= 0.0))
    throw Error(ErrorKind::kInvalidArgument, "scorer: alignment window and max rate must be > 0, step penalty >= 0");
  if (reference_->kind() == ReferenceKind::kClip) {
    cost_prev_.assign(static_cast<size_t>(reference_->frames()), 0.0);
    cost_cur_.assign(static_cast<size_t>(reference_->frames()), 0.0);
  }
}

void Aligner::reset() {
  lo_ = 0;
  hi_ = -1;
  match_ = 0;
  last_time_ = 0.0;
}

int Aligner::align(const float* s, double t) {
  if (reference_->kind() != ReferenceKind::kClip) return 0;
  const Reference& ref = *reference_;
  const int last = ref.frames() - 1;
  const int stride = ref.metric().stride();
  const int span = std::max(1, static_cast<int>(std::ceil(options_.window / ref.frame_time())));
  auto cost = [&](int j) { return std::sqrt(static_cast<double>(detail::dist2f(s, ref.alignment_projection(j), stride))); };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (hi_ < 0) {  // first frame after construction or reset: open begin within the window
    lo_ = 0;
    hi_ = std::min(last, span);
    for (int j = lo_; j <= hi_; ++j) cost_cur_[j] = cost(j);
  } else {
    const double dt = t - last_time_;
    const double advance = (dt > 0.0 ? dt : 0.0) / ref.frame_time();  // expected teacher frames
    const int k_max = std::max(1, static_cast<int>(std::ceil(options_.max_rate * advance)));
    const double penalty = options_.step_penalty * ref.step_cost();
    const int plo = lo_, phi = hi_;
    std::swap(cost_prev_, cost_cur_);
    lo_ = match_;
    hi_ = std::min({last, phi + k_max, match_ + span});
    for (int j = lo_; j <= hi_; ++j) {
      double best = kInf;
      for (int k = 0; k <= k_max; ++k) {
        const int i = j - k;
        if (i < plo) break;
        if (i <= phi) best = std::min(best, cost_prev_[i] + penalty * std::max(0.0, k - advance));
      }
      cost_cur_[j] = best == kInf ? kInf : best + cost(j);
    }
  }
  // Open end: the band's cheapest frame is the match; costs are re-based on it so they stay
  // small over long streams.
  int arg = lo_;
  for (int j = lo_ + 1; j <= hi_; ++j)
    if (cost_cur_[j] < cost_cur_[arg]) arg = j;
  const double base = cost_cur_[arg];
  for (int j = lo_; j <= hi_; ++j) cost_cur_[j] -= base;
  match_ = arg;
  last_time_ = t;
  return arg;
}

}  // namespace kata::metric
