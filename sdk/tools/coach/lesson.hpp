// A coaching lesson: the teacher and the student clips played frame by frame as two live streams
// through a kata runtime (kata/runtime.h: a worker thread, an I/O thread, results published over
// ZeroMQ), as any app on the public C ABI would: the clips, the model, the streams and the runtime
// are libkata's handles, nothing of the SDK's private core. The student's stream has the teacher attached (the
// whole clip, followed by the online alignment, with the model's calibrated score map): every
// frame is scored (total and per-part), the part to fix named, and the ghost made. The teacher's
// stream is published beside it (features only) so a subscriber sees both.
//
// This is the one place that drives the runtime for `kata coach`: the viewer, the terminal view,
// the report and the recording read LessonData and never touch the runtime.
//
// Threads: one thread (the caller's) pushes frames; the runtime hands every student result to an
// in-process callback (kata_runtime_desc.on_result) that writes it into the frame's preallocated record and then marks
// the frame ready (release store). The caller reads a frame's record only once ready(i) is true.
// Memory: the constructor loads the clips, builds the teacher and reserves every per-frame array;
// push() and the sink write into reserved storage.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "failure.hpp"
#include "kata/kata.h"

namespace kata::coach {

// What the viewer and report show per frame (the record's kata_score_state):
//   calibrating      the stream has just started: no score yet;
//   tracking         a scored frame;
//   tracking lost    too few joints tracked in this frame, or the stream refused it (NaN, wrong
//                    joint count, time not increasing): no score;
//   teacher finished the student outlasted the teacher's clip: scored against its last frame.
// The numbers are the recording's (stable).
enum class FrameState : uint8_t { kCalibrating = 0, kTracking = 1, kTrackingLost = 2, kTeacherFinished = 3 };
const char* state_name(FrameState s);

struct LessonSettings {
  std::string model = "models/default.kata";
  std::string teacher = "data/cmu/05_18.bvh";
  std::string student = "data/cmu/05_19_on_02.bvh";
  std::string preset = "cmu";  // GPD joint map of both clips
  int first_frame = 1;         // first frame of each clip (1 skips the CMU converter's T-pose)
  double speed = 1.0;          // playback rate (1 = real time)
  double window = 0.5;         // alignment window, teacher seconds
  std::string tolerance;       // kata_teacher_desc.tolerance; "" for the default (normal)
  // Practice (teacher clip frames, like first_frame; -1: unset): the lesson starts at
  // teacher_start (the teacher before it is not used), or loops the section loop_first..loop_last.
  // Kept in recordings (array 'practice').
  int teacher_start = -1;
  int loop_first = -1, loop_last = -1;
  // Repetitions (docs/coach/repetitions.md): the teacher (the whole clip from first_frame, or its
  // seconds rep_start..rep_end, clip time) is one repetition, looped; the counter, tempo and depth
  // are shown live and in the report. The settings are not kept in recordings (the repetitions are).
  bool reps = false;
  double rep_start = -1.0, rep_end = -1.0;
  // Where the runtime publishes results (ZeroMQ PUB, bound); "*" as the port: any free one.
  std::string publish = "tcp://127.0.0.1:*";
};

// One pushed student frame and its result.
struct FrameRecord {
  int64_t frame = 0;          // student frame, counted from first_frame
  double time = 0.0;          // capture time, seconds from the first pushed frame
  FrameState state = FrameState::kCalibrating;
  float score = 0.0f;         // 0-100, the calibrated total score
  float distance = 0.0f;
  float parts[KATA_PART_COUNT] = {};        // the split of distance^2 over the five parts
  float part_scores[KATA_PART_COUNT] = {};  // each part's calibrated 0-100 score
  int32_t matched = -1;       // teacher frame matched, counted from first_frame
  double matched_time = -1.0; // where the student is in the routine: the matched frame's time,
                              // seconds from first_frame (-1: not scored, or a recording's frame)
  int32_t part_to_fix = -1;   // the scorer's part to fix (kata/teacher.h: held 0.3 s), -1: none
  // The correction cue (kata/result.h): the GPD joint to move (-1: none), the angle at it in
  // degrees, the kata_cue_action (-1: none). Present iff part_to_fix is.
  int32_t cue_joint = -1;
  float cue_degrees = 0.0f;
  int32_t cue_action = -1;
  int64_t latency_ns = 0;     // frame in -> result published, steady clock
  bool has_ghost = false;
  // The repetition in progress (1 + the complete ones; 0 without a clip teacher or in a
  // recording from before repetitions) and the progress through the teacher's section, 0..1
  // (kata/result.h).
  int32_t repetition = 0;
  float repetition_progress = 0.0f;
};

// Share of distance^2 part p holds in a record (0..1; negative terms clamped to 0).
float part_share(const FrameRecord& r, int part);
// A frame with a score (tracking or teacher finished).
bool scored(const FrameRecord& r);
// The record's correction cue in English ("left knee: bend 30 deg more"; "" for none), as
// kata_cue_text writes it. Returns buf.
const char* cue_phrase(const FrameRecord& r, char* buf, size_t size);
// A kata_body_part's name ("left_arm"), "?" out of range.
const char* part_name(int part);
using cli::fail;  // the CLI's failure: "kata: message", exit 1

// Everything a lesson produced (also what a recording holds).
struct LessonData {
  LessonSettings settings;
  std::vector<std::string> joint_names;  // student skeleton
  std::vector<int> joint_parents;
  std::vector<int> ghost_sources;        // ghost joint -> student joint
  std::vector<int> joint_part;           // student joint -> body part (its own GPD joint's part, or
                                         // its nearest GPD ancestor's: fingers go with the hand)
  int joints = 0, ghost_joints = 0;
  int left_hip = -1, right_hip = -1;     // student joints of GPD LHip / RHip (which way the body faces)
  int teacher_frames = 0;                // from first_frame
  int student_frames = 0;                // frames to push
  double frame_time = 0.0;               // student clip, seconds
  double delta_star = 0.0;               // the model's threshold on the distance
  double d50 = 0.0, good_score = 0.0;    // the calibrated score map: distance scoring 50; no part
                                         // to fix at or above good_score
  std::vector<FrameRecord> frames;       // one per student frame (sized at start)
  int pushed = 0;                        // frames pushed so far
  std::vector<float> positions;          // frames x joints x 3: the pushed student frames
  std::vector<float> ghosts;             // frames x ghost_joints x 3 (zeros without a ghost)
  std::vector<kata_repetition> repetitions;  // every repetition that ended (complete or partial),
                                             // in order: Lesson::finish fills it (recorded)

  const float* frame_positions(size_t i) const { return positions.data() + i * 3 * static_cast<size_t>(joints); }
  const float* frame_ghost(size_t i) const { return ghosts.data() + i * 3 * static_cast<size_t>(ghost_joints); }
  double mean_score() const;             // over scored frames among the pushed ones
};

class Lesson {
 public:
  // Loads the model and both clips, builds the teacher (the whole clip from first_frame; the
  // ghost on the student's bones), starts the runtime (publisher bound to settings.publish) and
  // opens the two streams. Throws kata::cli::Failure with libkata's message.
  explicit Lesson(const LessonSettings& settings);
  ~Lesson();
  Lesson(const Lesson&) = delete;
  Lesson& operator=(const Lesson&) = delete;

  static constexpr uint64_t kTeacherStream = 1, kStudentStream = 2;

  int frame_count() const { return data_.student_frames; }
  double frame_time() const { return data_.frame_time; }
  // Pushes student frame i (i = 0, 1, ... in order) and every teacher frame due by its time.
  // Never blocks; a frame the runtime refuses is recorded as tracking lost.
  void push(int i);
  // Stops the runtime once every pushed frame has its result (sent and recorded).
  void finish();
  // True once frame i's result is in data().frames[i] (or the frame was refused).
  bool ready(size_t i) const { return ready_[i].load(std::memory_order_acquire) != 0; }
  // The number of leading frames whose record is final: ready, or passed over (a later frame has
  // its result, so this one, refused inside the stream, never will: recorded as tracking lost).
  // [the pushing thread]
  size_t settle();
  const LessonData& data() const { return data_; }
  // The runtime's endpoint (resolved port) and counters.
  std::string publish_endpoint() const { return kata_runtime_publish_endpoint(runtime_); }
  kata_runtime_counters counters() const;
  // Frame in -> result published, ns, below which a fraction q of every published result lies
  // (both streams).
  double latency_percentile(double q) const { return kata_runtime_latency_percentile(runtime_, q); }
  uint64_t teacher_results() const { return teacher_results_.load(std::memory_order_relaxed); }
  // The repetitions ended so far (the runtime's on_repetition), and the k-th (k < that), readable
  // from the pushing thread while the lesson runs. The first kMaxRepetitions are kept.
  static constexpr size_t kMaxRepetitions = 4096;
  size_t repetitions_ended() const { return repetitions_count_.load(std::memory_order_acquire); }
  const kata_repetition& repetition(size_t k) const { return repetitions_[k]; }

 private:
  static void on_result(void* self, const kata_result_record* r);  // the runtime's thread
  static void on_repetition(void* self, const kata_repetition* r);  // the runtime's thread

  LessonData data_;
  std::vector<float> clip_positions_;     // student frames x joints x 3
  std::vector<float> teacher_positions_;  // teacher frames x joints x 3
  int teacher_joints_ = 0;
  double teacher_frame_time_ = 0.0;
  int teacher_pushed_ = 0;
  std::unique_ptr<std::atomic<uint8_t>[]> ready_;
  std::atomic<uint64_t> teacher_results_{0};
  std::vector<kata_repetition> repetitions_;  // kMaxRepetitions, reserved at construction
  std::atomic<size_t> repetitions_count_{0};
  std::atomic<int64_t> newest_ready_{-1};  // the newest frame with a result (results come in order)
  size_t settled_ = 0;
  // libkata's handles, released in reverse order (the runtime first: its callback writes into data_).
  kata_context context_ = nullptr;
  kata_model model_ = nullptr;
  kata_clip teacher_clip_ = nullptr, student_clip_ = nullptr;
  kata_skeleton teacher_skeleton_ = nullptr, student_skeleton_ = nullptr;
  kata_stream teacher_stream_ = nullptr, student_stream_ = nullptr;  // until the runtime owns them
  kata_runtime runtime_ = nullptr;
  bool finished_ = false;
  void release();
};

}  // namespace kata::coach
