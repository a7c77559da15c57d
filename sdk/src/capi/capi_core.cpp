// C shims for versions, status strings, contexts, skeletons, clips and streams.
#include <algorithm>
#include <atomic>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "common/time_units.hpp"
#include "io/clip_features.hpp"
#include "io/file.hpp"
#include "io/motion_source.hpp"
#include "io/name_map.hpp"
#include "metric/model.hpp"

// kata.h states the core's limits as macros; they must stay the same numbers.
static_assert(KATA_MIN_TIME_STEP == kata::kMinTimeStep && KATA_MAX_TIME_STEP == kata::kMaxTimeStep && KATA_MAX_COORDINATE == kata::kMaxCoordinate &&
                  KATA_MIN_BODY_HEIGHT == kata::kMinBodyHeight && KATA_MAX_REACH == kata::kMaxReach &&
                  KATA_MAX_HISTORY == kata::kMaxHistory,
              "kata.h input limits differ from stream/stream.hpp");
static_assert(KATA_MAX_STRING_BYTES == kata::kMaxCStringBytes && KATA_MAX_BVH_BYTES == kata::kMaxBvhBytes &&
                  KATA_MAX_MODEL_BYTES == kata::metric::kMaxModelBytes &&
                  KATA_MAX_NAME_MAP_BYTES == kata::kMaxNameMapBytes,
              "kata.h file and string bounds differ from common/text.hpp, io/file.hpp, metric/model.hpp");

using kata::capi::guarded_context;
using kata::capi::set_context_error;

namespace kata::capi {
namespace {
thread_local kata_context t_current = nullptr;    // the context of the call in progress
// Failed calls so far, in every thread: one clock, so a context's creation orders against a
// thread's context-less failures (a context never shows a failure older than itself).
std::atomic<uint64_t> g_tick{0};
thread_local kata_context_s::ErrorSlot t_loose;   // the last context-less failure
}  // namespace

ContextScope::ContextScope(kata_context context) noexcept : previous_(t_current) { t_current = context; }
ContextScope::~ContextScope() { t_current = previous_; }

void set_context_error(const char* message) noexcept {
  try {
    const uint64_t tick = g_tick.fetch_add(1, std::memory_order_relaxed) + 1;
    if (t_current) {
      std::lock_guard<std::mutex> lock(t_current->errors_mutex);
      kata_context_s::ErrorSlot& slot = t_current->errors[std::this_thread::get_id()];
      slot.text = message;
      slot.tick = tick;
    } else {
      t_loose.text = message;
      t_loose.tick = tick;
    }
  } catch (...) {
    // Out of memory while reporting an error: keep the previous message.
  }
}

uint64_t current_tick() noexcept { return g_tick.load(std::memory_order_relaxed); }

const char* context_error(kata_context context) noexcept {
  if (context) {
    std::lock_guard<std::mutex> lock(context->errors_mutex);
    const auto it = context->errors.find(std::this_thread::get_id());
    if (it != context->errors.end() && it->second.tick > t_loose.tick) return it->second.text.c_str();
    if (t_loose.tick <= context->born) return "";
  }
  return t_loose.text.c_str();
}
}  // namespace kata::capi

namespace {

// An enum field read as the integer it holds: loading an out-of-range value through the enum
// type is undefined behaviour, so the bytes are copied and range-checked by the core.
template <class Enum>
int32_t enum_bits(const Enum& e) {
  static_assert(sizeof(Enum) == sizeof(int32_t), "C enums are 4 bytes on every supported ABI");
  int32_t v;
  std::memcpy(&v, &e, sizeof v);
  return v;
}

// Unsigned counts beyond int range become INT_MAX (refused by the core's range checks).
int clamp_count(uint32_t v) { return static_cast<int>(std::min<uint32_t>(v, INT_MAX)); }

// The stream's layout: a built-in layout by name (desc.layout), a name-map file
// (desc.name_map_path) or a name map's text (kata_stream_open_name_map, which wins). Strings are
// read bounded; a layout and a file together are contradictory and refused.
kata::Layout resolve_map(const kata::Skeleton& skeleton, const kata_stream_desc& desc, const char* name_map_text) {
  if (name_map_text) {  // kata.h: the text is used instead of desc.layout and desc.name_map_path
    kata::Layout layout;
    layout.map = kata::make_gpd_map(skeleton, kata::parse_name_map(name_map_text, "<name map>"));
    return layout;
  }
  const std::string layout_name = kata::c_string(desc.layout, "desc.layout");
  const std::string path = kata::c_string(desc.name_map_path, "desc.name_map_path");
  if (!layout_name.empty() && !path.empty())
    throw kata::Error(kata::ErrorKind::kInvalidArgument, "stream: give a layout or a name-map file, not both (layout '" +
                                                             kata::bounded(layout_name) + "', name map " +
                                                             kata::bounded(path) + ")");
  if (!layout_name.empty()) return kata::resolve_layout(skeleton, layout_name);
  kata::Layout layout;
  layout.map = kata::resolve_gpd_map(skeleton, layout_name, path);  // the file, or the "give a layout" refusal
  return layout;
}

}  // namespace

namespace {
// The defaults kata.h lists for kata_stream_desc.
kata_stream_desc stream_desc_defaults() {
  kata_stream_desc d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.layout = nullptr;
  d.name_map_path = nullptr;
  d.stencil = KATA_STENCIL_BACKWARD;
  d.up_axis = KATA_UP_Y;
  d.max_gap = 0.25;
  d.history_capacity = 16;
  d.body_height = 0.0;
  d.calibration_frames = 8;
  d.result_capacity = 64;
  d.keep_features = 0;
  return d;
}
// What the unsized init writes, for ever: 1.0's struct (programs built before the sized init
// call it by that name). When the struct grows, this stays at 72.
constexpr uint32_t kStreamDescSize10 = 72;
static_assert(sizeof(kata_stream_desc) >= kStreamDescSize10, "the struct only grows");
}  // namespace

extern "C" {

KATA_API uint32_t kata_version(void) {
  return KATA_VERSION_MAJOR * 10000u + KATA_VERSION_MINOR * 100u + KATA_VERSION_PATCH;
}

KATA_API const char* kata_status_string(kata_status status) {
  switch (enum_bits(status)) {  // an int: the caller may pass any value
    case KATA_OK: return "KATA_OK";
    case KATA_NO_DATA: return "KATA_NO_DATA";
    case KATA_E_INVALID_ARGUMENT: return "KATA_E_INVALID_ARGUMENT";
    case KATA_E_NULL_POINTER: return "KATA_E_NULL_POINTER";
    case KATA_E_WRONG_JOINT_COUNT: return "KATA_E_WRONG_JOINT_COUNT";
    case KATA_E_NON_FINITE: return "KATA_E_NON_FINITE";
    case KATA_E_TIMESTAMP_NOT_INCREASING: return "KATA_E_TIMESTAMP_NOT_INCREASING";
    case KATA_E_PARSE: return "KATA_E_PARSE";
    case KATA_E_IO: return "KATA_E_IO";
    case KATA_E_MODEL: return "KATA_E_MODEL";
    case KATA_E_NOT_FOUND: return "KATA_E_NOT_FOUND";
    case KATA_E_OUT_OF_MEMORY: return "KATA_E_OUT_OF_MEMORY";
    case KATA_E_BUFFER_TOO_SMALL: return "KATA_E_BUFFER_TOO_SMALL";
    case KATA_E_INTERNAL: return "KATA_E_INTERNAL";
    case KATA_E_STATE: return "KATA_E_STATE";
    case KATA_TRACKING_LOST: return "KATA_TRACKING_LOST";
    case KATA_E_STOPPED: return "KATA_E_STOPPED";
    case KATA_E_QUEUE_FULL: return "KATA_E_QUEUE_FULL";
    case KATA_E_NO_CLIP_TEACHER: return "KATA_E_NO_CLIP_TEACHER";
  }
  return "KATA_E_UNKNOWN_STATUS";
}

/* ---- context ---- */

KATA_API kata_status kata_context_create(kata_context* out) {
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  return guarded_context([&] {
    *out = new kata_context_s();
    (*out)->born = kata::capi::current_tick();
    return KATA_OK;
  });
}

KATA_API void kata_context_destroy(kata_context context) { delete context; }

KATA_API const char* kata_context_last_error(kata_context context) { return kata::capi::context_error(context); }

/* ---- skeletons ---- */

KATA_API kata_status kata_skeleton_create(kata_context context, uint32_t joint_count, const char* const* names,
                                          const int32_t* parents, const double* rest_offsets, kata_skeleton* out) {
  const kata::capi::ContextScope scope(context);
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!context || !names || !parents) {
    set_context_error("kata_skeleton_create: context, names and parents must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  return guarded_context([&] {
    if (joint_count == 0) throw kata::Error(kata::ErrorKind::kInvalidArgument, "skeleton: no joints");
    kata::Skeleton s;
    for (uint32_t i = 0; i < joint_count; ++i) {
      if (!names[i]) throw kata::Error(kata::ErrorKind::kInvalidArgument, "skeleton: joint " + std::to_string(i) + " has a NULL name");
      s.names.push_back(kata::c_string(names[i], "skeleton joint name"));  // bounded read
      s.parents.push_back(parents[i]);
      s.offsets.emplace_back(rest_offsets ? Eigen::Vector3d(rest_offsets[3 * i], rest_offsets[3 * i + 1], rest_offsets[3 * i + 2])
                                          : Eigen::Vector3d::Zero());
    }
    s.has_rest_pose = rest_offsets != nullptr;
    s.validate();
    *out = new kata_skeleton_s{std::move(s)};
    return KATA_OK;
  });
}

KATA_API kata_status kata_skeleton_load_bvh(kata_context context, const char* path, kata_skeleton* out) {
  const kata::capi::ContextScope scope(context);
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!context || !path) {
    set_context_error("kata_skeleton_load_bvh: context and path must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  return guarded_context([&] {
    kata::BvhClip clip = kata::load_bvh(kata::capi::shipped_file(path));
    *out = new kata_skeleton_s{std::move(clip.skeleton)};
    return KATA_OK;
  });
}

KATA_API void kata_skeleton_destroy(kata_skeleton skeleton) { delete skeleton; }

KATA_API uint32_t kata_skeleton_joint_count(kata_skeleton skeleton) {
  return skeleton ? static_cast<uint32_t>(skeleton->skeleton.joint_count()) : 0u;
}

KATA_API const char* kata_skeleton_joint_name(kata_skeleton skeleton, uint32_t i) {
  if (!skeleton || i >= static_cast<uint32_t>(skeleton->skeleton.joint_count())) return nullptr;
  return skeleton->skeleton.names[i].c_str();
}

KATA_API int32_t kata_skeleton_joint_parent(kata_skeleton skeleton, uint32_t i) {
  if (!skeleton || i >= static_cast<uint32_t>(skeleton->skeleton.joint_count())) return -2;
  return skeleton->skeleton.parents[i];
}

KATA_API kata_status kata_skeleton_joint_offset(kata_skeleton skeleton, uint32_t i, double* out) {
  if (!skeleton || !out) return KATA_E_NULL_POINTER;
  const kata::Skeleton& s = skeleton->skeleton;
  if (i >= static_cast<uint32_t>(s.joint_count())) return KATA_E_INVALID_ARGUMENT;
  if (!s.has_rest_pose) return KATA_E_STATE;
  for (int k = 0; k < 3; ++k) out[k] = s.offsets[i][k];
  return KATA_OK;
}

/* ---- clips ---- */

KATA_API kata_status kata_clip_load_bvh(kata_context context, const char* path, kata_clip* out) {
  const kata::capi::ContextScope scope(context);
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!context || !path) {
    set_context_error("kata_clip_load_bvh: context and path must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  return guarded_context([&] {
    *out = new kata_clip_s{kata::load_bvh(kata::capi::shipped_file(path))};
    return KATA_OK;
  });
}

KATA_API void kata_clip_destroy(kata_clip clip) { delete clip; }

KATA_API kata_status kata_landmarks_load(kata_context context, const char* path, const char* layout, double fps,
                                         int32_t time_units, kata_landmarks* out) {
  const kata::capi::ContextScope scope(context);
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!context || !path || !layout) {
    set_context_error("kata_landmarks_load: context, path and layout must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  return guarded_context([&] {
    kata::TimeUnits units = kata::TimeUnits::kAuto;
    if (time_units == KATA_TIME_SECONDS) units = kata::TimeUnits::kSeconds;
    else if (time_units == KATA_TIME_MILLISECONDS) units = kata::TimeUnits::kMilliseconds;
    else if (time_units != -1)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        "kata_landmarks_load: time_units must be KATA_TIME_SECONDS, KATA_TIME_MILLISECONDS or -1");
    const std::string name = kata::c_string(layout, "layout");
    if (name.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_landmarks_load: give the recording's layout");
    auto l = std::make_unique<kata_landmarks_s>();
    l->motion = kata::load_motion(kata::c_string(path, "path"), name, fps, kata::UpAxis::kY, 0, units);
    *out = l.release();
    return KATA_OK;
  });
}

KATA_API void kata_landmarks_destroy(kata_landmarks landmarks) { delete landmarks; }

KATA_API uint32_t kata_landmarks_frame_count(kata_landmarks landmarks) {
  return landmarks ? static_cast<uint32_t>(landmarks->motion.frames) : 0u;
}

KATA_API uint32_t kata_landmarks_joint_count(kata_landmarks landmarks) {
  return landmarks ? static_cast<uint32_t>(landmarks->motion.skeleton.joint_count()) : 0u;
}

KATA_API double kata_landmarks_frame_time(kata_landmarks landmarks) { return landmarks ? landmarks->motion.frame_time : 0.0; }

KATA_API double kata_landmarks_capture_time(kata_landmarks landmarks, uint32_t frame) {
  if (!landmarks || frame >= static_cast<uint32_t>(landmarks->motion.frames)) return -1.0;
  return landmarks->motion.time_of(static_cast<int>(frame));
}

KATA_API const float* kata_landmarks_positions(kata_landmarks landmarks) {
  return landmarks ? landmarks->motion.xyz.data() : nullptr;
}

KATA_API uint32_t kata_clip_frame_count(kata_clip clip) {
  return clip ? static_cast<uint32_t>(clip->clip.frame_count()) : 0u;
}

KATA_API double kata_clip_frame_time(kata_clip clip) { return clip ? clip->clip.frame_time : 0.0; }

KATA_API kata_status kata_clip_skeleton(kata_clip clip, kata_skeleton* out) {
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!clip) return KATA_E_NULL_POINTER;
  return guarded_context([&] {
    *out = new kata_skeleton_s{clip->clip.skeleton};
    return KATA_OK;
  });
}

KATA_API kata_status kata_clip_positions(kata_clip clip, uint32_t frame, float* out, size_t capacity) {
  if (!clip || !out) return KATA_E_NULL_POINTER;
  const auto& c = clip->clip;
  const size_t n = static_cast<size_t>(c.skeleton.joint_count());
  if (frame >= static_cast<uint32_t>(c.frame_count())) {
    set_context_error("kata_clip_positions: frame index past the clip's last frame");
    return KATA_E_INVALID_ARGUMENT;
  }
  if (capacity < 3 * n) {
    set_context_error("kata_clip_positions: buffer smaller than 3 x joint count floats");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  return guarded_context([&] {
    // Up to 256 joints the positions live on the stack (no allocation); larger rigs use the heap.
    using Small = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::ColMajor, 256, 3>;
    auto copy_out = [&](const auto& m) {
      for (size_t j = 0; j < n; ++j)
        for (int k = 0; k < 3; ++k) out[3 * j + k] = static_cast<float>(m(static_cast<Eigen::Index>(j), k));
    };
    if (n <= 256) {
      Small m(static_cast<Eigen::Index>(n), 3);
      kata::world_positions(c, static_cast<int>(frame), m);
      copy_out(m);
    } else {
      Eigen::MatrixX3d m(static_cast<Eigen::Index>(n), 3);
      kata::world_positions(c, static_cast<int>(frame), m);
      copy_out(m);
    }
    return KATA_OK;
  });
}

/* ---- streams ---- */

KATA_API void kata_stream_desc_init_sized(kata_stream_desc* desc, uint32_t struct_size) {
  kata::capi::init_sized(desc, struct_size, stream_desc_defaults());
}

// In parentheses: kata.h's macro of the same name is not expanded here.
KATA_API const char* kata_layout_name(uint32_t i) {
  try {
    static const std::vector<std::string> names = kata::layout_names();  // built once, kept for the process
    return i < names.size() ? names[i].c_str() : nullptr;
  } catch (...) {
    return nullptr;
  }
}

KATA_API kata_status kata_skeleton_create_layout(kata_context context, const char* layout, kata_skeleton* out) {
  const kata::capi::ContextScope scope(context);
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!context || !layout) {
    set_context_error("kata_skeleton_create_layout: context and layout must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  return guarded_context([&] {
    *out = new kata_skeleton_s{kata::layout_skeleton(layout)};
    return KATA_OK;
  });
}

static kata_status open_stream(kata_context context, kata_skeleton skeleton, const kata_stream_desc* desc,
                               const char* name_map_text, kata_stream* out) {
  const kata::capi::ContextScope scope(context);
  if (!out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  if (!context || !skeleton || !desc) {
    set_context_error("kata_stream_open: context, skeleton and desc must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  kata_stream_desc full;
  if (!kata::capi::read_sized(desc, stream_desc_defaults(), kata::capi::kStreamDesc10, &full)) {
    set_context_error("kata_stream_open: desc.struct_size is below 1.0's kata_stream_desc (call kata_stream_desc_init)");
    return KATA_E_INVALID_ARGUMENT;
  }
  desc = &full;
  return guarded_context([&] {
    const kata::Skeleton& skel = skeleton->skeleton;
    kata::StreamConfig config;
    const kata::Layout layout = resolve_map(skel, *desc, name_map_text);
    config.map = layout.map;
    config.input_joints = skel.joint_count();
    // Enum class values hold any int; Stream refuses those outside the enums.
    config.stencil = static_cast<kata::gpd::Stencil>(enum_bits(desc->stencil));
    config.up_axis = layout.fixed_axes ? layout.axes : static_cast<kata::UpAxis>(enum_bits(desc->up_axis));
    config.smoothing = layout.smooth;
    config.max_gap = desc->max_gap;
    config.history = clamp_count(desc->history_capacity);
    config.calibration_frames = clamp_count(desc->calibration_frames);
    // A Z-up rig's rest pose gives the same lengths: H only uses distances.
    config.body_height = kata::stream_body_height(desc->body_height, skel, config.map);
    kata::pipeline::PipelineConfig pc;
    pc.stream = config;
    pc.student = skel;
    pc.result_capacity = static_cast<int>(std::min<uint32_t>(desc->result_capacity, 1u << 20));
    pc.keep_features = desc->keep_features != 0;
    auto opened = std::make_unique<kata_stream_s>(pc);
    if (!name_map_text && desc->layout && desc->layout[0]) {
      opened->layout_name = kata::c_string(desc->layout, "desc.layout");
    } else {
      for (int g = 0; g < kata::kGpdJoints; ++g) {
        const int source = layout.map.source[static_cast<size_t>(g)];
        if (source < 0) throw std::logic_error("stream: a name map left a GPD joint unmapped");
        opened->name_map.push_back(skel.names[static_cast<size_t>(source)]);
      }
    }
    *out = opened.release();
    return KATA_OK;
  });
}

KATA_API kata_status kata_stream_open(kata_context context, kata_skeleton skeleton, const kata_stream_desc* desc,
                                      kata_stream* out) {
  return open_stream(context, skeleton, desc, nullptr, out);
}

KATA_API kata_status kata_stream_open_name_map(kata_context context, kata_skeleton skeleton,
                                               const kata_stream_desc* desc, const char* name_map_text,
                                               kata_stream* out) {
  const kata::capi::ContextScope scope(context);
  if (!name_map_text) {
    if (out) *out = nullptr;
    set_context_error("kata_stream_open_name_map: name_map_text must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  return open_stream(context, skeleton, desc, name_map_text, out);
}

KATA_API kata_status kata_stream_set_confidence_gate(kata_stream stream, float threshold, double max_hold,
                                                     double max_missing_share) {
  if (!stream) return KATA_E_NULL_POINTER;
  return kata::capi::guarded([stream](const char* m) { stream->set_error(m); }, [&] {
    stream->pipeline.stream().set_confidence_gate(threshold, max_hold, max_missing_share);
    return KATA_OK;
  });
}

KATA_API kata_status kata_stream_set_smoothing(kata_stream stream, int32_t enabled, double min_cutoff, double beta,
                                               double d_cutoff) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (enabled != 0 && enabled != 1) {
    stream->set_error("kata_stream_set_smoothing: enabled must be 0 or 1");
    return KATA_E_INVALID_ARGUMENT;
  }
  return kata::capi::guarded([stream](const char* m) { stream->set_error(m); }, [&] {
    stream->pipeline.stream().set_smoothing(enabled == 1, min_cutoff, beta, d_cutoff);
    return KATA_OK;
  });
}

KATA_API void kata_stream_destroy(kata_stream stream) { delete stream; }

KATA_API const char* kata_stream_last_error(kata_stream stream) { return stream ? stream->error : ""; }

KATA_API kata_status kata_stream_push(kata_stream stream, double timestamp, const float* positions,
                                      uint32_t joint_count) {
  if (!stream) return KATA_E_NULL_POINTER;
  // Stream::push never throws; joint counts beyond int range are simply wrong.
  const int count = joint_count > 1000000u ? -1 : static_cast<int>(joint_count);
  const kata::Status s = stream->pipeline.push(timestamp, positions, count);
  if (s != kata::Status::kOk) stream->set_error(stream->pipeline.last_error());
  return kata::capi::to_status(s);
}

KATA_API kata_status kata_stream_push_confidence(kata_stream stream, double timestamp, const float* positions,
                                                 const float* confidences, uint32_t joint_count) {
  if (!stream) return KATA_E_NULL_POINTER;
  const int count = joint_count > 1000000u ? -1 : static_cast<int>(joint_count);
  const kata::Status s = stream->pipeline.push(timestamp, positions, confidences, count);
  if (s != kata::Status::kOk) stream->set_error(stream->pipeline.last_error());
  return kata::capi::to_status(s);
}

KATA_API kata_status kata_stream_push_many(kata_stream stream, const double* timestamps, const float* positions,
                                           const float* confidences, uint32_t joint_count, uint32_t frames,
                                           uint32_t* pushed, uint32_t* tracking_lost) {
  if (pushed) *pushed = 0;
  if (tracking_lost) *tracking_lost = 0;
  if (!stream) return KATA_E_NULL_POINTER;
  if (frames > 0 && (!timestamps || !positions)) {
    stream->set_error("kata_stream_push_many: timestamps and positions must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  const int count = joint_count > 1000000u ? -1 : static_cast<int>(joint_count);
  const size_t stride = 3 * static_cast<size_t>(joint_count);
  uint32_t lost = 0;
  for (uint32_t i = 0; i < frames; ++i) {
    const float* c = confidences ? confidences + static_cast<size_t>(i) * joint_count : nullptr;
    const kata::Status s = stream->pipeline.push(timestamps[i], positions + static_cast<size_t>(i) * stride, c, count);
    if (s == kata::Status::kTrackingLost) {
      ++lost;
    } else if (s != kata::Status::kOk) {
      stream->set_error(stream->pipeline.last_error());
      if (pushed) *pushed = i;
      if (tracking_lost) *tracking_lost = lost;
      return kata::capi::to_status(s);
    }
  }
  if (pushed) *pushed = frames;
  if (tracking_lost) *tracking_lost = lost;
  return KATA_OK;
}

KATA_API kata_status kata_stream_push_landmarks(kata_stream stream, double timestamp, kata_time_units units,
                                                const float* values, uint32_t joint_count, uint32_t channels) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!values) {
    stream->set_error("kata_stream_push_landmarks: values is NULL");
    return KATA_E_NULL_POINTER;
  }
  if (units != KATA_TIME_SECONDS && units != KATA_TIME_MILLISECONDS) {
    stream->set_error("kata_stream_push_landmarks: units must be KATA_TIME_SECONDS or KATA_TIME_MILLISECONDS");
    return KATA_E_INVALID_ARGUMENT;
  }
  if (channels < 3 || channels > 5) {
    stream->set_error("kata_stream_push_landmarks: channels must be 3 (x y z), 4 (+ confidence) or 5 (+ visibility, presence)");
    return KATA_E_INVALID_ARGUMENT;
  }
  if (joint_count != stream->landmark_confidence.size()) {
    std::snprintf(stream->error, sizeof stream->error, "kata_stream_push_landmarks: %u joints, the stream has %zu",
                  joint_count, stream->landmark_confidence.size());
    return KATA_E_WRONG_JOINT_COUNT;
  }
  float* xyz = stream->landmark_xyz.data();
  float* confidence = stream->landmark_confidence.data();
  for (size_t j = 0; j < joint_count; ++j) {
    const float* v = values + j * channels;
    xyz[3 * j] = v[0], xyz[3 * j + 1] = v[1], xyz[3 * j + 2] = v[2];
    // Five channels: a joint is as confident as the smaller of visibility and presence (a NaN
    // in either stays NaN: missing).
    confidence[j] = channels == 3 ? 1.0f : channels == 4 ? v[3] : (std::isnan(v[3]) || std::isnan(v[4])) ? NAN : std::fmin(v[3], v[4]);
  }
  const double seconds = units == KATA_TIME_MILLISECONDS ? timestamp * 1e-3 : timestamp;
  return kata_stream_push_confidence(stream, seconds, xyz, confidence, joint_count);
}

KATA_API kata_status kata_time_units_detect(const double* timestamps, size_t count, kata_time_units* out) {
  if (!timestamps || !out) return KATA_E_NULL_POINTER;
  return kata::capi::guarded_context([&] {
    *out = kata::resolve_time_units(timestamps, count, kata::TimeUnits::kAuto, "timestamps") == kata::TimeUnits::kMilliseconds
               ? KATA_TIME_MILLISECONDS
               : KATA_TIME_SECONDS;
    return KATA_OK;
  });
}

KATA_API int64_t kata_stream_lost_frames(kata_stream stream) { return stream ? stream->pipeline.stream().lost_frames() : 0; }

KATA_API kata_status kata_stream_bone_lengths(kata_stream stream, double* lengths, double* spread, size_t capacity) {
  if (!stream) return KATA_E_NULL_POINTER;
  if ((lengths || spread) && capacity < static_cast<size_t>(KATA_GPD_JOINTS)) {
    stream->set_error("kata_stream_bone_lengths: arrays hold fewer than KATA_GPD_JOINTS entries");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  return stream->pipeline.stream().bone_lengths(lengths, spread) ? KATA_OK : KATA_NO_DATA;
}

KATA_API kata_status kata_stream_flush(kata_stream stream) {
  if (!stream) return KATA_E_NULL_POINTER;
  const kata::Status s = stream->pipeline.flush();
  if (s != kata::Status::kOk) stream->set_error(stream->pipeline.last_error());
  return kata::capi::to_status(s);
}

KATA_API kata_status kata_stream_reset(kata_stream stream) {
  if (!stream) return KATA_E_NULL_POINTER;
  stream->pipeline.reset();
  return KATA_OK;
}

KATA_API kata_status kata_stream_features(kata_stream stream, float* out, size_t capacity, double* timestamp,
                                          int64_t* frame_index) {
  if (!stream) return KATA_E_NULL_POINTER;
  if (!out) {
    stream->set_error("kata_stream_features: out is NULL");
    return KATA_E_NULL_POINTER;
  }
  if (capacity < static_cast<size_t>(KATA_GPD_DIMS)) {
    stream->set_error("kata_stream_features: buffer holds fewer than KATA_GPD_DIMS floats");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  const float* f = stream->pipeline.stream().features();
  if (!f) return KATA_NO_DATA;
  std::memcpy(out, f, sizeof(float) * KATA_GPD_DIMS);
  if (timestamp) *timestamp = stream->pipeline.stream().feature_time();
  if (frame_index) *frame_index = stream->pipeline.stream().feature_frame();
  return KATA_OK;
}

KATA_API int64_t kata_stream_feature_count(kata_stream stream) {
  return stream ? stream->pipeline.stream().emitted_count() : 0;
}

KATA_API double kata_stream_body_height(kata_stream stream) { return stream ? stream->pipeline.stream().body_height() : 0.0; }

KATA_API int32_t kata_stream_gpd_joint_source(kata_stream stream, uint32_t gpd_joint) {
  if (!stream || gpd_joint >= static_cast<uint32_t>(kata::kGpdJoints)) return -1;
  const int source = stream->pipeline.stream().config().map.source[gpd_joint];
  return source >= 0 ? source : -1;
}

}  // extern "C"
