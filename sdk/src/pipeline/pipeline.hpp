// One stream, one pipeline: every feature vector a stream emits goes features -> score -> ghost
// inside the push that produced it, and lands in a ring of per-frame results sized at open.
//
//   push(frame) -> Stream (map to GPD joints, local frame, static blocks, kinetics)
//               -> for each emitted vector (one per push; several after calibration or a flush):
//                    Scorer (normalise, project with W, score, part split, clip alignment)
//                    -> the matched teacher frame's joint positions -> Retargeter (warm solve,
//                       exact bones) -> placed over the student's pose of that same frame
//                  -> Result in the ring (sequence, frame, capture / arrival / computed times,
//                     score record, matched teacher frame, ghost)
//   read(...)   -> drains every result since the previous read, oldest first.
//
// So no emitted frame goes unscored, the alignment sees every frame whatever the reader's rate,
// and the ghost is driven by the frame the score matched. A full ring overwrites its oldest
// unread result and counts it (dropped()).
//
// Memory: the constructor and set_teacher() allocate everything; push/flush/reset/read never do.
// Threads: one pipeline is used by one thread at a time; pipelines share only immutable data
// (Teacher, metric), so many run in parallel with no lock.
// Clock: arrival and computed times are std::chrono::steady_clock (CLOCK_MONOTONIC on Linux)
// nanoseconds; the capture time is the caller's timestamp of the frame, in seconds.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/status.hpp"
#include "metric/reps.hpp"
#include "metric/scorer.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/mapped.hpp"
#include "retarget/retargeter.hpp"
#include "skeleton/skeleton.hpp"
#include "stream/stream.hpp"

namespace kata::pipeline {

// steady_clock nanoseconds: the clock of Result::arrival_ns / computed_ns.
int64_t now_ns();

// A teacher: the metric reference (W^T-projections of each teacher frame, what the score compares)
// and, frame for frame beside it, the teacher's joint positions (what the ghost is made from).
// Immutable once built; shared by any number of pipelines and threads.
struct Teacher {
  std::shared_ptr<const metric::Reference> reference;
  Skeleton skeleton;             // the teacher's joint tree; empty when only features were given
  std::vector<float> positions;  // reference->frames() x skeleton joints x 3 (teacher units), or empty

  bool has_positions() const { return !positions.empty(); }
  int joint_count() const { return skeleton.joint_count(); }
  const float* frame_positions(int j) const {
    return positions.data() + static_cast<size_t>(j) * 3 * static_cast<size_t>(joint_count());
  }

  // A teacher from recorded joint positions (frames x skeleton joints x 3 floats, row-major,
  // teacher units), `frame_time` seconds apart. Features are computed through a Stream with
  // `stream_config` (its stencil must be the metric's). pose_frame >= 0: only that frame, as a
  // pose reference; -1: the whole clip, followed by the online alignment. `progress`, if set, is
  // called with (frames projected, frames) after each chunk of a clip (a long teacher's loading
  // takes seconds: kata coach and kata serve show it). Throws kata::Error.
  using LoadProgress = std::function<void(int done, int frames)>;
  static std::shared_ptr<const Teacher> from_positions(std::shared_ptr<const metric::Metric> metric,
                                                       const Skeleton& skeleton, const StreamConfig& stream_config,
                                                       const float* positions, int frames, double frame_time,
                                                       int pose_frame = -1, const LoadProgress& progress = {});
  // A teacher known only by its features (no positions: scores, no ghost).
  static std::shared_ptr<const Teacher> from_reference(std::shared_ptr<const metric::Reference> reference);
};

struct PipelineConfig {
  StreamConfig stream;
  Skeleton student;          // the input skeleton; its rest offsets give the ghost's bone lengths
  int result_capacity = 64;  // results kept until read (>= 1)
  bool keep_features = false;  // also keep each result's feature vector (kDims floats) in the ring
};

// How the pipeline scores and ghosts against a teacher.
struct TeacherOptions {
  metric::AlignmentOptions alignment;
  bool ghost = true;                  // retarget the matched teacher frame (needs positions + rest pose)
  std::string ghost_joints = "cmu";   // retarget joint set (retarget/joint_set.hpp)
  retarget::RetargetOptions retarget;
  // The ghost across layouts (a CMU teacher, a MediaPipe student): the teacher's frames read
  // through ghost_teacher (its layout's map and axes), the student's through the stream's own,
  // retargeted on the 16 GPD joints both map (retarget::MappedRetargeter) and placed over the
  // student: 16 joints, GPD order, the student's axes and units. ghost_joints is then unused. The
  // student's bone lengths come from its rest pose, or else from the stream's estimate: no ghost
  // until Stream::bone_lengths has them (a webcam student has no rest pose).
  bool ghost_across = false;
  retarget::MappedSide ghost_teacher;
  // The lesson's tolerance: the part map of the stream's scores (metric/pose_error.hpp).
  metric::Tolerance tolerance;
};

// One emitted feature vector's result.
struct Result {
  uint64_t sequence = 0;      // 0, 1, 2... per pipeline: one per emitted vector, never reused
  int64_t frame_index = -1;   // the stream frame (0-based count of accepted frames)
  double capture_time = 0.0;  // the caller's timestamp of that frame, seconds
  int64_t arrival_ns = 0;     // steady clock: when the push that emitted it began
  int64_t computed_ns = 0;    // steady clock: when this result was complete
  bool scored = false;        // a teacher is attached: score holds the record
  metric::ScoreRecord score;  // score.matched = matched teacher frame
  int32_t matched_frame = -1; // teacher frame matched (-1 when not scored)
  bool has_ghost = false;     // the ghost (ghost_joint_count() x 3 floats) was made
  // Repetitions (metric/reps.hpp), against a clip teacher: the repetition in progress (1 + the
  // complete ones; 0 without a clip teacher), the match's progress through the section (0..1), and
  // whether this frame ended one (Pipeline::repetitions()->newest() says how it went).
  int32_t repetition = 0;
  float repetition_progress = 0.0f;
  bool repetition_ended = false;
};

class Pipeline;

// A thread's scratch for the pipelines it pushes, one frame at a time: the scorer's and the
// ghost's per-frame work (metric::Scorer::Workspace, retarget::Retargeter::Workspace). A runtime
// worker holds one for all its streams, so a frame touches these buffers hot, where each stream's
// own set would be evicted between two of its frames. Results equal the pipelines' own scratch's
// bit for bit. Grows on use: a push allocates only when a pipeline needs more than it holds (the
// first frame of a model or a ghost joint set larger than any before). [one thread at a time]
class Scratch {
 public:
  Scratch() = default;
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;

 private:
  friend class Pipeline;
  metric::Scorer::Workspace score_[metric::detail::kBatch];  // a score batch's frames
  retarget::Retargeter::Workspace ghost_;
};

class Pipeline {
 public:
  // Allocates the stream, the ring and its buffers. Throws kata::Error(kInvalidArgument).
  explicit Pipeline(const PipelineConfig& config);

  // Attaches a teacher (replacing any): builds the scorer and, when options.ghost and the teacher
  // has positions and the student a rest pose, the retargeter. Allocates. Throws kata::Error
  // (kInvalidArgument: the stream's stencil differs from the metric's; the skeletons do not
  // share the ghost joints). The alignment starts from the clip's beginning.
  void set_teacher(std::shared_ptr<const Teacher> teacher, const TeacherOptions& options = {});
  void clear_teacher();
  // Restarts the alignment (next frame matched from the clip's start) and the ghost's warm start.
  // A restart is the end of a take too: the repetition in progress ends first (as at flush(),
  // complete or partial; flush_ended_repetition() says so), then the counter starts again from 1.
  void restart_teacher();
  bool has_teacher() const { return teacher_ != nullptr; }
  bool has_ghost() const { return retargeter_ != nullptr || across_; }
  // The teacher's scorer (null without a teacher), e.g. to override its calibration.
  metric::Scorer* scorer() { return scorer_.get(); }
  // The teacher's repetition counter (null without a clip teacher): the repetitions ended so far.
  const metric::RepCounter* repetitions() const { return reps_.get(); }

  // Pushes a frame (Stream::push) and runs every vector it emits through score and ghost.
  // arrival_ns: the steady-clock time the frame arrived (0: now). A refused frame changes
  // nothing (last_error() says why). Allocation-free.
  Status push(double capture_time, const float* xyz, int joint_count, int64_t arrival_ns = 0) {
    return push(capture_time, xyz, nullptr, joint_count, arrival_ns);
  }
  // With a confidence per input joint (Stream::push with confidences; may return kTrackingLost).
  // A non-finite coordinate kept for the ghost's placement is replaced by the previous frame's.
  // scratch: the calling thread's Scratch for the frame's work, or null for the pipeline's own.
  Status push(double capture_time, const float* xyz, const float* confidence, int joint_count,
              int64_t arrival_ns = 0, Scratch* scratch = nullptr);

  // One frame of a burst (push_burst): the arguments of push() and, after the call, its status.
  struct BurstFrame {
    Pipeline* pipeline = nullptr;
    double capture_time = 0.0;
    const float* xyz = nullptr;
    const float* confidence = nullptr;
    int joint_count = 0;
    int64_t arrival_ns = 0;
    Status status = Status::kOk;  // out: what push() would have returned
  };
  // The most frames one push_burst call takes.
  static constexpr int kMaxBurst = 64;
  // Pushes one frame on each of n distinct pipelines (kMaxBurst at a time), stage by stage: the
  // features of all, then the frames scored against the same model together (one pass over W
  // for up to metric::detail::kBatch of them, Scorer::score_batch: every alignment, then every
  // part split), then each frame's repetitions, ghost and result. Every result, ring and
  // state equals what n push() calls in any order leave, bit for bit (computed_ns aside, a clock):
  // the pipelines share nothing but immutable data. A frame that emits other than one vector, is
  // tracking-lost, or has no teacher takes push()'s path. Allocation-free. Throws nothing the
  // pushes would not; frames[f].status is push()'s. scratch: as push()'s, for every frame.
  static void push_burst(BurstFrame* frames, int n, Scratch* scratch = nullptr);
  // Stream::flush / reset, with any vector they emit processed like a push's. flush returns
  // Stream::flush's status (kInternal when a non-finite vector was withheld). flush is the end
  // of a take: it also ends the repetition in progress (metric::RepCounter::finish: complete if
  // it reached the section's end, else partial), which no result carries: flush_ended_repetition()
  // says so until the next flush or restart_teacher(), repetitions()->newest() says how it went.
  Status flush();
  void reset();
  bool flush_ended_repetition() const { return flush_ended_repetition_; }

  // Moves every unread result (oldest first, at most `capacity`) into out[0..n); ghosts, when
  // not null, receives n x ghost_joint_count() x 3 floats (zeros for a result without a ghost);
  // features, when not null and keep_features is set, n x kDims floats. Returns n.
  size_t read(Result* out, float* ghosts, float* features, size_t capacity);
  // Unread results in the ring.
  size_t pending() const { return static_cast<size_t>(written_ - read_); }
  // Results overwritten before they were read, since construction.
  uint64_t dropped() const { return dropped_; }
  // The newest result (read or not), or null before the first; its ghost / features.
  const Result* newest() const;
  const float* newest_ghost() const;
  const float* newest_features() const;

  // Joints of a ghost (the retarget joint set; 0 without one) and the student skeleton joint each
  // stands for.
  int ghost_joint_count() const { return ghost_joints_; }
  const std::vector<int>& ghost_sources() const { return selection_.source; }

  const Stream& stream() const { return stream_; }
  Stream& stream() { return stream_; }  // for the stream's own settings (confidence gate, smoothing)
  const Skeleton& student() const { return config_.student; }
  const Teacher* teacher() const { return teacher_.get(); }
  const char* last_error() const { return stream_.last_error(); }

 private:
  // push() up to the scoring: the stream's push and the raw frame kept for the ghost. *before:
  // the stream's emitted count before it. Returns push()'s status.
  Status push_features(double capture_time, const float* xyz, const float* confidence, int joint_count,
                       int64_t* before);
  void process_emitted(int64_t before, int64_t arrival_ns);
  // prescored: the scorer already scored `frame` (push_burst); its record is scorer_->last().
  void produce(int64_t frame, int64_t arrival_ns, bool prescored = false);
  // Scores emitted frame `frame`; too few tracked joints give a tracking-lost record instead.
  const metric::ScoreRecord& score_frame(int64_t frame, double t);
  // The frame's scorer workspace k (< kBatch) and ghost workspace: scratch_'s, fitted, or the
  // scorer's and retargeter's own (null).
  metric::Scorer::Workspace* score_workspace(int k);
  retarget::Retargeter::Workspace* ghost_workspace();
  size_t slot(uint64_t sequence) const { return static_cast<size_t>(sequence % static_cast<uint64_t>(capacity_)); }

  PipelineConfig config_;
  Stream stream_;
  int history_ = 0;
  int capacity_ = 0;
  Scratch* scratch_ = nullptr;  // the push in progress's (null: the scorer's and retargeter's own)

  // Teacher side (rebuilt by set_teacher).
  std::shared_ptr<const Teacher> teacher_;
  std::unique_ptr<metric::Scorer> scorer_;
  std::unique_ptr<metric::RepCounter> reps_;  // a clip teacher's repetitions (metric/reps.hpp)
  bool flush_ended_repetition_ = false;        // the last flush() ended one
  std::unique_ptr<retarget::Retargeter> retargeter_;
  retarget::JointSelection selection_;   // ghost joints: index into student and teacher skeletons
  int ghost_joints_ = 0;
  std::vector<double> teacher_pose_, ghost_pose_, student_pose_;  // ghost joints x 3
  std::vector<float> student_ring_;      // history x input joints x 3: raw frames, for placing ghosts
  // The ghost across layouts (TeacherOptions::ghost_across): mapped_ is built in set_teacher from
  // the student's rest pose, or once, on the first result after the stream's bone-length estimate
  // is ready (one allocation per teacher, not per frame: the lengths are not known before).
  bool across_ = false;
  retarget::MappedSide across_teacher_;
  retarget::RetargetOptions across_options_;
  std::unique_ptr<retarget::MappedRetargeter> mapped_;
  bool make_mapped();  // builds mapped_ when the student's lengths are known; false before

  // Result ring.
  std::vector<Result> results_;
  std::vector<float> ghost_ring_;        // capacity x (ghost joints capacity) x 3
  std::vector<float> feature_ring_;      // capacity x kDims when keep_features
  int ghost_stride_ = 0;                 // floats per ghost slot (sized for the largest joint set)
  uint64_t written_ = 0, read_ = 0, dropped_ = 0;
};

}  // namespace kata::pipeline
