// Online alignment of a student stream to a teacher clip: a streaming DTW over
// the whole clip (or a practice section of it) with a jump transition, so that the match follows
// a student who joins anywhere, skips ahead or back, repeats, pauses or changes tempo.
//
// With c(n, j) = |s_n - s_j| the distance of the static-blocks projections (reference.hpp) of
// student frame n and teacher frame j, every teacher frame j of the section carries the cost of
// the best warping path that ends there now:
//   D(n, j) = c(n, j) + min( min_{k = 0..K} [D(n-1, j-k) + penalty(k)],  min_i D(n-1, i) + P ),
// K = max(1, ceil(max_rate * dt_student / frame_time)) (the largest step; holding, k = 0, is
// nearly free, so a paused student holds the teacher), penalty(k) as in AlignmentOptions::step_penalty and hold_penalty, and P the
// cost of a jump: a path may restart anywhere for P (AlignmentOptions::relocate_time). Costs are
// re-based on their minimum each frame, so they stay within max c + P over any stream.
//
// The match m(n) is the cheapest frame of the local band [m(n-1), m(n-1) + window] (the path
// just ahead, as the first, band-only aligner did) unless the cheapest frame of the whole section is cheaper
// by more than P: then the match moves there (re-localisation). Once moved, the old place must
// win back the same margin, so repeated moves (a cyclic walk) do not flicker between cycles.
// After a skip the wrong place's path gains about c_wrong - c_right per frame, so the move comes
// after about P / (c_wrong - c_right) frames: relocate_time seconds when the wrong place is as
// far as two unrelated teacher frames (Reference::spread) and the right one fits exactly.
//
// The first frame after construction or reset starts a path anywhere in the section (join
// anywhere), those away from its start for 0.1 P (ties go to the start). A section (first_frame..last_frame) restricts the match to a part of the clip;
// with loop, its last frame is followed by its first (practice a section over and over).
//
// Cost per frame (cold4): a section longer than twice the tracking window (3 x the band: one band
// behind the match, two ahead) is not compared whole every frame. The match is followed by the
// same dynamic programme over the window only (frames entering it start from a jump), and the
// relocation search, the same programme over the whole section, runs on every R-th student frame
// (R = ceil(frames / 256) within 4..8: the search's student rate is 120 / R Hz at 120 Hz), its
// distance pass and its step spread over the R frames (one slice of the section per frame), its
// costs, jump and open-begin prior 1/R of the frame rate's (one distance per R frames); when the
// search moves to a place outside the window (a re-localisation at its rate, judged at the
// window's match), the window is placed there with the search's costs (x R). So a frame reads the
// window's rows and 1/R of the section's (410 of the default lesson's 1,829 rows) instead of all
// of them; a skip is found up to 2R frames later than by the whole-section pass. Shorter sections
// take the whole-section programme every frame, as before (docs/performance.md,
// "cold4", has the figures).
//
// R stops at 8 (the search sees the student at 15 Hz or more): at 15 and 30 (8 and 4 Hz) it followed
// a real student's dance too coarsely and moved the window to wrong places: the default lesson's
// student (05_19 on 05_18) scored 70.7 and 68.7 instead of 76.2 (the whole-section pass: 76.4),
// and 70.5 against the teacher repeated 4 times, 64.8 at 80 times, where R had reached 30
// (tests/metric/test_relocate.cpp, ARealStudentScoresAsAgainstTheClipWhenTheTeacherIsRepeated).
//
// Long teachers: past 2,048 frames (17 s at 120 Hz) the search reads more than 256 rows
// per frame, the more the longer the teacher. A section longer than Reference::kSearchFrames is
// searched on a grid instead: every M-th teacher frame, M = ceil(frames / kSearchFrames), the
// programme's steps counted in grid frames (M teacher frames each: a step of k grid frames is
// k M teacher frames, the band span / M grid frames). The search only chooses where the window
// goes; the window then follows at the teacher's full rate, so the match is as fine as before.
// A frame reads the window's rows and at most 3,584 / 8 = 448 of the grid's: the same for a
// 20-minute teacher as for a 30-second one (docs/model/alignment.md has the figures). kSearchFrames
// was 7,680 (960 rows, a long teacher's alignment 2.2x the lesson clip's: 860 KB of grid rows, more
// than L2, where the 1,829-frame clip reads 229), then 4,096 (512 rows: 1.30x at 16x, 1.35x at
// 64x, over the 1.3x allowed); at 3,584 the grid is 402 KB and 16x / 64x cost 1.2x / 1.25x the clip's
// (the cost per frame is about 1.8 us + 2.6 ns a grid row on this machine), and the real student
// scores 75.4-75.5 against the lesson repeated 4, 16 and 80 times as against the clip (grid steps
// of 3, 9 and 41 teacher frames: 25-340 ms), as with 4,096. (A coarser grid loses the student:
// kSearchFrames 2,048 scored the 20-minute lesson 75.7 instead of 76.3, with a grid step of 0.6 s;
// 1,024, a step of 1.2 s, 55.3.) A teacher longer than 60 x 3,584 frames (30 minutes at 120 Hz)
// has a grid step wider than the window's 0.5 s band.
// Threads: an Aligner belongs to one stream, used by one thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "metric/reference.hpp"

namespace kata::metric {

// Online alignment of a student to a clip reference.
struct AlignmentOptions {
  // The local band: how far ahead of the last match a student frame may be matched without a
  // re-localisation, in teacher seconds.
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
  // Cost of advancing less than expected, per teacher frame short, in the same units:
  // hold(k) = hold_penalty * step_cost * max(0, a - k), added to penalty(k). Small next to the
  // cost of a real mismatch (a teacher frame of motion costs about step_cost), so a student who
  // pauses still holds the teacher; it breaks the ties where the teacher holds still, so the
  // match moves on through a held pose at the expected rate instead of staying at its start.
  double hold_penalty = 0.1;
  // Re-localisation margin, seconds: the jump cost P (and the margin a better place elsewhere
  // must win by) is relocate_time / dt_student * Reference::spread, the cost of this long at the
  // distance of two unrelated teacher frames. 0 turns re-localisation off (the match only
  // follows the band, as the first aligner did). 0.2 s: on the tests' students a skip is found
  // 0.2-0.9 s after it (0.3 s: 0.2-1.1 s), and a 20-cycle walk never moves between cycles
  // (tests/metric/test_relocate.cpp).
  double relocate_time = 0.2;
  // Practice section: teacher frames first_frame..last_frame (last_frame -1: the clip's end).
  int32_t first_frame = 0;
  int32_t last_frame = -1;
  // Loop the section: its last frame is followed by its first.
  bool loop = false;
  // Follow a long section in a window with the relocation search on every R-th frame (above:
  // "Cost per frame"); false: the whole section every frame, as before cold4 (the reference the
  // windowed aligner is tested against).
  bool windowed = true;
  // The re-match (Scorer, not the Aligner): the student frame is scored against the teacher frame
  // within +-rematch_time seconds of the alignment's match with the smallest trimmed pose distance
  // (pose_error.hpp: the worst part counts at most twice the rest of the body), taken only where
  // the rest of the body agrees (Scorer::kRematchAgreement). The alignment compares whole poses, so
  // a joint held wrong throughout pulls its match to where the teacher's joint is nearer the
  // student's (a knee bent 45 deg in a walk went 2-5 frames off, to where the teacher's knee bends
  // more, and scored 55 instead of 43); the re-match puts the frame back where the rest of the body
  // agrees, so the error stays in the score. 0: the alignment's match. docs/model/scores.md
  // "The re-match" has the figures.
  double rematch_time = 0.05;
};

// Follows one student stream along a clip reference. Allocates at construction only.
class Aligner {
 public:
  // Throws kInvalidArgument for a null reference or options out of range (window and max rate
  // > 0, step penalty and relocate time >= 0, a section inside the clip with first <= last).
  explicit Aligner(std::shared_ptr<const Reference> reference, AlignmentOptions options = {});

  // Matches the frame whose static-blocks projection is s (Reference::alignment_projection
  // layout) at time t (seconds, increasing) and returns the matched teacher frame. A pose
  // reference always matches frame 0. Allocation-free.
  int align(const float* s, double t);
  int match() const { return match_; }
  // Re-localisations since construction or reset (moves outside the local band).
  int64_t relocations() const { return relocations_; }
  const AlignmentOptions& options() const { return options_; }
  // The section's frames (first..last of the clip; 0..0 for a pose).
  int first() const { return first_; }
  int last() const { return last_; }
  // Whether the section is followed in a window (AlignmentOptions::windowed and a section longer
  // than twice the window), and the search's decimation R (1 when not windowed).
  bool windowed() const { return windowed_; }
  int decimation() const { return windowed_ ? decimation_ : 1; }
  // The next frame is matched anywhere in the section again.
  void reset();

 private:
  // One dynamic programme over frames 0..size-1 of its own index (the whole section, or the
  // window): its accumulated costs, match and student clock.
  struct Track {
    std::vector<double> prev, cur;  // accumulated cost D
    bool started = false;
    int match = 0;
    int64_t relocations = 0;
    double last_time = 0.0;
    double student_dt = 0.0;  // smoothed student frame interval, seconds
    int grid = 1;             // teacher frames per index (the search's grid on a long section)
    int span = 1;             // the band, in indices
  };
  int wrap(int j) const;                   // j folded into the section when looping
  double jump_cost(const Track& track) const;  // P, for the track's student frame interval
  // One student frame of a track over its indices [a, b] (loop: b is followed by a) with c the
  // distances of this frame: the programme's step (or open begin, free within the band after
  // `start`), then the match (the band after the last one, or the best place by the margin).
  // decimation: the track sees every decimation-th student frame (its first interval guess).
  int follow(Track& track, const float* c, int a, int b, bool loop, int start, double t, int decimation);
  // The costs of one step of a track (and its clock moved on to t, its costs swapped): the
  // largest step, and the jump; pk[0..k_max] = the cost of a step of k.
  struct StepCosts {
    int k_max = 1;
    double jump = 0.0;
  };
  StepCosts begin_step(Track& track, int n, double t, int decimation, double* pk);
  // The match after a step whose best place is `best`: the band after the last match, or the move.
  void decide(Track& track, int best, int a, int b, bool loop, double jump);
  // c[j - a] = the distance of the student's scaled row to section frames j = a..b (in order).
  void distances(const float* scaled, int a, int b, float* c) const;
  // The same for the search's grid indices a..b (teacher frames a M .. b M).
  void search_distances(const float* scaled, int a, int b, float* c) const;
  int search_frame(int index) const { return index * search_grid_; }  // grid index -> teacher frame
  int search_index(int frame) const;  // teacher frame -> the nearest grid index of the section
  int teacher_frame(int window_index) const;  // the section frame at a window index
  int window_start_for(int target) const;  // the window placed one band behind a match at target
  void seed_window(int target, double t, const float* scaled);
  void move_window(int target);
  // One frame of the window (seed_index >= 0: its open begin, free after that window index).
  void follow_window(const float* scaled, double t, int seed_index);

  std::shared_ptr<const Reference> reference_;
  AlignmentOptions options_;
  int first_ = 0, last_ = 0, span_ = 1;
  std::vector<double> step_costs_;  // the cost of a step of k frames, k <= span_
  std::vector<float> scaled_;       // the student's row / the reference's half scale
  Track search_;                    // the whole section (every frame, or every R-th when windowed)
  int search_grid_ = 1;             // M: the search's teacher frames are every M-th (long sections)
  int search_a_ = 0, search_b_ = 0; // the section on the search's grid (indices)
  std::vector<float> search_c_;     // its distances (section frames), filled slice by slice
  // Windowed sections only:
  bool windowed_ = false;
  static constexpr int kMaxDecimation = 8;  // R's cap ("Cost per frame": 15 and 30 lost the student)
  int decimation_ = 1;              // R: the search's student frames are every R-th
  int phase_ = 0;                   // this frame's slice of the search's pass (0..R-1)
  std::vector<float> search_row_;   // the search's student row (scaled), kept for its R slices
  double search_time_ = 0.0;        // its time
  StepCosts search_step_;           // its step's costs
  std::vector<double> search_pk_;
  int64_t search_moves_ = 0;        // the search's relocations already followed
  int search_anchor_ = 0;           // the match of the search's frame: the place it judges
  bool search_anchor_pending_ = false;
  Track window_;                    // the window's programme
  int window_start_ = 0;            // section frame at window index 0
  int window_size_ = 0, window_back_ = 0;
  std::vector<float> window_c_;
  int match_ = 0;
  int64_t relocations_ = 0;
};

}  // namespace kata::metric
