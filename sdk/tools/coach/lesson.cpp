#include "coach/lesson.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "metric/scorer.hpp"

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

int32_t part_to_fix(const float* parts) {
  int32_t worst = -1;
  float worst_value = 0.0f;
  for (int p = 0; p < metric::kParts; ++p)
    if (parts[p] > worst_value) worst = p, worst_value = parts[p];
  return worst;
}

double LessonData::mean_score() const {
  double sum = 0.0;
  int n = 0;
  for (size_t i = 0; i < static_cast<size_t>(pushed) && i < frames.size(); ++i)
    if (const FrameRecord& r = frames[i]; r.state == FrameState::kTracking || r.state == FrameState::kTeacherFinished) sum += r.score, ++n;
  return n ? sum / n : 0.0;
}

Lesson::Lesson(const LessonSettings& settings) {
  data_.settings = settings;
  const auto metric = std::make_shared<const metric::Metric>(metric::load_model(settings.model));
  const BvhClip teacher = load_bvh(settings.teacher);
  const BvhClip student = load_bvh(settings.student);
  if (settings.first_frame < 0 || settings.first_frame >= teacher.frame_count() ||
      settings.first_frame >= student.frame_count())
    throw Error(ErrorKind::kInvalidArgument, "--first-frame " + std::to_string(settings.first_frame) +
                                                 " is past the end of a clip");
  if (!(settings.speed > 0.0)) throw Error(ErrorKind::kInvalidArgument, "--speed must be > 0");

  // The teacher: the whole clip from first_frame (positions for the ghost, features for the score).
  const GpdMap teacher_map = resolve_gpd_map(teacher.skeleton, settings.preset, "");
  const StreamConfig teacher_config = stream_config_for(teacher.skeleton, teacher_map, metric->stencil());
  const std::vector<float> teacher_positions = clip_positions(teacher, settings.first_frame);
  const int teacher_frames = teacher.frame_count() - settings.first_frame;
  const auto teacher_ref = pipeline::Teacher::from_positions(metric, teacher.skeleton, teacher_config,
                                                             teacher_positions.data(), teacher_frames,
                                                             teacher.frame_time);

  // The student: one live stream with its pipeline.
  pipeline::PipelineConfig config;
  const GpdMap student_map = resolve_gpd_map(student.skeleton, settings.preset, "");
  config.stream = stream_config_for(student.skeleton, student_map, metric->stencil());
  config.student = student.skeleton;
  config.result_capacity = 64;
  pipeline_ = std::make_unique<pipeline::Pipeline>(config);
  pipeline::TeacherOptions options;
  options.alignment.window = settings.window;
  pipeline_->set_teacher(teacher_ref, options);

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
  data_.ghost_joints = pipeline_->ghost_joint_count();
  data_.ghost_sources = pipeline_->ghost_sources();
  data_.teacher_frames = teacher_frames;
  data_.student_frames = student.frame_count() - settings.first_frame;
  data_.frame_time = student.frame_time;
  data_.delta_star = metric->delta_star();
  data_.frames.resize(static_cast<size_t>(data_.student_frames));
  for (int i = 0; i < data_.student_frames; ++i) {
    data_.frames[static_cast<size_t>(i)].frame = i;
    data_.frames[static_cast<size_t>(i)].time = i * data_.frame_time;
  }
  data_.positions.reserve(clip_positions_.size());
  data_.ghosts.assign(static_cast<size_t>(data_.student_frames) * 3 * static_cast<size_t>(data_.ghost_joints), 0.0f);
  ghost_scratch_.assign(3 * static_cast<size_t>(std::max(1, data_.ghost_joints)), 0.0f);
}

int Lesson::push(int i) {
  const size_t per_frame = 3 * static_cast<size_t>(data_.joints);
  const float* xyz = clip_positions_.data() + static_cast<size_t>(i) * per_frame;
  data_.positions.insert(data_.positions.end(), xyz, xyz + per_frame);
  ++data_.pushed;
  const Status status = pipeline_->push(i * data_.frame_time, xyz, data_.joints);
  if (status != Status::kOk) {
    data_.frames[static_cast<size_t>(i)].state = FrameState::kTrackingLost;
    return 0;
  }
  return drain();
}

int Lesson::finish() {
  pipeline_->flush();
  return drain();
}

int Lesson::drain() {
  int n = 0;
  pipeline::Result r;
  while (pipeline_->read(&r, ghost_scratch_.data(), nullptr, 1) == 1) {
    if (r.frame_index < 0 || r.frame_index >= data_.student_frames || !r.scored) continue;
    FrameRecord& f = data_.frames[static_cast<size_t>(r.frame_index)];
    f.score = r.score.score;
    f.distance = r.score.distance;
    std::copy(std::begin(r.score.parts), std::end(r.score.parts), f.parts);
    f.matched = r.matched_frame;
    f.part_to_fix = part_to_fix(f.parts);
    f.latency_ns = r.computed_ns - r.arrival_ns;
    f.has_ghost = r.has_ghost;
    f.state = r.matched_frame >= data_.teacher_frames - 1 ? FrameState::kTeacherFinished : FrameState::kTracking;
    if (r.has_ghost)
      std::copy(ghost_scratch_.begin(), ghost_scratch_.begin() + 3 * data_.ghost_joints,
                data_.ghosts.begin() + static_cast<ptrdiff_t>(r.frame_index) * 3 * data_.ghost_joints);
    ++n;
  }
  return n;
}

}  // namespace kata::coach
