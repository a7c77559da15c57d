#include "coach/lesson.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "load_progress.hpp"

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

const char* cue_phrase(const FrameRecord& r, char* buf, size_t size) {
  kata_result_record k;
  std::memset(&k, 0, sizeof k);
  k.struct_size = sizeof k;
  k.part_to_fix = r.part_to_fix;
  k.cue_joint = r.cue_joint;
  k.cue_degrees = r.cue_degrees;
  k.cue_action = r.cue_action;
  kata_cue_text(&k, buf, size);
  return buf;
}

const char* part_name(int part) {
  const char* name = kata_body_part_name(part);
  return name ? name : "?";
}

double LessonData::mean_score() const {
  double sum = 0.0;
  int n = 0;
  for (size_t i = 0; i < static_cast<size_t>(pushed) && i < frames.size(); ++i)
    if (scored(frames[i])) sum += frames[i].score, ++n;
  return n ? sum / n : 0.0;
}

namespace {

FrameState frame_state(int32_t score_state) {
  switch (score_state) {
    case KATA_SCORE_SCORING: return FrameState::kTracking;
    case KATA_SCORE_CALIBRATING: return FrameState::kCalibrating;
    case KATA_SCORE_TRACKING_LOST: return FrameState::kTrackingLost;
    case KATA_SCORE_TEACHER_FINISHED: return FrameState::kTeacherFinished;
    default: return FrameState::kTrackingLost;
  }
}

// Every frame of a clip from `first` on: frames x joints x 3 floats.
std::vector<float> clip_positions(kata_clip clip, uint32_t joints, int first) {
  const size_t per_frame = 3 * static_cast<size_t>(joints);
  const int frames = static_cast<int>(kata_clip_frame_count(clip));
  std::vector<float> out(static_cast<size_t>(std::max(frames - first, 0)) * per_frame);
  for (int f = first; f < frames; ++f)
    if (kata_clip_positions(clip, static_cast<uint32_t>(f), out.data() + static_cast<size_t>(f - first) * per_frame,
                            per_frame) != KATA_OK)
      fail("frame " + std::to_string(f) + " of a clip: its joint positions could not be computed");
  return out;
}

}  // namespace

Lesson::Lesson(const LessonSettings& settings) {
  data_.settings = settings;
  try {
    if (kata_context_create(&context_) != KATA_OK) fail("cannot create a kata context");
    auto check = [&](kata_status status) {
      if (status != KATA_OK) fail(kata_context_last_error(context_));
    };
    check(kata_model_load(context_, settings.model.c_str(), &model_));
    tools::LoadProgress progress(settings.teacher);  // a line on stderr if loading takes > 1 s
    check(kata_clip_load_bvh(context_, settings.teacher.c_str(), &teacher_clip_));
    check(kata_clip_load_bvh(context_, settings.student.c_str(), &student_clip_));
    const int teacher_count = static_cast<int>(kata_clip_frame_count(teacher_clip_));
    const int student_count = static_cast<int>(kata_clip_frame_count(student_clip_));
    if (settings.first_frame < 0 || settings.first_frame >= teacher_count || settings.first_frame >= student_count)
      fail("--first-frame " + std::to_string(settings.first_frame) + " is past the end of a clip");
    if (!(settings.speed > 0.0)) fail("--speed must be > 0");
    check(kata_clip_skeleton(teacher_clip_, &teacher_skeleton_));
    check(kata_clip_skeleton(student_clip_, &student_skeleton_));

    // Both streams read their clip through the lesson's layout, with the model's stencil.
    kata_stream_desc sd;
    kata_stream_desc_init(&sd);
    sd.layout = settings.preset.c_str();
    sd.stencil = kata_model_stencil(model_);
    check(kata_stream_open(context_, teacher_skeleton_, &sd, &teacher_stream_));
    sd.result_capacity = 64;
    check(kata_stream_open(context_, student_skeleton_, &sd, &student_stream_));

    // The student's teacher: the whole clip from first_frame (positions for the ghost on the
    // student's bones, features for the score), attached here so the ghost's joints are known
    // before the first result.
    kata_teacher_desc td;
    kata_teacher_desc_init(&td);
    td.model = model_;
    td.clip = teacher_clip_;
    td.layout = settings.preset.c_str();
    td.first_frame = static_cast<uint32_t>(settings.first_frame);
    td.alignment_window = settings.window;
    if (!settings.tolerance.empty()) td.tolerance = settings.tolerance.c_str();
    td.on_progress = [](void* user, uint32_t done, uint32_t frames) {
      (*static_cast<tools::LoadProgress*>(user))(static_cast<int>(done), static_cast<int>(frames));
    };
    td.on_progress_user = &progress;
    if (kata_stream_attach_teacher(student_stream_, &td) != KATA_OK) fail(kata_stream_last_error(student_stream_));
    // Practice modes: clip frames to teacher frames (counted from first_frame); the stream refuses
    // a section outside the clip, naming it.
    int32_t section_first = -1, section_last = -1, loop = 0;
    if (settings.teacher_start >= 0) section_first = settings.teacher_start - settings.first_frame;
    if (settings.loop_first >= 0) {
      section_first = settings.loop_first - settings.first_frame;
      section_last = settings.loop_last - settings.first_frame;
      loop = 1;
    }
    if (settings.reps) {
      // The repetition: the whole teacher (from first_frame) or its seconds rep_start..rep_end
      // (clip time: the clip frames in [start, end)), looped.
      if (section_first != -1) fail("--reps / --rep-section set the section themselves: not with --loop or --teacher-start");
      section_first = 0, section_last = -1, loop = 1;
      if (settings.rep_start >= 0.0) {
        const double ft = kata_clip_frame_time(teacher_clip_);
        const int fa = static_cast<int>(std::ceil(settings.rep_start / ft - 1e-6));
        const int fb = static_cast<int>(std::ceil(settings.rep_end / ft - 1e-6)) - 1;
        if (!(settings.rep_end > settings.rep_start) || fb < fa || fa < settings.first_frame ||
            fb >= static_cast<int>(teacher_count))
          fail("--rep-section " + std::to_string(settings.rep_start) + " " + std::to_string(settings.rep_end) +
               " is not a section of " + settings.teacher + " (seconds A < B within its " +
               std::to_string(settings.first_frame * ft) + ".." + std::to_string(teacher_count * ft) + " s)");
        section_first = fa - settings.first_frame;
        section_last = fb - settings.first_frame;
      }
    }
    if (section_first != -1 &&
        kata_stream_set_practice_section(student_stream_, section_first, section_last, loop) != KATA_OK)
      fail(kata_stream_last_error(student_stream_));

    teacher_joints_ = static_cast<int>(kata_skeleton_joint_count(teacher_skeleton_));
    teacher_frame_time_ = kata_clip_frame_time(teacher_clip_);
    teacher_positions_ = clip_positions(teacher_clip_, static_cast<uint32_t>(teacher_joints_), settings.first_frame);
    data_.joints = static_cast<int>(kata_skeleton_joint_count(student_skeleton_));
    clip_positions_ = clip_positions(student_clip_, static_cast<uint32_t>(data_.joints), settings.first_frame);
    for (int j = 0; j < data_.joints; ++j) {
      data_.joint_names.emplace_back(kata_skeleton_joint_name(student_skeleton_, static_cast<uint32_t>(j)));
      data_.joint_parents.push_back(kata_skeleton_joint_parent(student_skeleton_, static_cast<uint32_t>(j)));
    }
    // Each student joint's body part: its own GPD joint's, or its nearest GPD ancestor's (fingers
    // go with the hand).
    data_.joint_part.assign(static_cast<size_t>(data_.joints), KATA_PART_TORSO_HEAD);
    data_.left_hip = kata_stream_gpd_joint_source(student_stream_, 10);
    data_.right_hip = kata_stream_gpd_joint_source(student_stream_, 13);
    std::vector<int> own_part(static_cast<size_t>(data_.joints), -1);
    for (int g = 0; g < KATA_GPD_JOINTS; ++g) {
      const int32_t source = kata_stream_gpd_joint_source(student_stream_, static_cast<uint32_t>(g));
      if (source >= 0) own_part[static_cast<size_t>(source)] = kata_gpd_joint_part(g);
    }
    for (int j = 0; j < data_.joints; ++j) {  // parents come first, so a parent's part is final
      const int parent = data_.joint_parents[static_cast<size_t>(j)];
      data_.joint_part[static_cast<size_t>(j)] = own_part[static_cast<size_t>(j)] >= 0 ? own_part[static_cast<size_t>(j)]
                                                 : parent >= 0 ? data_.joint_part[static_cast<size_t>(parent)]
                                                               : static_cast<int>(KATA_PART_TORSO_HEAD);
    }
    data_.ghost_joints = static_cast<int>(kata_stream_ghost_joint_count(student_stream_));
    for (int g = 0; g < data_.ghost_joints; ++g)
      data_.ghost_sources.push_back(kata_stream_ghost_joint_source(student_stream_, static_cast<uint32_t>(g)));
    data_.teacher_frames = teacher_count - settings.first_frame;
    data_.student_frames = student_count - settings.first_frame;
    data_.frame_time = kata_clip_frame_time(student_clip_);
    data_.delta_star = kata_model_delta_star(model_);
    kata_score_calibration calibration;
    std::memset(&calibration, 0, sizeof calibration);
    calibration.struct_size = sizeof calibration;
    check(kata_model_calibration(model_, &calibration));
    data_.d50 = calibration.d50;
    data_.good_score = calibration.good_score;
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
    kata_runtime_desc rd;
    kata_runtime_desc_init(&rd);
    rd.workers = 1;
    rd.max_streams = 2;
    rd.max_joints = static_cast<uint32_t>(std::max(data_.joints, teacher_joints_));
    rd.queue_capacity = 1024;
    rd.publish_endpoints = settings.publish.c_str();
    rd.on_result = &Lesson::on_result;
    // Repetitions only for a lesson that counts them (--reps): the end of any lesson closes the
    // repetition in progress, which on a dance would be one partial "repetition" of nothing.
    rd.on_repetition = settings.reps ? &Lesson::on_repetition : nullptr;
    rd.on_result_user = this;
    repetitions_.resize(kMaxRepetitions);
    check(kata_runtime_create(context_, &rd, &runtime_));
    check(kata_runtime_add_stream(runtime_, kTeacherStream, &teacher_stream_, settings.preset.c_str(), 0));
    check(kata_runtime_add_stream(runtime_, kStudentStream, &student_stream_, settings.preset.c_str(), 0));
  } catch (...) {
    release();
    throw;
  }
}

void Lesson::release() {
  kata_runtime_destroy(runtime_);  // stops first: the callback writes into data_
  runtime_ = nullptr;
  kata_stream_destroy(teacher_stream_);
  kata_stream_destroy(student_stream_);
  kata_skeleton_destroy(teacher_skeleton_);
  kata_skeleton_destroy(student_skeleton_);
  kata_clip_destroy(teacher_clip_);
  kata_clip_destroy(student_clip_);
  kata_model_destroy(model_);
  kata_context_destroy(context_);
  teacher_stream_ = student_stream_ = nullptr;
  teacher_skeleton_ = student_skeleton_ = nullptr;
  teacher_clip_ = student_clip_ = nullptr;
  model_ = nullptr;
  context_ = nullptr;
}

Lesson::~Lesson() { release(); }

kata_runtime_counters Lesson::counters() const {
  kata_runtime_counters c;
  std::memset(&c, 0, sizeof c);
  c.struct_size = sizeof c;
  kata_runtime_get_counters(runtime_, &c);
  return c;
}

void Lesson::on_result(void* self, const kata_result_record* f) {
  Lesson& l = *static_cast<Lesson*>(self);
  if (f->stream_id == kTeacherStream) {
    l.teacher_results_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  LessonData& data = l.data_;
  if (f->stream_id != kStudentStream || f->frame_sequence >= static_cast<uint64_t>(data.student_frames)) return;
  const size_t i = static_cast<size_t>(f->frame_sequence);
  FrameRecord& r = data.frames[i];
  r.state = f->scored ? frame_state(f->state) : FrameState::kCalibrating;
  r.score = f->score;
  r.distance = f->distance;
  std::copy(std::begin(f->parts), std::end(f->parts), r.parts);
  std::copy(std::begin(f->part_scores), std::end(f->part_scores), r.part_scores);
  r.matched = f->matched_teacher_frame;
  r.matched_time = f->matched_teacher_time;
  r.part_to_fix = f->part_to_fix;
  r.cue_joint = f->cue_joint, r.cue_degrees = f->cue_degrees, r.cue_action = f->cue_action;
  if (KATA_RESULT_HAS(f, repetition_progress)) r.repetition = f->repetition, r.repetition_progress = f->repetition_progress;
  r.latency_ns = f->published_ns > 0 ? f->published_ns - f->arrival_ns : f->computed_ns - f->arrival_ns;
  r.has_ghost = f->ghost != nullptr && static_cast<int>(f->ghost_joint_count) == data.ghost_joints;
  if (r.has_ghost)
    std::memcpy(data.ghosts.data() + i * 3 * static_cast<size_t>(data.ghost_joints), f->ghost,
                sizeof(float) * 3 * static_cast<size_t>(data.ghost_joints));
  l.ready_[i].store(1, std::memory_order_release);
  l.newest_ready_.store(static_cast<int64_t>(i), std::memory_order_release);
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
    kata_runtime_push(runtime_, kTeacherStream, static_cast<uint64_t>(teacher_pushed_), teacher_pushed_ * teacher_frame_time_,
                      teacher_positions_.data() + static_cast<size_t>(teacher_pushed_) * teacher_floats,
                      static_cast<uint32_t>(teacher_joints_));
  if (kata_runtime_push(runtime_, kStudentStream, static_cast<uint64_t>(i), t, xyz, static_cast<uint32_t>(data_.joints)) !=
      KATA_OK) {
    data_.frames[static_cast<size_t>(i)].state = FrameState::kTrackingLost;
    ready_[static_cast<size_t>(i)].store(1, std::memory_order_release);
  }
}

void Lesson::on_repetition(void* self, const kata_repetition* r) {
  Lesson& l = *static_cast<Lesson*>(self);
  if (r->stream_id != kStudentStream) return;
  const size_t n = l.repetitions_count_.load(std::memory_order_relaxed);
  if (n >= l.repetitions_.size()) return;  // bounded: the first kMaxRepetitions
  l.repetitions_[n] = *r;
  l.repetitions_count_.store(n + 1, std::memory_order_release);
}

void Lesson::finish() {
  if (finished_) return;
  finished_ = true;
  kata_runtime_stop(runtime_);  // every queued frame computed, every result sent and recorded
  data_.repetitions.assign(repetitions_.begin(), repetitions_.begin() + static_cast<std::ptrdiff_t>(repetitions_ended()));
  // A pushed frame the stream accepted but never answered (none expected): shown as lost.
  for (int i = 0; i < data_.pushed; ++i)
    if (!ready(static_cast<size_t>(i))) {
      data_.frames[static_cast<size_t>(i)].state = FrameState::kTrackingLost;
      ready_[static_cast<size_t>(i)].store(1, std::memory_order_release);
    }
}

}  // namespace kata::coach
