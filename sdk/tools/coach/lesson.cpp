#include "coach/lesson.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "load_progress.hpp"
#include "metric/scorer.hpp"
#include "pipeline/pipeline.hpp"

namespace kata::coach {

const char* state_name(FrameState s) {
  switch (s) {
    case FrameState::kCalibrating: return "calibrating";
    case FrameState::kTracking: return "tracking";
    case FrameState::kTrackingLost: return "tracking lost";
    case FrameState::kTeacherFinished: return "teacher finished";
  }
  return "?";
}

float part_share(const FrameRecord& r, int part) {
  double total = 0.0;
  for (float p : r.parts) total += std::max(0.0f, p);
  return total > 0.0 ? static_cast<float>(std::max(0.0f, r.parts[part]) / total) : 0.0f;
}

bool scored(const FrameRecord& r) { return r.state == FrameState::kTracking || r.state == FrameState::kTeacherFinished; }

double LessonData::mean_score() const {
  double sum = 0.0;
  int n = 0;
  for (size_t i = 0; i < static_cast<size_t>(pushed) && i < frames.size(); ++i)
    if (scored(frames[i])) sum += frames[i].score, ++n;
  return n ? sum / n : 0.0;
}

namespace {

FrameState frame_state(int32_t score_state) {
  switch (static_cast<metric::ScoreState>(score_state)) {
    case metric::ScoreState::kScoring: return FrameState::kTracking;
    case metric::ScoreState::kCalibrating: return FrameState::kCalibrating;
    case metric::ScoreState::kTrackingLost: return FrameState::kTrackingLost;
    case metric::ScoreState::kTeacherFinished: return FrameState::kTeacherFinished;
  }
  return FrameState::kTrackingLost;
}

transport::SkeletonDefinition definition(uint64_t id, const BvhClip& clip, const std::string& preset) {
  transport::SkeletonDefinition d;
  d.stream_id = id;
  d.revision = 1;
  d.skeleton = clip.skeleton;
  d.layout = preset;
  d.frame_rate = static_cast<float>(1.0 / clip.frame_time);
  return d;
}

}  // namespace

Lesson::Lesson(const LessonSettings& settings) {
  data_.settings = settings;
  const auto metric = std::make_shared<const metric::Metric>(metric::load_model(settings.model));
  tools::LoadProgress progress(settings.teacher);  // a line on stderr if loading takes > 1 s (issue 36)
  const BvhClip teacher = load_bvh(settings.teacher);
  const BvhClip student = load_bvh(settings.student);
  if (settings.first_frame < 0 || settings.first_frame >= teacher.frame_count() ||
      settings.first_frame >= student.frame_count())
    throw Error(ErrorKind::kInvalidArgument, "--first-frame " + std::to_string(settings.first_frame) +
                                                 " is past the end of a clip");
  if (!(settings.speed > 0.0)) throw Error(ErrorKind::kInvalidArgument, "--speed must be > 0");

  // The teacher: the whole clip from first_frame (positions for the ghost, features for the score).
  const GpdMap teacher_map = resolve_gpd_map(teacher, settings.preset, "");
  const StreamConfig teacher_config = stream_config_for(teacher.skeleton, teacher_map, metric->stencil());
  teacher_positions_ = clip_positions(teacher, settings.first_frame);
  const int teacher_frames = teacher.frame_count() - settings.first_frame;
  const auto teacher_ref = pipeline::Teacher::from_positions(metric, teacher.skeleton, teacher_config,
                                                             teacher_positions_.data(), teacher_frames,
                                                             teacher.frame_time, -1, std::ref(progress));
  teacher_joints_ = teacher.skeleton.joint_count();
  teacher_frame_time_ = teacher.frame_time;

  // The student's pipeline with the teacher attached, built here (so the ghost's joints are
  // known before the first result) and handed to the runtime.
  pipeline::PipelineConfig config;
  const GpdMap student_map = resolve_gpd_map(student, settings.preset, "");
  config.stream = stream_config_for(student.skeleton, student_map, metric->stencil());
  config.student = student.skeleton;
  config.result_capacity = 64;
  auto student_pipeline = std::make_unique<pipeline::Pipeline>(config);
  pipeline::TeacherOptions options;
  options.alignment.window = settings.window;
  // Practice modes: clip frames to reference frames (counted from first_frame); the Aligner
  // refuses a section outside the clip, naming it.
  if (settings.teacher_start >= 0) options.alignment.first_frame = settings.teacher_start - settings.first_frame;
  if (settings.loop_first >= 0) {
    options.alignment.first_frame = settings.loop_first - settings.first_frame;
    options.alignment.last_frame = settings.loop_last - settings.first_frame;
    options.alignment.loop = true;
  }
  student_pipeline->set_teacher(teacher_ref, options);

  clip_positions_ = clip_positions(student, settings.first_frame);
  data_.joint_names = student.skeleton.names;
  data_.joint_parents = student.skeleton.parents;
  data_.joints = student.skeleton.joint_count();
  data_.joint_part.assign(static_cast<size_t>(data_.joints), static_cast<int>(metric::Part::kTorsoHead));
  data_.left_hip = student_map.source[10];
  data_.right_hip = student_map.source[13];
  std::vector<int> own_part(static_cast<size_t>(data_.joints), -1);
  for (int g = 0; g < kGpdJoints; ++g) own_part[static_cast<size_t>(student_map.source[static_cast<size_t>(g)])] = metric::joint_part(g);
  for (int j = 0; j < data_.joints; ++j) {  // parents come first, so a parent's part is final
    const int parent = student.skeleton.parents[static_cast<size_t>(j)];
    data_.joint_part[static_cast<size_t>(j)] = own_part[static_cast<size_t>(j)] >= 0 ? own_part[static_cast<size_t>(j)]
                                               : parent >= 0 ? data_.joint_part[static_cast<size_t>(parent)]
                                                             : static_cast<int>(metric::Part::kTorsoHead);
  }
  data_.ghost_joints = student_pipeline->ghost_joint_count();
  data_.ghost_sources = student_pipeline->ghost_sources();
  data_.teacher_frames = teacher_frames;
  data_.student_frames = student.frame_count() - settings.first_frame;
  data_.frame_time = student.frame_time;
  data_.delta_star = metric->delta_star();
  data_.d50 = metric->calibration().d50;
  data_.good_score = metric->calibration().good_score;
  data_.frames.resize(static_cast<size_t>(data_.student_frames));
  for (int i = 0; i < data_.student_frames; ++i) {
    data_.frames[static_cast<size_t>(i)].frame = i;
    data_.frames[static_cast<size_t>(i)].time = i * data_.frame_time;
  }
  data_.positions.reserve(clip_positions_.size());
  data_.ghosts.assign(static_cast<size_t>(data_.student_frames) * 3 * static_cast<size_t>(data_.ghost_joints), 0.0f);
  ready_ = std::make_unique<std::atomic<uint8_t>[]>(static_cast<size_t>(data_.student_frames));
  for (int i = 0; i < data_.student_frames; ++i) ready_[static_cast<size_t>(i)].store(0, std::memory_order_relaxed);

  // The runtime: one worker (two streams), results published over ZeroMQ and recorded here.
  runtime::RuntimeConfig rc;
  rc.workers = 1;
  rc.max_streams = 2;
  rc.max_joints = std::max(data_.joints, teacher_joints_);
  rc.frame_queue_capacity = 1024;
  rc.result_queue_capacity = 1024;
  rc.publish.endpoints = {settings.publish};
  rc.sinks.push_back({[this](const transport::ResultFields& f) { on_result(f); }, {}});
  runtime_ = std::make_unique<runtime::Runtime>(rc);

  runtime::StreamSetup teacher_setup;
  teacher_setup.pipeline.stream = teacher_config;
  teacher_setup.pipeline.student = teacher.skeleton;
  runtime_->open_stream(definition(kTeacherStream, teacher, settings.preset), teacher_setup);
  runtime_->adopt_stream(definition(kStudentStream, student, settings.preset), student_pipeline.get(),
                         [](pipeline::Pipeline* p) { delete p; }, false);
  student_pipeline.release();  // the runtime owns it now
}

Lesson::~Lesson() {
  if (runtime_) runtime_->stop();  // the sink writes into data_: stop before it goes
}

void Lesson::on_result(const transport::ResultFields& f) {
  if (f.stream_id == kTeacherStream) {
    teacher_results_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (f.stream_id != kStudentStream || f.frame_sequence >= static_cast<uint64_t>(data_.student_frames)) return;
  const size_t i = static_cast<size_t>(f.frame_sequence);
  FrameRecord& r = data_.frames[i];
  r.state = f.scored ? frame_state(f.state) : FrameState::kCalibrating;
  r.score = f.score;
  r.distance = f.distance;
  std::copy(std::begin(f.parts), std::end(f.parts), r.parts);
  std::copy(std::begin(f.part_scores), std::end(f.part_scores), r.part_scores);
  r.matched = f.matched_teacher_frame;
  r.matched_time = f.matched_teacher_time;
  r.part_to_fix = f.part_to_fix;
  r.cue_joint = f.cue_joint, r.cue_degrees = f.cue_degrees, r.cue_action = f.cue_action;
  r.latency_ns = f.published_ns > 0 ? f.published_ns - f.arrival_ns : f.computed_ns - f.arrival_ns;
  r.has_ghost = f.ghost != nullptr && static_cast<int>(f.ghost_joint_count) == data_.ghost_joints;
  if (r.has_ghost)
    std::memcpy(data_.ghosts.data() + i * 3 * static_cast<size_t>(data_.ghost_joints), f.ghost,
                sizeof(float) * 3 * static_cast<size_t>(data_.ghost_joints));
  ready_[i].store(1, std::memory_order_release);
  newest_ready_.store(static_cast<int64_t>(i), std::memory_order_release);
}

size_t Lesson::settle() {
  const int64_t newest = newest_ready_.load(std::memory_order_acquire);
  while (settled_ < static_cast<size_t>(data_.pushed)) {
    if (!ready(settled_)) {
      if (static_cast<int64_t>(settled_) >= newest) break;
      data_.frames[settled_].state = FrameState::kTrackingLost;
      ready_[settled_].store(1, std::memory_order_release);
    }
    ++settled_;
  }
  return settled_;
}

void Lesson::push(int i) {
  const size_t per_frame = 3 * static_cast<size_t>(data_.joints);
  const float* xyz = clip_positions_.data() + static_cast<size_t>(i) * per_frame;
  data_.positions.insert(data_.positions.end(), xyz, xyz + per_frame);  // reserved: no allocation
  ++data_.pushed;
  const double t = i * data_.frame_time;
  // The teacher's stream plays on the same clock: every teacher frame due by now.
  const size_t teacher_floats = 3 * static_cast<size_t>(teacher_joints_);
  for (; teacher_pushed_ < data_.teacher_frames && teacher_pushed_ * teacher_frame_time_ <= t + 1e-9; ++teacher_pushed_)
    runtime_->push(kTeacherStream, static_cast<uint64_t>(teacher_pushed_), teacher_pushed_ * teacher_frame_time_,
                   teacher_positions_.data() + static_cast<size_t>(teacher_pushed_) * teacher_floats, teacher_joints_);
  if (runtime_->push(kStudentStream, static_cast<uint64_t>(i), t, xyz, data_.joints) != Status::kOk) {
    data_.frames[static_cast<size_t>(i)].state = FrameState::kTrackingLost;
    ready_[static_cast<size_t>(i)].store(1, std::memory_order_release);
  }
}

void Lesson::finish() {
  if (finished_) return;
  finished_ = true;
  runtime_->stop();  // every queued frame computed, every result sent and recorded
  // A pushed frame the stream accepted but never answered (none expected): shown as lost.
  for (int i = 0; i < data_.pushed; ++i)
    if (!ready(static_cast<size_t>(i))) {
      data_.frames[static_cast<size_t>(i)].state = FrameState::kTrackingLost;
      ready_[static_cast<size_t>(i)].store(1, std::memory_order_release);
    }
}

}  // namespace kata::coach
