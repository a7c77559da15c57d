// Online alignment of a student stream to a teacher clip (issue 3): an open-end DTW restricted to
// a band that moves forward with the match.
//
// With c(n, j) = |s_n - s_j| the distance of the static-blocks projections (reference.hpp) of
// student frame n and teacher frame j, the accumulated cost is
// D(n, j) = c(n, j) + min_{k = 0..K} [D(n-1, j-k) + penalty(k)], K = max(1, ceil(max_rate *
// dt_student / frame_time)), penalty as in AlignmentOptions::step_penalty. Only j in
// [m(n-1), m(n-1) + window] is evaluated, and the match is m(n) = argmin_j D(n, j) over the band:
// never backwards, and never more than K frames ahead of the band's previous end. The first frame
// matches within [0, window] of the clip's start.
//
// Threads: an Aligner belongs to one stream, used by one thread at a time.
#pragma once

#include <memory>
#include <vector>

#include "metric/reference.hpp"

namespace kata::metric {

// Online alignment of a student to a clip reference.
struct AlignmentOptions {
  // How far ahead of the last match a student frame may be matched, in teacher seconds.
  double window = 0.5;
  // The fastest the teacher may advance per student second (2 = the student may run twice as
  // fast); sets the largest step of the warping path.
  double max_rate = 2.0;
  // Cost of a warping step that advances further than expected (a = dt_student / frame_time
  // teacher frames), per extra teacher frame, in units of the clip's median frame-to-frame
  // distance: penalty(k) = step_penalty * step_cost * max(0, k - a). It keeps the match from
  // jumping ahead through stretches where the teacher barely moves; holding (k < a) is free,
  // since students pause and lag. 0.25 was the best of {0, 0.25, 0.5, 1} on the shipped clips
  // slowed by 10%, sped up by 15% and delayed by 0.3 s (tests/metric/test_align.cpp).
  double step_penalty = 0.25;
};

// Follows one student stream along a clip reference. Allocates at construction only.
class Aligner {
 public:
  // Throws kInvalidArgument for a null reference or options out of range (window and max rate
  // > 0, step penalty >= 0).
  explicit Aligner(std::shared_ptr<const Reference> reference, AlignmentOptions options = {});

  // Matches the frame whose static-blocks projection is s (Reference::alignment_projection
  // layout) at time t (seconds, increasing) and returns the matched teacher frame. A pose
  // reference always matches frame 0. Allocation-free.
  int align(const float* s, double t);
  int match() const { return match_; }
  const AlignmentOptions& options() const { return options_; }
  // The next frame is matched from the clip's start again.
  void reset();

 private:
  std::shared_ptr<const Reference> reference_;
  AlignmentOptions options_;
  std::vector<double> cost_prev_, cost_cur_;  // accumulated DTW cost over teacher frames
  int lo_ = 0, hi_ = -1, match_ = 0;
  double last_time_ = 0.0;
};

}  // namespace kata::metric
