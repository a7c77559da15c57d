#include <cmath>
#include "pipeline/pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>

#include "common/error.hpp"
#include "metric/smoothed_rematch.hpp"

namespace kata::pipeline {

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::shared_ptr<const Teacher> Teacher::from_positions(std::shared_ptr<const metric::Metric> metric,
                                                       const Skeleton& skeleton, const StreamConfig& stream_config,
                                                       const float* positions, int frames, double frame_time,
                                                       int pose_frame, const LoadProgress& progress) {
  if (!metric) throw Error(ErrorKind::kInvalidArgument, "teacher: no model");
  if (frames < 1 || !positions) throw Error(ErrorKind::kInvalidArgument, "teacher: no frames");
  if (stream_config.input_joints != skeleton.joint_count())
    throw Error(ErrorKind::kInvalidArgument, "teacher: the stream config's joint count differs from the skeleton's");
  if (stream_config.stencil != metric->stencil())
    throw Error(ErrorKind::kInvalidArgument, "teacher: the features' stencil differs from the model's");
  if (pose_frame < -1 || pose_frame >= frames)
    throw Error(ErrorKind::kInvalidArgument, "teacher: pose frame " + std::to_string(pose_frame) +
                                                 " is outside -1.." + std::to_string(frames - 1));
  auto teacher = std::make_shared<Teacher>();
  teacher->skeleton = skeleton;
  const size_t per_frame = 3 * static_cast<size_t>(skeleton.joint_count());
  const FramePositions frame = [&](int i, float* xyz) {
    const float* p = positions + static_cast<size_t>(i) * per_frame;
    std::copy(p, p + per_frame, xyz);
  };
  if (pose_frame >= 0) {
    const std::vector<float> features = features_of_frames(stream_config, positions, frames, frame_time);
    teacher->reference = std::make_shared<const metric::Reference>(
        metric, features.data() + static_cast<size_t>(pose_frame) * gpd::kDims);
    const float* p = positions + static_cast<size_t>(pose_frame) * per_frame;
    teacher->positions.assign(p, p + per_frame);
  } else {
    // The features are projected chunk by chunk as the stream makes them and let go (an
    // 11-minute teacher's would be 550 MB); the Reference is the one-shot constructor's, bit for bit.
    constexpr int kChunkFrames = 1024;
    int done = 0;
    teacher->reference = std::make_shared<const metric::Reference>(
        metric,
        [&](const std::function<void(const float*, int)>& sink) {
          features_in_chunks(stream_config, frame, frames, frame_time, kChunkFrames, [&](const float* f, int n) {
            sink(f, n);
            done += n;
            if (progress) progress(done, frames);
          });
        },
        frames, frame_time);
    teacher->positions.assign(positions, positions + static_cast<size_t>(frames) * per_frame);
  }
  return teacher;
}

std::shared_ptr<const Teacher> Teacher::from_reference(std::shared_ptr<const metric::Reference> reference) {
  if (!reference) throw Error(ErrorKind::kInvalidArgument, "teacher: no reference");
  auto teacher = std::make_shared<Teacher>();
  teacher->reference = std::move(reference);
  return teacher;
}

Pipeline::Pipeline(const PipelineConfig& config) : config_(config), stream_(config.stream) {
  if (config_.result_capacity < 1 || config_.result_capacity > (1 << 20))
    throw Error(ErrorKind::kInvalidArgument, "pipeline: result capacity must be in 1..2^20");
  if (config_.student.joint_count() != config_.stream.input_joints)
    throw Error(ErrorKind::kInvalidArgument, "pipeline: the student skeleton's joint count differs from the stream's");
  history_ = config_.stream.history;
  capacity_ = config_.result_capacity;
  const size_t input_floats = 3 * static_cast<size_t>(config_.stream.input_joints);
  student_ring_.assign(static_cast<size_t>(history_) * input_floats, 0.0f);
  results_.assign(static_cast<size_t>(capacity_), Result{});
  // No joint set has more joints than the student; the ghost across layouts has the 16 GPD joints
  // whatever the student's count.
  ghost_stride_ = static_cast<int>(std::max(input_floats, static_cast<size_t>(3 * kGpdJoints)));
  ghost_ring_.assign(static_cast<size_t>(capacity_) * static_cast<size_t>(ghost_stride_), 0.0f);
  if (config_.keep_features) feature_ring_.assign(static_cast<size_t>(capacity_) * gpd::kDims, 0.0f);
}

void Pipeline::set_teacher(std::shared_ptr<const Teacher> teacher, const TeacherOptions& options) {
  if (!teacher || !teacher->reference) throw Error(ErrorKind::kInvalidArgument, "pipeline: no teacher");
  if (teacher->reference->metric().stencil() != config_.stream.stencil)
    throw Error(ErrorKind::kInvalidArgument,
                "pipeline: the stream's stencil differs from the one the model was trained with; open the stream "
                "with the model's stencil");
  // Build everything first, then swap in: a refused teacher leaves the old one in place.
  // A smoothed student (One-Euro: a landmark layout's default, a webcam's) is re-matched within
  // kSmoothedRematchTime (metric/smoothed_rematch.hpp has why), if re-matched at all. Decided when
  // the teacher is attached.
  metric::AlignmentOptions alignment = options.alignment;
  if (config_.stream.smoothing && alignment.rematch_time > 0.0)
    alignment.rematch_time = std::max(alignment.rematch_time, metric::kSmoothedRematchTime);
  auto scorer = std::make_unique<metric::Scorer>(teacher->reference, alignment);
  scorer->set_tolerance(options.tolerance);
  std::unique_ptr<metric::RepCounter> reps;
  if (teacher->reference->kind() == metric::ReferenceKind::kClip)
    reps = std::make_unique<metric::RepCounter>(teacher->reference);
  std::unique_ptr<retarget::Retargeter> retargeter;
  retarget::JointSelection selection;
  const bool across = options.ghost && options.ghost_across && teacher->has_positions();
  if (across) {
    if (options.ghost_teacher.joints != teacher->joint_count())
      throw Error(ErrorKind::kInvalidArgument, "pipeline: the ghost's teacher side has " +
                                                   std::to_string(options.ghost_teacher.joints) + " joints, the teacher " +
                                                   std::to_string(teacher->joint_count()));
    // The ghost's joints are the 16 GPD joints; each stands for the student joint its layout maps
    // there (-1: a joint the layout synthesises).
    selection.preset = "gpd";
    for (int g = 0; g < kGpdJoints; ++g) {
      selection.names.emplace_back(kGpdJointNames[static_cast<size_t>(g)]);
      selection.parents.push_back(kGpdParents[static_cast<size_t>(g)]);
      selection.source.push_back(config_.stream.map.source[static_cast<size_t>(g)]);
    }
  } else if (options.ghost && teacher->has_positions() && config_.student.has_rest_pose) {
    selection = retarget::select_joints(teacher->skeleton, config_.student, options.ghost_joints);
    retargeter = std::make_unique<retarget::Retargeter>(
        selection.parents, retarget::selected_rest_lengths(config_.student, selection), options.retarget,
        retarget::selected_rest_directions(config_.student, selection));
  }
  const size_t n = selection.source.size();
  teacher_pose_.assign(3 * n, 0.0);
  ghost_pose_.assign(3 * n, 0.0);
  student_pose_.assign(3 * n, 0.0);
  teacher_ = std::move(teacher);
  scorer_ = std::move(scorer);
  reps_ = std::move(reps);
  flush_ended_repetition_ = false;
  retargeter_ = std::move(retargeter);
  selection_ = std::move(selection);
  ghost_joints_ = static_cast<int>(n);
  across_ = across;
  across_teacher_ = options.ghost_teacher;
  across_options_ = options.retarget;
  mapped_.reset();
  if (across_ && config_.student.has_rest_pose) make_mapped();
}

bool Pipeline::make_mapped() {
  if (mapped_) return true;
  std::array<double, kGpdJoints> lengths{};
  if (config_.student.has_rest_pose)
    lengths = retarget::gpd_rest_lengths(config_.student, config_.stream.map);
  else if (!stream_.bone_lengths(lengths.data(), nullptr))
    return false;
  for (int g = 1; g < kGpdJoints; ++g)
    if (!(lengths[static_cast<size_t>(g)] > 0.0)) return false;  // a degenerate estimate: no ghost yet
  const retarget::MappedSide student{config_.stream.map, config_.stream.up_axis, config_.stream.input_joints};
  mapped_ = std::make_unique<retarget::MappedRetargeter>(across_teacher_, student, lengths, across_options_);
  return true;
}

void Pipeline::clear_teacher() {
  teacher_.reset();
  scorer_.reset();
  reps_.reset();
  flush_ended_repetition_ = false;
  retargeter_.reset();
  mapped_.reset();
  across_ = false;
  selection_ = {};
  ghost_joints_ = 0;
}

void Pipeline::restart_teacher() {
  // The repetition in progress ends before the count restarts (its frames are in the counter's
  // running figures; a reset would drop them unreported).
  const Result* last = newest();
  flush_ended_repetition_ = reps_ && reps_->finish(last ? last->capture_time : 0.0) > 0;
  if (scorer_) scorer_->reset();
  if (reps_) reps_->reset();
  if (retargeter_) retargeter_->reset();
  if (mapped_) mapped_->reset();
}

Status Pipeline::push(double capture_time, const float* xyz, const float* confidence, int joint_count,
                      int64_t arrival_ns, Scratch* scratch) {
  if (arrival_ns == 0) arrival_ns = now_ns();
  int64_t before = 0;
  const Status s = push_features(capture_time, xyz, confidence, joint_count, &before);
  // kInternal: the frame was accepted but a non-finite vector was withheld (a bug, reported);
  // kTrackingLost: the frame ended the segment (which may emit its held vector). Either way
  // the vectors emitted with it are still processed.
  if (s != Status::kOk && s != Status::kInternal && s != Status::kTrackingLost) return s;
  scratch_ = scratch;
  process_emitted(before, arrival_ns);
  scratch_ = nullptr;
  return s;
}

metric::Scorer::Workspace* Pipeline::score_workspace(int k) {
  if (!scratch_) return nullptr;
  metric::Scorer::Workspace& ws = scratch_->score_[k];
  ws.fit(scorer_->reference().metric());  // no allocation once it has served this model's shape
  return &ws;
}

retarget::Retargeter::Workspace* Pipeline::ghost_workspace() {
  if (!scratch_) return nullptr;
  scratch_->ghost_.fit(retargeter_->joint_count());
  return &scratch_->ghost_;
}

Status Pipeline::push_features(double capture_time, const float* xyz, const float* confidence, int joint_count,
                               int64_t* before) {
  const int64_t frame = stream_.accepted_count();
  *before = stream_.emitted_count();
  const Status s = stream_.push(capture_time, xyz, confidence, joint_count);
  if (s != Status::kOk && s != Status::kInternal && s != Status::kTrackingLost) return s;
  if (stream_.accepted_count() == frame) return s;  // tracking lost: no frame to keep for the ghost
  const size_t input_floats = 3 * static_cast<size_t>(joint_count);
  float* slot = student_ring_.data() + static_cast<size_t>(frame % history_) * input_floats;
  std::memcpy(slot, xyz, input_floats * sizeof(float));
  if (confidence) {
    const float* previous = student_ring_.data() + static_cast<size_t>((frame + history_ - 1) % history_) * input_floats;
    for (size_t i = 0; i < input_floats; ++i)
      if (!std::isfinite(slot[i])) slot[i] = std::isfinite(previous[i]) ? previous[i] : 0.0f;
  }
  return s;
}

void Pipeline::push_burst(BurstFrame* frames, int n, Scratch* scratch) {
  // Frames scored together: the pipeline and the time of its one emitted vector.
  int scored[kMaxBurst];
  double times[kMaxBurst];
  bool done[kMaxBurst];
  int m = 0;
  if (n > kMaxBurst) {  // in bursts of kMaxBurst
    for (int f0 = 0; f0 < n; f0 += kMaxBurst) push_burst(frames + f0, std::min(kMaxBurst, n - f0), scratch);
    return;
  }
  // Stage 1: every frame's features (and push()'s path for a frame the batch does not take).
  for (int f = 0; f < n; ++f) {
    BurstFrame& b = frames[f];
    Pipeline& p = *b.pipeline;
    if (b.arrival_ns == 0) b.arrival_ns = now_ns();
    int64_t before = 0;
    b.status = p.push_features(b.capture_time, b.xyz, b.confidence, b.joint_count, &before);
    if (b.status != Status::kOk && b.status != Status::kInternal && b.status != Status::kTrackingLost) continue;
    const int64_t frame = p.stream_.feature_frame();
    if (p.scorer_ && p.stream_.emitted_count() - before == 1 &&
        !metric::tracking_lost(p.stream_.joints_of(frame))) {
      times[m] = p.stream_.time_of(frame);
      scored[m++] = f;
      p.scratch_ = scratch;  // until its frame is done (stage 3)
    } else {
      p.scratch_ = scratch;
      p.process_emitted(before, b.arrival_ns);
      p.scratch_ = nullptr;
    }
  }
  // Stage 2: the scores, the frames of one model together (W read once per group of kBatch).
  metric::Scorer* scorers[kMaxBurst];
  const float* xs[kMaxBurst];
  double ts[kMaxBurst];
  std::fill(done, done + m, false);
  for (int i = 0; i < m; ++i) {
    if (done[i]) continue;
    const metric::Metric* model = &frames[scored[i]].pipeline->scorer_->reference().metric();
    int k = 0;
    for (int j = i; j < m; ++j) {
      Pipeline& p = *frames[scored[j]].pipeline;
      if (done[j] || &p.scorer_->reference().metric() != model) continue;
      scorers[k] = p.scorer_.get();
      xs[k] = p.stream_.vector_of(p.stream_.feature_frame());
      ts[k] = times[j];
      ++k;
      done[j] = true;
    }
    if (scratch) {
      // The scratch's kBatch workspaces serve each group of kBatch frames in turn.
      metric::Scorer::Workspace* ws[metric::detail::kBatch];
      for (int w = 0; w < std::min(k, metric::detail::kBatch); ++w) ws[w] = frames[scored[i]].pipeline->score_workspace(w);
      metric::Scorer::score_batch(scorers, xs, ts, k, ws);
    } else {
      metric::Scorer::score_batch(scorers, xs, ts, k);
    }
  }
  // Stage 3: repetitions, ghosts and results.
  for (int i = 0; i < m; ++i) {
    BurstFrame& b = frames[scored[i]];
    b.pipeline->produce(b.pipeline->stream_.feature_frame(), b.arrival_ns, true);
    b.pipeline->scratch_ = nullptr;
  }
}

Status Pipeline::flush() {
  const int64_t before = stream_.emitted_count();
  const Status s = stream_.flush();
  process_emitted(before, now_ns());
  const Result* last = newest();
  flush_ended_repetition_ = reps_ && reps_->finish(last ? last->capture_time : 0.0) > 0;
  return s;
}

void Pipeline::reset() {
  const int64_t before = stream_.emitted_count();
  stream_.reset();
  process_emitted(before, now_ns());
}

void Pipeline::process_emitted(int64_t before, int64_t arrival_ns) {
  const int64_t count = stream_.emitted_count() - before;
  if (count <= 0) return;
  // Emitted vectors are consecutive frames ending at the newest one.
  const int64_t last = stream_.feature_frame();
  for (int64_t f = last - count + 1; f <= last; ++f) produce(f, arrival_ns);
}

void Pipeline::produce(int64_t frame, int64_t arrival_ns, bool prescored) {
  if (written_ - read_ == static_cast<uint64_t>(capacity_)) {  // full: the oldest unread result goes
    ++read_;
    ++dropped_;
  }
  const uint64_t seq = written_;
  const size_t k = slot(seq);
  Result& r = results_[k];
  r = Result{};
  r.sequence = seq;
  r.frame_index = frame;
  r.capture_time = stream_.time_of(frame);
  r.arrival_ns = arrival_ns;
  const float* x = stream_.vector_of(frame);
  if (config_.keep_features) std::memcpy(feature_ring_.data() + k * gpd::kDims, x, gpd::kDims * sizeof(float));
  float* ghost = ghost_ring_.data() + k * static_cast<size_t>(ghost_stride_);
  if (scorer_) {
    r.score = prescored ? scorer_->last() : score_frame(frame, r.capture_time);
    r.scored = true;
    r.matched_frame = r.score.matched;
    if (reps_) {
      r.repetition_ended = reps_->update(r.score, x, scorer_->aligner()) > 0;
      r.repetition = reps_->current_index();
      r.repetition_progress = reps_->progress();
    }
    if (retargeter_) {
      const float* t = teacher_->frame_positions(r.matched_frame);
      const float* s = student_ring_.data() + static_cast<size_t>(frame % history_) * 3 *
                                                  static_cast<size_t>(config_.stream.input_joints);
      for (int j = 0; j < ghost_joints_; ++j) {
        const size_t src = 3 * static_cast<size_t>(selection_.source[static_cast<size_t>(j)]);
        for (int c = 0; c < 3; ++c) {
          teacher_pose_[3 * static_cast<size_t>(j) + c] = t[src + c];
          student_pose_[3 * static_cast<size_t>(j) + c] = s[src + c];
        }
      }
      if (retarget::Retargeter::Workspace* ws = ghost_workspace())
        retargeter_->retarget(teacher_pose_.data(), ghost_pose_.data(), *ws);
      else
        retargeter_->retarget(teacher_pose_.data(), ghost_pose_.data());
      retarget::place_over_student(ghost_joints_, student_pose_.data(), ghost_pose_.data());
      for (int i = 0; i < 3 * ghost_joints_; ++i) ghost[i] = static_cast<float>(ghost_pose_[static_cast<size_t>(i)]);
      r.has_ghost = true;
    } else if (across_ && make_mapped()) {
      const float* s = student_ring_.data() + static_cast<size_t>(frame % history_) * 3 *
                                                  static_cast<size_t>(config_.stream.input_joints);
      mapped_->retarget(teacher_->frame_positions(r.matched_frame), ghost);
      mapped_->place(s, ghost);
      r.has_ghost = true;
    }
  }
  r.computed_ns = now_ns();
  written_ = seq + 1;
}

size_t Pipeline::read(Result* out, float* ghosts, float* features, size_t capacity) {
  size_t n = 0;
  const size_t g = 3 * static_cast<size_t>(ghost_joints_);
  for (; n < capacity && read_ < written_; ++n, ++read_) {
    const size_t k = slot(read_);
    out[n] = results_[k];
    if (ghosts) {
      if (results_[k].has_ghost)
        std::memcpy(ghosts + n * g, ghost_ring_.data() + k * static_cast<size_t>(ghost_stride_), g * sizeof(float));
      else
        std::fill(ghosts + n * g, ghosts + (n + 1) * g, 0.0f);
    }
    if (features && config_.keep_features)
      std::memcpy(features + n * gpd::kDims, feature_ring_.data() + k * gpd::kDims, gpd::kDims * sizeof(float));
  }
  return n;
}

const metric::ScoreRecord& Pipeline::score_frame(int64_t frame, double t) {
  if (metric::tracking_lost(stream_.joints_of(frame))) return scorer_->score_lost(t);
  if (metric::Scorer::Workspace* ws = score_workspace(0)) return scorer_->score(stream_.vector_of(frame), t, *ws);
  return scorer_->score(stream_.vector_of(frame), t);
}

const Result* Pipeline::newest() const { return written_ ? &results_[slot(written_ - 1)] : nullptr; }

const float* Pipeline::newest_ghost() const {
  return written_ ? ghost_ring_.data() + slot(written_ - 1) * static_cast<size_t>(ghost_stride_) : nullptr;
}

const float* Pipeline::newest_features() const {
  return written_ && config_.keep_features ? feature_ring_.data() + slot(written_ - 1) * gpd::kDims : nullptr;
}

}  // namespace kata::pipeline
