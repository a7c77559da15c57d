// Repetitions against a one-repetition teacher (docs/coach/repetitions.md): the teacher's
// section (the whole clip, or a practice section of it, best looped) is one repetition; the
// online alignment follows the student through it, and each time the match comes round from the
// section's end to its start, a repetition ends. Fed by the scorer's records (the matched teacher
// frame, the score, the part to fix and the cue) and the frame's features (for the joint angles);
// no alignment of its own.
//
// What ends a repetition (the match m in the section a..b, progress p = (m - a) / period):
//   - the wrap: a forward step of the match across the section's end into its start (a looped
//     section; the step's crossing time, interpolated, is the boundary);
//   - a jump back into the start (p <= kStartRegion) from further on (a restart, or a non-looped
//     teacher's re-localisation to its start);
//   - a hold at the end: no forward step for kEndHold seconds while p >= kEndRegion (the student
//     finished and stopped);
//   - finish(): the end of the student's clip (kata score).
// A repetition is complete when its forward steps covered at least kCompleteCoverage of the
// section (kBins bins of progress, marked by steps no longer than the alignment's fastest rate
// allows; a jump marks nothing) and it ended at the end (the wrap, or the last match in the end
// region); otherwise it is partial (reported, never counted) when it covered at least
// kPartialCoverage, and dropped as noise below that.
// Times: a repetition starts at the boundary before it, or, when the match did not move on at
// once, at the last frame before its first forward step; it ends at its last forward step (the
// wrap's crossing time when it ran straight into it): a pause between repetitions (the match
// holding) belongs to neither. Tempo = duration / the teacher's period (the section's frames x the
// frame time when looped, (frames - 1) x the frame time when not).
// Range of motion: eight joint angles (RomJoint), degrees, max - min over the repetition's frames
// with features (from its start to its last forward step), and the teacher's over the section.
//
// Memory: allocates nothing; the teacher's ranges are computed from Reference::pose when the
// section changes (an O(section) pass, between frames: set_section). Threads: one stream's, one
// thread at a time.
#pragma once

#include <cstdint>
#include <memory>

#include "metric/reference.hpp"
#include "metric/scorer.hpp"

namespace kata::metric {

// The joint angles whose range a repetition reports, in this order (the CSV's and the record's).
// Each is the angle at a joint between its two segments, degrees (0..180), from the 16 GPD joints
// (any frame: rotation and scale do not change it):
//   knee     at Knee between Hip(side) and Foot (180 straight);
//   hip      at Hip(side) between the trunk (Hip -> Neck, up) and the thigh (Hip(side) -> Knee):
//            180 standing, 90 with the thigh raised level, flexion or abduction alike;
//   elbow    at Elbow between Shoulder and Hand (180 straight);
//   shoulder at Shoulder between the trunk (Neck -> Hip, down) and the upper arm (Shoulder ->
//            Elbow): 0 with the arm hanging, 90 raised level, flexion or abduction alike.
enum class RomJoint : int {
  kLeftKnee = 0,
  kRightKnee,
  kLeftHip,
  kRightHip,
  kLeftElbow,
  kRightElbow,
  kLeftShoulder,
  kRightShoulder,
};
constexpr int kRomJoints = 8;
// "left_knee", "right_knee", ... (the CSV's range_<name> columns).
const char* rom_joint_name(int joint);
// The eight angles (degrees) of a pose given as GPD features' Jc block (x[0..44]: joints 1..15,
// the hip at the origin) or, with hip_at_origin false, as 16 x 3 joint positions. A degenerate
// segment gives 0. Allocation-free.
void rom_angles(const float* joints, bool hip_at_origin, float* degrees);

// One repetition, complete or partial.
struct Repetition {
  int32_t index = 0;          // 1, 2, 3... the count of complete repetitions with this one; a partial
                              // one carries the index the attempt would have had (the next complete
                              // one gets the same index: the count goes on as if it had not happened)
  bool partial = false;       // abandoned before the end (not counted)
  double start_time = 0.0;    // student seconds (the stream's clock)
  double end_time = 0.0;
  double tempo = 0.0;         // (end - start) / the teacher's period (1: the teacher's pace, 1.2: 20 % slower)
  float score = 0.0f;         // mean total score over its scoring frames (0 without one)
  int32_t part_to_fix = -1;   // the part to fix shown on most of its scoring frames, "none" counting
                              // as one (-1: no part was shown as often as none)
  int32_t cue_joint = -1;     // the cue shown most while that part was shown (GPD joint, -1 none)
  int32_t cue_action = -1;    // CueAction, -1 none
  float cue_degrees = 0.0f;   // that cue's mean degrees while shown
  float coverage = 0.0f;      // the fraction of the section its forward steps covered, 0..1
  int32_t frames = 0;         // student frames in it (start .. last forward step)
  float range[kRomJoints] = {};          // the student's range of motion per RomJoint, degrees
  float teacher_range[kRomJoints] = {};  // the teacher's over the section, degrees
};

class RepCounter {
 public:
  // Progress below this is the section's start, at or above kEndRegion its end.
  static constexpr double kStartRegion = 0.25, kEndRegion = 0.8;
  static constexpr int kBins = 40;
  static constexpr double kCompleteCoverage = 0.7, kPartialCoverage = 0.2;
  static constexpr double kEndHold = 0.5;  // seconds without a forward step at the end: finished
  // A step covers the section only on a frame whose model score (ScoreRecord::model_score, the
  // learned distance's map: another motion scores low whatever the joints) is at least this.
  static constexpr double kMotionScore = 20.0;
  // Repetitions kept for readers that poll (Pipeline, the runtime's publisher).
  static constexpr int kKept = 16;

  // A counter over the scorer's current section (Scorer::aligner: first, last, loop). A pose
  // reference counts nothing (progress 0).
  explicit RepCounter(std::shared_ptr<const Reference> reference);

  // Follows the section first..last (teacher frames), looped or not: the teacher's ranges are
  // computed, the repetition in progress is dropped, the count kept. Allocation-free (O(section)).
  void set_section(int first, int last, bool loop);
  // One scored record of the stream (any state) and the frame's features (null for a frame
  // without: tracking lost). The section is the aligner's: set_section is called when it changed.
  // Returns the number of repetitions this frame ended (0 or 1; complete or partial): read them
  // with newest(). Allocation-free.
  int update(const ScoreRecord& record, const float* features, const Aligner& aligner);
  // The student's clip ended at time t: the repetition in progress ends (complete if it reached
  // the end, else partial or dropped). Returns the number ended (0 or 1).
  int finish(double t);
  // The count so far (complete repetitions) and the current one's number (count + 1).
  int32_t count() const { return count_; }
  int32_t current_index() const { return count_ + 1; }
  // Where the match is in the section, 0..1 (0 before the first frame).
  float progress() const { return progress_; }
  // Repetitions ended since construction (complete and partial), and the i-th newest of them (0 =
  // the newest; i < min(ended(), kKept)).
  int64_t ended() const { return ended_; }
  const Repetition& newest(int i = 0) const;
  // Clears the count and the repetition in progress (a restart).
  void reset();

 private:
  struct Range {
    float lo[kRomJoints], hi[kRomJoints];
    bool any = false;
    void clear() { any = false; }
    void add(const float* a);
    void add(const Range& r);
  };
  void begin(double start_time, bool moving);
  // Ends the repetition in progress at end_time: complete when `at_end` and covered enough.
  int close(double end_time, bool at_end);
  void mark(int from, int to);  // forward step from section frame `from` to `to` (wrapping)
  double coverage() const;

  std::shared_ptr<const Reference> reference_;
  int first_ = 0, last_ = -1;
  bool loop_ = false;
  double period_ = 0.0;           // teacher seconds of one repetition
  float teacher_range_[kRomJoints] = {};
  // The repetition in progress.
  bool has_prev_ = false;
  int prev_match_ = 0;
  double prev_time_ = 0.0;
  double moved_at_ = 0.0;         // when the match last moved on (any forward move)
  bool moving_ = false;           // a forward step since it began
  double start_time_ = 0.0, last_advance_ = 0.0;
  bool bins_[kBins] = {};
  Range range_, pending_;         // its angles to the last forward step; those after it
  double score_sum_ = 0.0;
  int scored_ = 0, frames_ = 0, pending_frames_ = 0, none_frames_ = 0;
  int part_frames_[kParts] = {};
  int cue_frames_[kParts][gpd::kJoints][5] = {};  // per part, joint, action: frames shown
  float cue_degrees_sum_[kParts][gpd::kJoints][5] = {};
  float progress_ = 0.0f;
  int32_t count_ = 0;
  int64_t ended_ = 0;
  Repetition kept_[kKept];
};

}  // namespace kata::metric
