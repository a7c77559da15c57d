#include "metric/align.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "common/error.hpp"
#include "metric/align_pass.hpp"

namespace kata::metric {

Aligner::Aligner(std::shared_ptr<const Reference> reference, AlignmentOptions options)
    : reference_(std::move(reference)), options_(options) {
  if (!reference_) throw Error(ErrorKind::kInvalidArgument, "scorer: null reference");
  if (!(options_.window > 0.0) || !(options_.max_rate > 0.0) || !(options_.step_penalty >= 0.0) || !(options_.hold_penalty >= 0.0) ||
      !(options_.relocate_time >= 0.0) || !std::isfinite(options_.relocate_time))
    throw Error(ErrorKind::kInvalidArgument,
                "scorer: alignment window and max rate must be > 0, step penalty and relocate time >= 0");
  if (reference_->kind() != ReferenceKind::kClip) return;
  const int frames = reference_->frames();
  const int last = options_.last_frame < 0 ? frames - 1 : options_.last_frame;
  if (options_.first_frame < 0 || options_.first_frame > last || last >= frames)
    throw Error(ErrorKind::kInvalidArgument, "scorer: practice section " + std::to_string(options_.first_frame) +
                                                 ".." + std::to_string(options_.last_frame) +
                                                 " is not inside the teacher clip's " + std::to_string(frames) +
                                                 " frames");
  first_ = options_.first_frame;
  last_ = last;
  span_ = std::max(1, static_cast<int>(std::ceil(options_.window / reference_->frame_time())));
  cost_prev_.assign(static_cast<size_t>(frames), 0.0);
  cost_cur_.assign(static_cast<size_t>(frames), 0.0);
  local_.assign(static_cast<size_t>(frames), 0.0f);
  step_costs_.assign(static_cast<size_t>(span_) + 1, 0.0);
  scaled_.assign(static_cast<size_t>(reference_->metric().stride()), 0.0f);
  match_ = first_;
}

void Aligner::reset() {
  started_ = false;
  match_ = first_;
  relocations_ = 0;
  last_time_ = 0.0;
}

int Aligner::wrap(int j) const {
  const int n = last_ - first_ + 1;
  if (j < first_) return j + n;
  if (j > last_) return j - n;
  return j;
}

double Aligner::jump_cost() const {
  return options_.relocate_time > 0.0 ? options_.relocate_time / student_dt_ * reference_->spread()
                                      : std::numeric_limits<double>::infinity();
}

int Aligner::align(const float* s, double t) {
  if (reference_->kind() != ReferenceKind::kClip) return 0;
  const Reference& ref = *reference_;
  const int a = first_, b = last_, n = b - a + 1;
  const int stride = ref.metric().stride();
  const double ft = ref.frame_time();
  float* c = local_.data();
  // The pass over the section reads the half-precision rows (half the bytes from a cold cache).
  const float inv = 1.0f / ref.alignment_half_scale();  // a power of two: exact
  float* scaled = scaled_.data();
  for (int i = 0; i < stride; ++i) scaled[i] = s[i] * inv;
  detail::alignment_distances_half(scaled, ref.alignment_rows_half(a), n, stride, ref.alignment_half_scale(), c + a);
  double* cur = cost_cur_.data();
  int best = a;
  if (!started_) {
    // Open begin: a path starts anywhere, those outside the band at the section's start for a
    // tenth of a jump: enough that a student who starts with the teacher is not placed in a
    // look-alike later in the clip (a cyclic walk), little enough that one who joins late is
    // found about as soon as after a skip.
    student_dt_ = ft;
    const double prior = 0.1 * jump_cost();
    for (int j = a; j <= b; ++j) cur[j] = c[j] + (j - a <= span_ ? 0.0 : prior);
    // Re-based on the section's cheapest frame, the best place anywhere.
    best = detail::alignment_rebase(cur, a, b);
  } else {
    const double dt = std::max(0.0, t - last_time_);
    // The jump cost is set in seconds, so it follows the student's frame rate, smoothed over
    // about 10 frames (a gap after lost tracking counts as at most 0.1 s).
    if (dt > 0.0) student_dt_ += 0.1 * (std::min(dt, 0.1) - student_dt_);
    const double advance = dt / ft;  // expected teacher frames
    // Steps beyond the band are never needed: further moves are jumps.
    const int k_max = std::min({std::max(1, static_cast<int>(std::ceil(options_.max_rate * advance))), span_, n - 1});
    const double penalty = options_.step_penalty * ref.step_cost(), hold = options_.hold_penalty * ref.step_cost();
    const double jump = jump_cost();
    std::swap(cost_prev_, cost_cur_);
    cur = cost_cur_.data();
    const double* prev = cost_prev_.data();
    // One pass per step k over the section (align_pass_kernel.inl; the inner loops vectorise): a
    // jump from the best place (0 after the re-basing), or a step of k from j - k; then re-based
    // on the section's cheapest frame, the best place anywhere.
    double* pk = step_costs_.data();
    for (int k = 0; k <= k_max; ++k)
      pk[k] = penalty * std::max(0.0, k - advance) + hold * std::max(0.0, advance - k);
    best = detail::alignment_step(prev, cur, c, a, b, pk, k_max, jump, options_.loop);
  }
  if (!started_) {
    match_ = best;
    started_ = true;
  } else {
    // The local band just ahead of the last match, then the move if the best place elsewhere is
    // cheaper by the margin.
    int local = match_;
    for (int k = 1; k <= std::min(span_, n - 1); ++k) {
      const int j = options_.loop ? wrap(match_ + k) : match_ + k;
      if (j > b) break;
      if (cur[j] < cur[local]) local = j;
    }
    if (cur[local] > jump_cost()) {
      match_ = best;
      ++relocations_;
    } else {
      match_ = local;
    }
  }
  last_time_ = t;
  return match_;
}

}  // namespace kata::metric
