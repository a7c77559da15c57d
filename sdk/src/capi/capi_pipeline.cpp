// C shims for the per-stream pipeline (kata.h section "Pipeline"): attaching a teacher in one call
// and draining results. The composition is kata::pipeline::Pipeline's; these only translate.
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "io/clip_features.hpp"

using kata::capi::guarded_stream;
using kata::capi::refuse;

namespace {

// The caller's desc, checked to be a whole kata_teacher_desc.
kata_teacher_desc effective_teacher_desc(const kata_teacher_desc* desc) {
  kata_teacher_desc d;
  kata_teacher_desc_init(&d);
  // Only whole released structs: a partial copy could take half of the model pointer (the
  // first release of this struct is this one, so its size is the only valid one).
  if (desc->struct_size != sizeof d)
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      "kata_stream_attach_teacher: desc->struct_size is not sizeof(kata_teacher_desc) "
                      "(call kata_teacher_desc_init)");
  std::memcpy(&d, desc, sizeof d);
  d.struct_size = sizeof d;
  return d;
}

// The teacher's joint positions and skeleton from the desc (a clip, or frames given in memory).
std::shared_ptr<const kata::pipeline::Teacher> make_teacher(const kata_teacher_desc& d, kata::gpd::Stencil stencil) {
  std::string preset = kata::c_string(d.preset, "kata_teacher_desc.preset");  // bounded read
  if (preset.empty()) preset = "cmu";
  if (d.clip && (d.skeleton || d.positions))
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      "kata_stream_attach_teacher: give a clip or skeleton + positions, not both");
  kata::Skeleton skeleton;
  std::vector<float> positions;
  double frame_time = 0.0;
  int frames = 0;
  if (d.clip) {
    const kata::BvhClip& c = d.clip->clip;
    if (d.first_frame >= static_cast<uint32_t>(c.frame_count()))
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_stream_attach_teacher: first_frame is past the clip's end");
    skeleton = c.skeleton;
    positions = kata::clip_positions(c, static_cast<int>(d.first_frame));
    frames = c.frame_count() - static_cast<int>(d.first_frame);
    frame_time = c.frame_time;
  } else {
    if (!d.skeleton || !d.positions)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_stream_attach_teacher: no teacher motion (set clip, or skeleton + positions + frames)");
    if (d.frames == 0 || d.frames > (1u << 24) || d.first_frame >= d.frames)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_stream_attach_teacher: frames must be in 1..2^24 and first_frame below it");
    skeleton = d.skeleton->skeleton;
    const size_t per_frame = 3 * static_cast<size_t>(skeleton.joint_count());
    positions.assign(d.positions + d.first_frame * per_frame, d.positions + d.frames * per_frame);
    frames = static_cast<int>(d.frames - d.first_frame);
    frame_time = d.frame_time;
  }
  int pose = -1;
  if (d.pose_frame >= 0) {
    if (static_cast<uint32_t>(d.pose_frame) < d.first_frame || d.pose_frame - static_cast<int>(d.first_frame) >= frames)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_stream_attach_teacher: pose_frame must be -1 or a teacher frame >= first_frame");
    pose = d.pose_frame - static_cast<int>(d.first_frame);
  } else if (d.pose_frame != -1) {
    throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_stream_attach_teacher: pose_frame must be >= -1");
  }
  const kata::GpdMap map = kata::make_gpd_map(skeleton, kata::preset_joint_names(preset));
  kata::StreamConfig config = kata::stream_config_for(skeleton, map, stencil);
  return kata::pipeline::Teacher::from_positions(d.model->metric, skeleton, config, positions.data(), frames,
                                                 frame_time, pose);
}

}  // namespace

extern "C" {

KATA_API void kata_teacher_desc_init(kata_teacher_desc* desc) {
  if (!desc) return;
  std::memset(desc, 0, sizeof *desc);
  desc->struct_size = sizeof *desc;
  desc->pose_frame = -1;
  desc->ghost = 1;
}

KATA_API kata_status kata_stream_attach_teacher(kata_stream stream, const kata_teacher_desc* desc) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!desc) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_attach_teacher: desc is NULL");
  return guarded_stream(stream, [&] {
    const kata_teacher_desc d = effective_teacher_desc(desc);
    if (!d.model) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_attach_teacher: desc->model is NULL");
    kata::pipeline::TeacherOptions options;
    options.ghost = d.ghost != 0;
    options.retarget = kata::capi::retarget_options(d.retarget, &options.ghost_joints);
    if (options.ghost && !stream->pipeline.student().has_rest_pose)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_stream_attach_teacher: a ghost needs the student's bone lengths, and the stream's "
                        "skeleton has no rest offsets (set desc->ghost = 0 for scores only)");
    stream->pipeline.set_teacher(make_teacher(d, stream->pipeline.stream().config().stencil), options);
    return KATA_OK;
  });
}

KATA_API kata_status kata_stream_read_results(kata_stream stream, kata_result* results, kata_score_record* scores,
                                              float* ghosts, size_t ghost_capacity, float* features,
                                              size_t feature_capacity, uint32_t capacity, uint32_t* count) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!results || !count) return refuse(stream, KATA_E_NULL_POINTER, "kata_stream_read_results: results and count must not be NULL");
  *count = 0;
  kata::pipeline::Pipeline& p = stream->pipeline;
  const uint32_t result_size = results->struct_size;
  if (result_size < offsetof(kata_result, flags) + sizeof(uint32_t))
    return refuse(stream, KATA_E_INVALID_ARGUMENT, "kata_stream_read_results: results[0].struct_size is not set");
  const uint32_t score_size = scores ? scores->struct_size : 0;
  if (scores && score_size < sizeof(uint32_t))
    return refuse(stream, KATA_E_INVALID_ARGUMENT, "kata_stream_read_results: scores[0].struct_size is not set");
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
    kata_result k{};
    k.struct_size = sizeof k;
    k.flags = (r.scored ? KATA_RESULT_SCORED : 0u) | (r.has_ghost ? KATA_RESULT_GHOST : 0u);
    k.sequence = r.sequence;
    k.frame_index = r.frame_index;
    k.capture_time = r.capture_time;
    k.arrival_ns = r.arrival_ns;
    k.computed_ns = r.computed_ns;
    k.matched_teacher_frame = r.scored ? r.matched_frame : -1;
    k.matched_teacher_time = r.scored ? r.score.matched_time : -1.0;
    k.ghost_joint_count = r.has_ghost ? static_cast<uint32_t>(p.ghost_joint_count()) : 0u;
    auto* dst = reinterpret_cast<unsigned char*>(results) + static_cast<size_t>(n) * result_size;
    std::memcpy(dst, &k, std::min<size_t>(result_size, sizeof k));
    std::memcpy(dst, &result_size, sizeof result_size);
    if (scores) {
      auto* rec = reinterpret_cast<kata_score_record*>(reinterpret_cast<unsigned char*>(scores) +
                                                      static_cast<size_t>(n) * score_size);
      rec->struct_size = score_size;
      if (r.scored) {
        kata::capi::copy_score(r, rec);
      } else {
        std::memset(rec, 0, score_size);
        rec->struct_size = score_size;
      }
    }
  }
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

}  // extern "C"
