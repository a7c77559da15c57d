// C shims for the per-stream pipeline (kata.h section "Pipeline"): attaching a teacher in one call
// and draining results. The composition is kata::pipeline::Pipeline's; these only translate.
#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "io/clip_features.hpp"

using kata::capi::guarded_stream;
using kata::capi::refuse;

namespace {

// The caller's desc over the defaults (capi/struct_size.hpp: from 1.0's size up).
kata_teacher_desc effective_teacher_desc(const kata_teacher_desc* desc, const char* call) {
  kata_teacher_desc defaults, d;
  kata_teacher_desc_init(&defaults);
  if (!kata::capi::read_sized(desc, defaults, kata::capi::kTeacherDesc10, &d))
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      std::string(call) + ": desc->struct_size is below 1.0's kata_teacher_desc "
                      "(call kata_teacher_desc_init)");
  return d;
}

[[noreturn]] void invalid(const char* call, const std::string& what) {
  throw kata::Error(kata::ErrorKind::kInvalidArgument, std::string(call) + ": " + what);
}

// pose_frame (clip-relative, >= first_frame or -1) as an index into the teacher's frames from
// first_frame on.
int pose_index(const kata_teacher_desc& d, int frames, const char* call) {
  if (d.pose_frame >= 0) {
    if (static_cast<uint32_t>(d.pose_frame) < d.first_frame || d.pose_frame - static_cast<int>(d.first_frame) >= frames)
      invalid(call, "pose_frame must be -1 or a teacher frame >= first_frame");
    return d.pose_frame - static_cast<int>(d.first_frame);
  }
  if (d.pose_frame != -1)
    invalid(call, "pose_frame " + std::to_string(d.pose_frame) + " is below -1 (-1: the whole clip)");
  return -1;
}

// A teacher known by its features or its 16 GPD joints: scores only.
std::shared_ptr<const kata::pipeline::Teacher> make_feature_teacher(const kata_teacher_desc& d, const char* call) {
  const std::shared_ptr<const kata::metric::Metric>& metric = d.model->metric;
  std::shared_ptr<const kata::metric::Reference> ref;
  if (d.joints) {
    if (d.frames > 1 || d.first_frame != 0 || d.pose_frame > 0)
      invalid(call, "joints is one held pose: frames must be 1 (or 0) (a moving teacher of 16 GPD joints: positions "
                    "on the \"gpd\" layout's skeleton)");
    ref = std::make_shared<const kata::metric::Reference>(
        kata::metric::Reference::from_joints(metric, d.joints, d.body_height));
  } else {
    if (d.frames == 0 || d.frames > (1u << 24) || d.first_frame >= d.frames)
      invalid(call, "frames must be in 1..2^24 and first_frame below it");
    const int frames = static_cast<int>(d.frames - d.first_frame);
    const float* first = d.features + static_cast<size_t>(d.first_frame) * KATA_GPD_DIMS;
    const int pose = pose_index(d, frames, call);
    if (pose >= 0 || frames == 1)
      ref = std::make_shared<const kata::metric::Reference>(metric, first + static_cast<size_t>(std::max(pose, 0)) * KATA_GPD_DIMS);
    else
      ref = std::make_shared<const kata::metric::Reference>(metric, first, frames, d.frame_time);
  }
  return kata::pipeline::Teacher::from_reference(std::move(ref));
}

// The teacher's joint positions and skeleton from the desc (a clip, or frames given in memory).
// ghost_side, when not null, receives how the teacher's frames are read for a ghost across layouts
// (its layout's map, the axes its features are read in, its joint count). student_map, when not
// null, is the map of the stream the teacher is attached to: a student layout that synthesises
// its trunk (a webcam's landmarks) has the teacher's trunk made by the same rule
// (kata::trunk_as_student); the ghost keeps the teacher's own joints.
std::shared_ptr<const kata::pipeline::Teacher> make_teacher(const kata_teacher_desc& d, kata::gpd::Stencil stencil,
                                                            const char* call,
                                                            kata::retarget::MappedSide* ghost_side = nullptr,
                                                            const kata::GpdMap* student_map = nullptr) {
  std::string layout = kata::c_string(d.layout, "kata_teacher_desc.layout");  // bounded read
  if (layout.empty()) layout = "cmu";
  if (d.features || d.joints) return make_feature_teacher(d, call);
  kata::Skeleton skeleton;
  std::vector<float> positions;
  double frame_time = 0.0;
  int frames = 0;
  if (d.clip) {
    const kata::BvhClip& c = d.clip->clip;
    if (d.first_frame >= static_cast<uint32_t>(c.frame_count())) invalid(call, "first_frame is past the clip's end");
    skeleton = c.skeleton;
    positions = kata::clip_positions(c, static_cast<int>(d.first_frame));
    frames = c.frame_count() - static_cast<int>(d.first_frame);
    frame_time = c.frame_time;
  } else {
    if (!d.skeleton || !d.positions)
      invalid(call, "no teacher motion (set clip, skeleton + positions + frames, features + frames, or joints)");
    if (d.frames == 0 || d.frames > (1u << 24) || d.first_frame >= d.frames)
      invalid(call, "frames must be in 1..2^24 and first_frame below it");
    skeleton = d.skeleton->skeleton;
    const size_t per_frame = 3 * static_cast<size_t>(skeleton.joint_count());
    positions.assign(d.positions + d.first_frame * per_frame, d.positions + d.frames * per_frame);
    frames = static_cast<int>(d.frames - d.first_frame);
    frame_time = d.frame_time;
  }
  const int pose = pose_index(d, frames, call);
  // The layout as a stream of it reads its frames: a name map, or one that synthesises joints and
  // fixes its axes and smoothing ("mediapipe": a teacher recorded from a webcam).
  const kata::Layout resolved = kata::resolve_layout(skeleton, layout);
  const kata::GpdMap& map = resolved.map;
  kata::StreamConfig config =
      kata::stream_config_for(skeleton, student_map ? kata::trunk_as_student(map, *student_map) : map, stencil);
  if (resolved.fixed_axes) config.up_axis = resolved.axes;
  config.smoothing = resolved.smooth;
  if (ghost_side) *ghost_side = {map, config.up_axis, skeleton.joint_count()};
  kata::pipeline::Teacher::LoadProgress progress;
  if (d.on_progress) {
    const kata_progress_callback callback = d.on_progress;
    void* const user = d.on_progress_user;
    progress = [callback, user](int done, int total) {
      callback(user, static_cast<uint32_t>(std::max(done, 0)), static_cast<uint32_t>(std::max(total, 0)));
    };
  }
  return kata::pipeline::Teacher::from_positions(d.model->metric, skeleton, config, positions.data(), frames,
                                                 frame_time, pose, progress);
}

// One teacher motion at most: a clip, skeleton + positions, features or joints.
void check_one_motion(const kata_teacher_desc& d, const char* call) {
  const int motions = (d.clip ? 1 : 0) + (d.skeleton || d.positions ? 1 : 0) + (d.features ? 1 : 0) + (d.joints ? 1 : 0);
  if (motions > 1) invalid(call, "give one teacher motion: a clip, skeleton + positions, features or joints, not several");
}

// The per-stream options a desc gives (ghost, ghost_across, retarget, alignment_window, tolerance), checked
// against the teacher's motion (one given as features or joints has no ghost) but not yet against
// the student stream (check_student). Throws kata::Error.
kata::pipeline::TeacherOptions teacher_options(const kata_teacher_desc& d, const char* call) {
  kata::pipeline::TeacherOptions options;
  // The aligner refuses a window out of range, naming it.
  if (!(d.alignment_window > 0.0 && d.alignment_window <= 60.0))
    invalid(call, "alignment_window must be in (0, 60] teacher seconds");
  options.alignment.window = d.alignment_window;
  if (d.tolerance) {
    try {
      options.tolerance = kata::metric::parse_tolerance(d.tolerance);
    } catch (const kata::Error& e) {
      invalid(call, std::string("desc->") + e.what());
    }
  }
  options.ghost = d.ghost != 0;
  options.retarget = kata::capi::retarget_options(d.retarget, &options.ghost_joints);
  check_one_motion(d, call);
  if (options.ghost && (d.features || d.joints))
    invalid(call, "a teacher given as features or GPD joints has no joint positions to make a ghost from "
                  "(set desc->ghost = 0, or give the teacher as a clip or positions)");
  // Across layouts the stream's bone-length estimate stands in for a rest pose (the pipeline
  // makes the ghost once it is ready).
  options.ghost_across = options.ghost && d.ghost_across != 0;
  if (d.ghost_across != 0 && d.ghost_across != 1) invalid(call, "ghost_across must be 0 or 1");
  if (d.ghost_across && !options.ghost) invalid(call, "ghost_across = 1 needs ghost = 1");
  return options;
}

// A ghost on the student's own joints needs the student's bone lengths.
void check_student(kata_stream stream, const kata::pipeline::TeacherOptions& options, const char* call) {
  if (options.ghost && !options.ghost_across && !stream->pipeline.student().has_rest_pose)
    invalid(call, "a ghost needs the student's bone lengths, and the stream's skeleton has no rest offsets "
                  "(set desc->ghost = 0 for scores only, or ghost_across = 1 for the 16 GPD joints from the "
                  "stream's estimate)");
}

}  // namespace

namespace kata::capi {

kata_status attach_teacher(kata_stream stream, const kata_teacher_desc* desc, const char* call) {
  return guarded_stream(stream, [&] {
    const kata_teacher_desc d = effective_teacher_desc(desc, call);
    if (!d.model) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_attach_teacher: desc->model is NULL");
    kata::pipeline::TeacherOptions options = teacher_options(d, call);
    check_student(stream, options, call);
    stream->pipeline.set_teacher(
        make_teacher(d, stream->pipeline.stream().config().stencil, call, &options.ghost_teacher,
                     &stream->pipeline.stream().config().map),
        options);
    return KATA_OK;
  });
}

}  // namespace kata::capi

namespace {
// The defaults kata.h lists for kata_teacher_desc.
kata_teacher_desc teacher_desc_defaults() {
  kata_teacher_desc d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.pose_frame = -1;
  d.ghost = 1;
  d.alignment_window = kata::metric::AlignmentOptions{}.window;
  return d;
}
// What the unsized init writes, for ever: 1.0's struct (programs built before the sized init
// call it by that name). When the struct grows, this stays at 112.
constexpr uint32_t kTeacherDescSize10 = 112;
static_assert(sizeof(kata_teacher_desc) >= kTeacherDescSize10, "the struct only grows");
}  // namespace

extern "C" {

KATA_API void kata_teacher_desc_init_sized(kata_teacher_desc* desc, uint32_t struct_size) {
  kata::capi::init_sized(desc, struct_size, teacher_desc_defaults());
}

// In parentheses: kata.h's macro of the same name is not expanded here.
KATA_API kata_status kata_stream_attach_teacher(kata_stream stream, const kata_teacher_desc* desc) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!desc) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_attach_teacher: desc is NULL");
  return kata::capi::attach_teacher(stream, desc, "kata_stream_attach_teacher");
}

KATA_API kata_status kata_stream_detach_teacher(kata_stream stream) {
  if (!stream) return KATA_E_NULL_POINTER;
  stream->pipeline.clear_teacher();
  return KATA_OK;
}

KATA_API kata_status kata_stream_restart_teacher(kata_stream stream) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!stream->pipeline.has_teacher())
    return refuse(stream, KATA_E_STATE, "kata_stream_restart_teacher: no teacher is attached");
  stream->pipeline.restart_teacher();
  return KATA_OK;
}

KATA_API kata_status kata_stream_read_results(kata_stream stream, kata_result_record* results, float* ghosts, size_t ghost_capacity, float* features,
                                              size_t feature_capacity, uint32_t capacity, uint32_t* count) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!results || !count) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_read_results: results and count must not be NULL");
  *count = 0;
  kata::pipeline::Pipeline& p = stream->pipeline;
  const uint32_t result_size = results->struct_size;
  if (result_size < offsetof(kata_result_record, scored) + sizeof(int32_t))
    return refuse(stream, KATA_E_INVALID_ARGUMENT, "kata_stream_read_results: results[0].struct_size is not set");
  const size_t ghost_floats = 3 * static_cast<size_t>(p.ghost_joint_count());
  if (ghosts && ghost_capacity < capacity * ghost_floats)
    return refuse(stream, KATA_E_BUFFER_TOO_SMALL,
                  "kata_stream_read_results: ghosts holds fewer than capacity x 3 x kata_stream_ghost_joint_count() floats");
  if (features && feature_capacity < capacity * static_cast<size_t>(KATA_GPD_DIMS))
    return refuse(stream, KATA_E_BUFFER_TOO_SMALL,
                  "kata_stream_read_results: features holds fewer than capacity x KATA_GPD_DIMS floats");
  // One result at a time through a stack record, so the caller's strides (struct sizes) apply.
  uint32_t n = 0;
  for (; n < capacity; ++n) {
    kata::pipeline::Result r;
    float* g = ghosts ? ghosts + n * ghost_floats : nullptr;
    float* f = features ? features + static_cast<size_t>(n) * KATA_GPD_DIMS : nullptr;
    if (p.read(&r, g, f, 1) == 0) break;
    kata_result_record k;
    kata::pipeline::fill_record(r, static_cast<uint32_t>(p.ghost_joint_count()), &k);
    kata::pipeline::copy_record_out(k, result_size, reinterpret_cast<unsigned char*>(results) + static_cast<size_t>(n) * result_size);
  }
  *count = n;
  return KATA_OK;
}

KATA_API kata_status kata_stream_read_newest(kata_stream stream, kata_result_record* result, float* ghost, size_t ghost_capacity, float* features,
                                             size_t feature_capacity) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!result) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_read_newest: result must not be NULL");
  kata::pipeline::Pipeline& p = stream->pipeline;
  const uint32_t result_size = result->struct_size;
  if (result_size < offsetof(kata_result_record, scored) + sizeof(int32_t))
    return refuse(stream, KATA_E_INVALID_ARGUMENT, "kata_stream_read_newest: result->struct_size is not set");
  if (ghost && ghost_capacity < 3 * static_cast<size_t>(p.ghost_joint_count()))
    return refuse(stream, KATA_E_BUFFER_TOO_SMALL,
                  "kata_stream_read_newest: ghost holds fewer than 3 x kata_stream_ghost_joint_count() floats");
  if (features && feature_capacity < static_cast<size_t>(KATA_GPD_DIMS))
    return refuse(stream, KATA_E_BUFFER_TOO_SMALL, "kata_stream_read_newest: features holds fewer than KATA_GPD_DIMS floats");
  if (p.pending() == 0) return KATA_NO_DATA;
  kata::pipeline::Result r;
  while (p.pending() > 1) p.read(&r, nullptr, nullptr, 1);  // the older unread results: passed over
  p.read(&r, ghost, features, 1);
  kata_result_record k;
  kata::pipeline::fill_record(r, static_cast<uint32_t>(p.ghost_joint_count()), &k);
  kata::pipeline::copy_record_out(k, result_size, result);
  return KATA_OK;
}

KATA_API kata_status kata_stream_read_repetitions(kata_stream stream, kata_repetition* repetitions, uint32_t capacity,
                                                  uint32_t* count) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!repetitions || !count)
    return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_read_repetitions: repetitions and count must not be NULL");
  *count = 0;
  const uint32_t size = repetitions->struct_size;
  if (size < offsetof(kata_repetition, index) + sizeof(int32_t))
    return refuse(stream, KATA_E_INVALID_ARGUMENT, "kata_stream_read_repetitions: repetitions[0].struct_size is not set");
  const kata::metric::RepCounter* reps = stream->pipeline.repetitions();
  if (!reps) return KATA_OK;
  if (stream->repetitions_of != reps) {
    stream->repetitions_of = reps;
    stream->repetitions_read = 0;
  }
  const int64_t ended = reps->ended();
  // The counter keeps the newest kKept; older unread ones are gone.
  int64_t next = std::max(stream->repetitions_read, ended - kata::metric::RepCounter::kKept);
  uint32_t n = 0;
  for (; n < capacity && next < ended; ++n, ++next) {
    kata_repetition k;
    kata::pipeline::fill_repetition(reps->newest(static_cast<int>(ended - 1 - next)), 0, &k);
    unsigned char* out = reinterpret_cast<unsigned char*>(repetitions) + static_cast<size_t>(n) * size;
    std::memcpy(out, &k, std::min<size_t>(size, sizeof k));
    if (size > sizeof k) std::memset(out + sizeof k, 0, size - sizeof k);
    std::memcpy(out, &size, sizeof size);
  }
  stream->repetitions_read = next;
  *count = n;
  return KATA_OK;
}

KATA_API uint64_t kata_stream_results_dropped(kata_stream stream) { return stream ? stream->pipeline.dropped() : 0u; }

KATA_API uint32_t kata_stream_results_pending(kata_stream stream) {
  return stream ? static_cast<uint32_t>(stream->pipeline.pending()) : 0u;
}

KATA_API uint32_t kata_stream_ghost_joint_count(kata_stream stream) {
  return stream ? static_cast<uint32_t>(stream->pipeline.ghost_joint_count()) : 0u;
}

KATA_API int32_t kata_stream_ghost_joint_source(kata_stream stream, uint32_t i) {
  if (!stream || i >= static_cast<uint32_t>(stream->pipeline.ghost_joint_count())) return -1;
  return stream->pipeline.ghost_sources()[i];
}

KATA_API kata_status kata_teacher_create(kata_context context, const kata_teacher_desc* desc, kata_teacher* out) {
  const kata::capi::ContextScope scope(context);
  if (!context || !desc || !out) {
    kata::capi::set_context_error("kata_teacher_create: context, desc and out must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  *out = nullptr;
  return kata::capi::guarded_context([&] {
    const char* call = "kata_teacher_create";
    const kata_teacher_desc d = effective_teacher_desc(desc, call);
    if (!d.model) {
      kata::capi::set_context_error("kata_teacher_create: desc->model is NULL");
      return KATA_E_NULL_POINTER;
    }
    auto t = std::make_unique<kata_teacher_s>();
    t->options = teacher_options(d, call);
    t->scores_only = d.features || d.joints;
    // Built in the model's stencil: a stream it is attached to must use it anyway.
    t->teacher = make_teacher(d, d.model->metric->stencil(), call, &t->ghost_side);
    t->options.ghost_teacher = t->ghost_side;
    *out = t.release();
    return KATA_OK;
  });
}

KATA_API void kata_teacher_destroy(kata_teacher teacher) { delete teacher; }

KATA_API uint32_t kata_teacher_frame_count(kata_teacher teacher) {
  return teacher ? static_cast<uint32_t>(teacher->teacher->reference->frames()) : 0u;
}

KATA_API double kata_teacher_frame_time(kata_teacher teacher) {
  return teacher ? teacher->teacher->reference->frame_time() : 0.0;
}

KATA_API uint64_t kata_teacher_memory_bytes(kata_teacher teacher) {
  if (!teacher) return 0u;
  const kata::pipeline::Teacher& t = *teacher->teacher;
  return static_cast<uint64_t>(t.reference->memory_bytes() + t.positions.capacity() * sizeof(float));
}

KATA_API kata_status kata_stream_attach_shared_teacher(kata_stream stream, kata_teacher teacher,
                                                       const kata_teacher_desc* options) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!teacher) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_attach_shared_teacher: teacher is NULL");
  return guarded_stream(stream, [&] {
    const char* call = "kata_stream_attach_shared_teacher";
    kata::pipeline::TeacherOptions o = teacher->options;
    if (options) {
      const kata_teacher_desc d = effective_teacher_desc(options, call);
      if (d.clip || d.skeleton || d.positions || d.features || d.joints)
        invalid(call, "options gives a teacher motion; the shared teacher is the motion (set only ghost, "
                      "ghost_across, retarget, alignment_window and tolerance)");
      o = teacher_options(d, call);
      if (o.ghost && teacher->scores_only)
        invalid(call, "the shared teacher was given as features or GPD joints: it has no ghost (set options->ghost = 0)");
      o.ghost_teacher = teacher->ghost_side;
    }
    check_student(stream, o, call);
    stream->pipeline.set_teacher(teacher->teacher, o);
    return KATA_OK;
  });
}

}  // extern "C"
