// A coaching lesson: a student clip played frame by frame as a live stream through one
// per-stream pipeline (kata::pipeline::Pipeline) with the teacher attached, every result kept.
//
// This is the one place that drives the pipeline for `kata coach`: the viewer, the terminal view,
// the report and the recording read LessonData and never touch the pipeline. When the live
// runtime (`kata serve`, issue 9) lands, only Lesson's body changes: frames go to the runtime's
// stream and results come back from it.
//
// Memory: the constructor loads the clips, builds the teacher and reserves every per-frame array,
// so push() appends into reserved storage. Threads: one thread drives a Lesson.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "metric/parts.hpp"
#include "pipeline/pipeline.hpp"

namespace kata::coach {

// What the viewer and report show per frame, derived from what a result carries today:
//   calibrating      the push emitted no result yet (the stream is filling its history or
//                    estimating the body height) -- no score for this frame;
//   tracking         a scored result;
//   tracking lost    the stream refused the frame (NaN, wrong joint count, time not increasing);
//   teacher finished the alignment matched the teacher's last frame: the teacher has nothing
//                    more to show, the student is still moving.
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
};

// One pushed student frame and its result.
struct FrameRecord {
  int64_t frame = 0;          // student frame, counted from first_frame
  double time = 0.0;          // capture time, seconds from the first pushed frame
  FrameState state = FrameState::kCalibrating;
  float score = 0.0f;         // 0-100 (the pipeline's score)
  float distance = 0.0f;
  float parts[metric::kParts] = {};  // the split of distance^2 over the five parts
  int32_t matched = -1;       // teacher frame matched, counted from first_frame
  int32_t part_to_fix = -1;   // the part with the largest share of distance^2 (-1: none)
  int64_t latency_ns = 0;     // push -> result complete, steady clock
  bool has_ghost = false;
};

// Share of distance^2 part p holds in a record (0..1; negative terms clamped to 0).
float part_share(const FrameRecord& r, int part);
// argmax of parts (the part whose difference weighs most), -1 when all are <= 0.
int32_t part_to_fix(const float* parts);

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
  double delta_star = 0.0;               // the model's score scale
  std::vector<FrameRecord> frames;       // one per student frame (sized at start; state calibrating
                                         // until its result arrives)
  int pushed = 0;                        // frames pushed so far
  std::vector<float> positions;          // frames x joints x 3: the pushed student frames
  std::vector<float> ghosts;             // frames x ghost_joints x 3 (zeros without a ghost)

  const float* frame_positions(size_t i) const { return positions.data() + i * 3 * static_cast<size_t>(joints); }
  const float* frame_ghost(size_t i) const { return ghosts.data() + i * 3 * static_cast<size_t>(ghost_joints); }
  double mean_score() const;             // over tracking / teacher-finished frames
};

class Lesson {
 public:
  // Loads the model and both clips, attaches the teacher (the whole clip from first_frame,
  // followed by the online alignment; the ghost on the student's bones). Throws kata::Error.
  explicit Lesson(const LessonSettings& settings);

  int frame_count() const { return data_.student_frames; }
  double frame_time() const { return data_.frame_time; }
  // Pushes student frame i (i = 0, 1, ... in order) now and records every result it emits
  // (the frame's own; with the central stencil the previous frame's). Returns the number of
  // frames that got a result.
  int push(int i);
  // Flushes the stream after the last frame (the central stencil's last result).
  int finish();
  const LessonData& data() const { return data_; }

 private:
  LessonData data_;
  std::vector<float> clip_positions_;  // student frames x joints x 3
  std::unique_ptr<pipeline::Pipeline> pipeline_;
  std::vector<float> ghost_scratch_;
  int drain();
};

}  // namespace kata::coach
