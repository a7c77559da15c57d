// Scoring a pose stream against a teacher (spec gpd-v1.md section 6): a per-stream
// Scorer turns each student feature vector into a distance, a 0-100 score, a per-part breakdown
// and, for a clip, the matched teacher frame. Its parts live in their own headers, included here:
// the compiled model (metric.hpp: Metric, score_from_distance), the teacher (reference.hpp:
// Reference) and the clip alignment (align.hpp: Aligner, AlignmentOptions).
//
// Threads: Metric and Reference are immutable after construction and may be shared by any
// number of threads and streams. A Scorer belongs to one stream, used by one thread at a time.
#pragma once

#include <cstdint>
#include <memory>

#include "metric/align.hpp"
#include "metric/cue.hpp"
#include "metric/metric.hpp"
#include "metric/pose_error.hpp"
#include "metric/reference.hpp"

namespace kata::metric {

// What a record reports: a score to show, or why there is none.
enum class ScoreState : int32_t {
  kScoring = 0,          // the fields below are this frame's scores
  kCalibrating = 1,      // the first FeedbackOptions::calibrating_time seconds after start/reset
  kTrackingLost = 2,     // too few joints tracked in this frame (score_lost): no score
  kTeacherFinished = 3,  // the student outlasted the teacher clip (FeedbackOptions::finished_time)
};

// One scored frame.
//
// The coaching total (docs/model/scores.md): score = min(model_score, the lowest part score), so the total is
// never above its worst part (a part at 10 cannot hide in a total of 90). model_score is the
// model's calibrated map of the learned distance d (it tells motions apart: another motion scores
// low whatever the joints' angles); each part score is the map of the part's joint angle
// (pose_error.hpp: the largest angle between a student bone and the teacher's, in the body's
// frames), the same map for every part, so the same bend costs the same at every joint, left or right.
// The part to fix ranks by offset among the parts scoring below kBandScore within kOffsetBand
// points of the lowest averaged part score, the torso's offset weighed kTorsoOffsetWeight times
// while the torso scores below good_score (scorer.cpp update_part_to_fix; docs/model/scores.md
// "The part to fix"). kBandScore 99 is a part angle of about 16 deg: two people's legs are often
// the farthest joints while their angles score 93-99, so the band reaches past good_score.
constexpr double kOffsetBand = 30.0;
constexpr double kBandScore = 99.0;
// The torso's offset is a mean over the hip (its height), chest, neck and head, of which a bent
// chest moves only the neck and head, while the arms it carries move farther in the local frame:
// weighed alike, a chest bent 30 deg on a dance lost to the arms and legs its online match puts
// 20-30 deg off. Only while the torso is below good: weighed always, it outranked two people's
// arms on real pairs where the torso scored 94-97 (and is never geometry's largest part).
constexpr double kTorsoOffsetWeight = 3.25;

struct ScoreRecord {
  double time = 0.0;          // timestamp of the scored frame, seconds (stream clock)
  int64_t frame = -1;         // count of frames scored before this one by this Scorer
  float distance = 0.0f;      // d = |W^T (x'' - y'')|, dimensionless
  float score = 0.0f;         // the coaching total: min(model_score, min over parts of part_scores), 0..100
  float model_score = 0.0f;   // calibrated_score(d, d50, slope) of the scorer's calibration, 0..100
  float parts[kParts] = {};   // split of d^2 (sums to d^2), in Part order
  int32_t matched = 0;        // matched reference frame (0 for a pose reference): online, the
                              // alignment's match re-matched (AlignmentOptions::rematch_time)
  // Per part p: its distance d_p = |W^T (jc_p o (x'' - y''))|, the difference of the part's own
  // joint positions (block Jc: its joints' local-frame coordinates; the hip height for the
  // torso) seen through W (metric.hpp kJointRows); reported, no longer scored.
  float part_distance[kParts] = {};
  // Per part p (pose_error.hpp PartError): its angle, degrees (the largest angle between a
  // student bone of the part and the teacher's, each in the body's frame it hangs from), the GPD
  // joint (1..15) at the end of that bone, its offset (mean joint distance in the local frame, body
  // heights) and its score angle_score(degrees, the scorer's tolerance), 0..100.
  float part_degrees[kParts] = {};
  int32_t part_joint[kParts] = {};
  float part_offset[kParts] = {};
  float part_scores[kParts] = {};
  // The part to fix (Part index), -1 for none: Scorer::update_part_to_fix (scorer.cpp), the one
  // place it is decided. With part scores and offsets averaged over
  // FeedbackOptions::smoothing_time (exponentially, normalised by the weights summed since scoring
  // started): while the lowest averaged part score (or the averaged total)
  // is below the calibration's good_score in kScoring, the candidate is, among the lowest averaged
  // part and the parts below kBandScore within kOffsetBand points of it, the one with the largest
  // averaged offset (local-frame mean joint distance; the torso's weighed kTorsoOffsetWeight times
  // while it is below good_score); named at once when no part is named; another part replaces it,
  // or "none" clears it, only after holding for FeedbackOptions::hold_time seconds (hysteresis).
  int32_t part_to_fix = -1;
  // The correction cue (cue.hpp), present iff part_to_fix >= 0: the GPD joint to move (0..15,
  // always in part_to_fix; -1 none), the angle at that joint between the student's bone and the
  // teacher's (degrees, 0..180, averaged over FeedbackOptions::smoothing_time like the part
  // scores; 0 for none) and the action (CueAction as int32_t, -1 none), from the same averages.
  // Decided with the part to fix in Scorer::update_part_to_fix, with the same hysteresis.
  int32_t cue_joint = -1;
  float cue_degrees = 0.0f;
  int32_t cue_action = -1;
  ScoreState state = ScoreState::kScoring;
  // Where the student is in the routine: matched * the clip's frame time, seconds from the
  // clip's first frame (0 for a pose reference).
  double matched_time = 0.0;
};

// How feedback is held and when the states apply.
struct FeedbackOptions {
  // A new part to fix (or "none") replaces a part shown only after it has been the candidate for
  // this long, seconds (the cue's joint within a part alike). 0.3 s, not the 0.5 s a person needs
  // to read and react: a walk or a run alternates its legs every 0.4-0.6 s, and with a 0.5 s hold
  // the part shown lagged the part that was wrong (docs/model/scores.md "The part to fix"). When
  // no part is shown, a candidate is named at once, and so it is when the part shown scores at or
  // above good_score in this frame while the candidate scores kOffsetBand below good_score.
  double hold_time = 0.3;
  // The part scores the cue compares are averaged exponentially with this time constant,
  // seconds (0: this frame's alone), normalised by the weights summed since scoring started. A single frame's lowest part changes every few frames
  // (joints cross the reference's path); a coach names what has been wrong for a while.
  double smoothing_time = 0.5;
  // Records are kCalibrating for this long after the first frame (and after reset), seconds:
  // the alignment's open begin and the kinetics' first differences settle in that time.
  double calibrating_time = 0.25;
  // A clip reference is finished once the match has stayed on its last frame this long, seconds.
  double finished_time = 0.25;
};

// True when fewer than `min_tracked` of the 16 GPD joints (16 x 3 floats) carry a position: a
// joint at exactly (0, 0, 0) or non-finite counts as missing (trackers zero lost landmarks).
bool tracking_lost(const float* joints, int min_tracked = 13);

// Scores one stream's frames against a reference, following a clip reference with an Aligner
// (align.hpp). Allocates at construction only. [one thread at a time].
class Scorer {
 public:
  // A frame's scratch (the model's projection work, this frame's projections and u): read and
  // written within one frame only, so one workspace may serve every scorer a thread runs, one
  // frame at a time (a worker's streams), and stay in the caches across them. A Scorer owns one
  // for the calls without a workspace. [one thread at a time]
  struct Workspace {
    Metric::Workspace metric;
    AlignedFloats p;  // kProjectionRows x stride: a frame's projections
    AlignedFloats u;  // stride: u = W^T (x'' - y'')
    // Sizes the buffers for `m` (allocates only when they are too small) and, when the last
    // model it served had another shape, zero-fills them (padding reads as 0, as when fresh).
    void fit(const Metric& m);

   private:
    int stride_ = -1, groups_ = -1;
  };

  explicit Scorer(std::shared_ptr<const Reference> reference, AlignmentOptions options = {},
                  FeedbackOptions feedback = {});

  // Scores features x (kDims floats) of a frame at time t (seconds, increasing). Allocation-free.
  const ScoreRecord& score(const float* x, double t);
  // The same in the caller's workspace (fitted to this scorer's model: Workspace::fit), instead
  // of the scorer's own: results equal score()'s bit for bit. Allocation-free once fitted.
  const ScoreRecord& score(const float* x, double t, Workspace& ws);
  // The same against teacher frame `matched` (clamped to the clip) given by an offline alignment
  // (align_dtw.hpp), instead of the online alignment's match, which does not see the frame.
  // Allocation-free.
  const ScoreRecord& score_matched(const float* x, double t, int matched);
  // Scores one frame on each of n scorers at once, sharing each pass over W (the scorers must
  // use the same Metric and be distinct). Allocation-free; results equal score()'s.
  static void score_batch(Scorer* const* scorers, const float* const* x, const double* t, int n);
  // The same in the caller's workspaces instead of the scorers' own: ws[0 .. min(n, kBatch))
  // (distinct, each fitted to the model), frame f0 + f of each group of kBatch frames in ws[f].
  static void score_batch(Scorer* const* scorers, const float* const* x, const double* t, int n,
                          Workspace* const* ws);

  // A frame at time t without a usable pose (tracking lost, too few joints): a kTrackingLost
  // record (distance and scores 0, part_to_fix -1); the alignment holds. Allocation-free.
  const ScoreRecord& score_lost(double t);

  // The score map in use: the model's (Metric::calibration) until overridden here, e.g. by a
  // teacher who calibrated to their own takes. Throws kata::Error(kModel) for a bad calibration.
  // Allocates (the method text): call it between frames, not in the frame loop.
  void set_calibration(const ScoreCalibration& calibration);
  const ScoreCalibration& calibration() const { return calibration_; }
  // The lesson's tolerance (pose_error.hpp Tolerance): the part map every part score takes from
  // the next frame on; normal until set. Allocation-free.
  void set_tolerance(const Tolerance& tolerance) { tolerance_ = tolerance; }
  const Tolerance& tolerance() const { return tolerance_; }

  // Practice: follows only the reference frames first..last (last -1: the clip's end), looping
  // when `loop`, from the next frame on (the alignment restarts; the calibration is kept). Throws
  // kInvalidArgument for a section outside the clip (the scorer is then unchanged). Allocates:
  // call it between frames.
  void set_section(int first, int last, bool loop);

  const ScoreRecord& last() const { return record_; }
  const Reference& reference() const { return *reference_; }
  // The alignment's re-localisations since construction or reset (Aligner::relocations).
  int64_t relocations() const { return aligner_.relocations(); }
  const Aligner& aligner() const { return aligner_; }
  // Restarts the alignment (the next frame is matched anywhere in the section) and the frame count.
  void reset();

 private:
  void finish(const float* x, double t, int matched = -1);  // matched >= 0: that frame, not the alignment's
  // finish() in two stages (score_batch runs each over all its frames): the alignment's match of
  // this frame's projections (aligned_), then everything after it (given: aligned_ was the
  // caller's match, not the alignment's, so no re-match).
  void align_frame(double t);
  void finish_aligned(const float* x, double t, bool given);
  void feedback(double t);
  // The re-match of the alignment's match j (AlignmentOptions::rematch_time): the frame within
  // +-rematch_time of j, inside the section, with the smallest trimmed pose distance to this
  // frame's student pose (bones_); ties go to the frame nearest j; never before the last
  // re-matched frame while the alignment moves on. Allocation-free.
  // Taken only where the rest of the body agrees: trimmed_pose_distance's rest (12 bones) within
  // 12 (2 - 2 cos kRematchAgreement), i.e. its bones kRematchAgreement degrees off on average (as
  // a mean of 2 - 2 cos); otherwise j. 12 degrees (docs/model/scores.md "The re-match"): 8-12 left
  // every different-motion pairing of coaching.py unchanged and raised the same-motion ones (walk
  // 66.6 -> 67.8, run 58.3 -> 59.7); 15 raised dance vs walk by 1.2, no limit (every frame) by 3.7.
  // Allocation-free.
  int rematch(int j);
  static constexpr double kRematchAgreement = 12.0;
  // The part to fix of a kScoring frame at time t, from this frame's part scores and total: the
  // one decision (candidate, averaging and hysteresis) that the cue follows.
  void update_part_to_fix(double t);
  // The cue of the part to fix (called by update_part_to_fix, after it chose the part).
  void update_cue(double t);
  void clear_cue();

  std::shared_ptr<const Reference> reference_;
  Aligner aligner_;
  FeedbackOptions feedback_;
  ScoreCalibration calibration_;
  Tolerance tolerance_;
  Workspace own_;                   // the workspace of the calls that give none
  Workspace* ws_ = &own_;           // this frame's workspace (set by each scoring call)
  float pose_[kPoseFloats] = {};    // this frame's student pose in the body's frames (pose_error.hpp)
  PartError error_ = {};            // this frame's per-part angles and offsets
  float bones_[3 * kBones] = {};    // this frame's student bone directions (the re-match's)
  int rematch_frames_ = 0;          // the re-match's reach, teacher frames each way
  double rematch_rest_max_ = 0.0;   // the largest rest distance a re-match is taken at
  int aligned_ = 0;                 // this frame's alignment match (before the re-match)
  int last_aligned_ = -1, last_rematched_ = -1;  // the last re-match's input and output (-1: none)
  double smoothed_offset_[kParts] = {};  // part offsets averaged like the part scores (the ranking)
  int64_t count_ = 0;
  double start_time_ = 0.0;         // time of the first frame since construction or reset
  double at_end_since_ = -1.0;      // when the match reached the clip's last frame; -1: not there
  int32_t candidate_ = -1;          // part to fix proposed by the newest frames
  double smoothed_parts_[kParts] = {};  // part scores averaged over smoothing_time (the cue's)
  double smoothed_total_ = 0.0;     // the total averaged the same way
  double smoothed_time_ = -1.0;     // time of the newest frame in smoothed_parts_; -1: none yet
  double smoothed_weight_ = 0.0;    // the averages' summed weights since scoring (re)started (newest frame 1)
  double candidate_since_ = 0.0;
  int32_t shown_ = -1;              // part to fix reported
  BoneCue cue_ = {};                // this frame's per-bone angles at the joints (cue.hpp)
  double smoothed_cue_[gpd::kJoints] = {};   // cue_.degrees averaged like the part scores
  double smoothed_change_[gpd::kJoints] = {};  // cue_.change averaged the same way
  int32_t cue_candidate_ = -1;      // cue joint proposed by the newest frames
  double cue_candidate_since_ = 0.0;
  int32_t cue_shown_ = -1;          // cue joint reported
  ScoreRecord record_;
};

}  // namespace kata::metric
