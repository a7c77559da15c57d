// What lies behind kata.h's opaque handles, and the one place exceptions become status codes.
// Private to libkata (and the internal tests).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "capi/struct_size.hpp"
#include "common/error.hpp"
#include "common/status.hpp"
#include "io/bvh.hpp"
#include "io/motion_source.hpp"
#include "kata/kata.h"
#include "skeleton/skeleton.hpp"
#include "metric/model.hpp"
#include "pipeline/pipeline.hpp"
#include "pipeline/record.hpp"
#include "stream/stream.hpp"

namespace kata::capi {

// Options of a retargeter from a kata_retarget_desc (NULL: defaults; validated: throws
// kata::Error), and its joint set name ("cmu", "gpd"). Defined in capi_retarget.cpp.
kata::retarget::RetargetOptions retarget_options(const kata_retarget_desc* desc, std::string* joint_set);

// A shipped file named relative to the checkout ("models/default.kata", "data/cmu/05_18.bvh"):
// `path` when absolute or found from the current folder, else the share/kata beside libkata
// (as the CLI and the Python binding look); none: kata::Error(kIo) naming every place looked in.
// Defined in capi_paths.cpp.
std::string shipped_file(const char* path);

// Attaches the teacher a kata_teacher_desc describes to a stream (kata_stream_attach_teacher and
// the deprecated reference calls); messages name `call`. Defined in capi_pipeline.cpp.
kata_status attach_teacher(kata_stream stream, const kata_teacher_desc* desc, const char* call);

// The sized desc inits (kata_*_desc_init_sized): the defaults, cut to the caller's struct so
// that nothing past it is written; struct_size becomes the size written (a caller built against
// a newer kata.h gets this library's smaller size back). Below 4 bytes nothing is written.
template <typename Desc>
void init_sized(Desc* desc, uint32_t struct_size, const Desc& defaults) noexcept {
  if (!desc || struct_size < sizeof(uint32_t)) return;
  const uint32_t size = std::min<uint32_t>(struct_size, static_cast<uint32_t>(sizeof(Desc)));
  std::memcpy(static_cast<void*>(desc), &defaults, size);
  desc->struct_size = size;
}

// Each growable struct's size as 1.0 released it: the end of its last 1.0 field (tail padding
// differs between ABIs; a caller's sizeof is never smaller). read_sized / write_sized
// (capi/struct_size.hpp) refuse a struct_size below these. Never change them: 1.1's fields go
// after these ends.
#define KATA_CAPI_END_OF(T, field) static_cast<uint32_t>(offsetof(T, field) + sizeof(static_cast<T*>(nullptr)->field))
inline constexpr uint32_t kStreamDesc10 = KATA_CAPI_END_OF(kata_stream_desc, keep_features);
inline constexpr uint32_t kTeacherDesc10 = KATA_CAPI_END_OF(kata_teacher_desc, body_height);
inline constexpr uint32_t kRetargetDesc10 = KATA_CAPI_END_OF(kata_retarget_desc, restore_bone_lengths);
inline constexpr uint32_t kRuntimeDesc10 = KATA_CAPI_END_OF(kata_runtime_desc, idle_stream_seconds);
inline constexpr uint32_t kScoreCalibration10 = KATA_CAPI_END_OF(kata_score_calibration, good_score);
inline constexpr uint32_t kRuntimeCounters10 = KATA_CAPI_END_OF(kata_runtime_counters, ingest_practice_queue_full);
inline constexpr uint32_t kRetargetInfo10 = KATA_CAPI_END_OF(kata_retarget_info, max_bone_error);
// The structs 1.1 added, as 1.1 released them (the same rule from their first release on).
inline constexpr uint32_t kSkeletonMessage11 = KATA_CAPI_END_OF(kata_skeleton_message, closed);
inline constexpr uint32_t kFrameMessage11 = KATA_CAPI_END_OF(kata_frame_message, confidences);
inline constexpr uint32_t kPracticeMessage11 = KATA_CAPI_END_OF(kata_practice_message, loop_end);
// A result record a caller hands in (kata_message_write_result): at least 1.0's fields (the
// correction cue came after reserved0; a smaller record's cue is "none").
inline constexpr uint32_t kResultRecord10 = KATA_CAPI_END_OF(kata_result_record, reserved0);
inline constexpr uint32_t kStreamCounters11 = KATA_CAPI_END_OF(kata_stream_counters, send_failed);

// Context errors are kept per context and per thread (kata.h: "the last failed call made on this
// context from the calling thread"). A call made on a context, or on an object that knows its
// context (a runtime), opens a ContextScope; set_context_error then files the message under that
// context. Calls that have no context (kata_clip_positions, kata_time_units_detect) file it under
// the thread alone, and kata_context_last_error shows it on every context of that thread when it
// is newer than the context's own.
class ContextScope {
 public:
  explicit ContextScope(kata_context context) noexcept;
  ~ContextScope();
  ContextScope(const ContextScope&) = delete;
  ContextScope& operator=(const ContextScope&) = delete;

 private:
  kata_context previous_;
};
void set_context_error(const char* message) noexcept;
// The message kata_context_last_error(context) returns on the calling thread.
const char* context_error(kata_context context) noexcept;
// The failure clock now (context creation records it).
uint64_t current_tick() noexcept;

inline kata_status to_status(ErrorKind kind) noexcept {
  switch (kind) {
    case ErrorKind::kInvalidArgument: return KATA_E_INVALID_ARGUMENT;
    case ErrorKind::kParse: return KATA_E_PARSE;
    case ErrorKind::kIo: return KATA_E_IO;
    case ErrorKind::kModel: return KATA_E_MODEL;
    case ErrorKind::kNotFound: return KATA_E_NOT_FOUND;
  }
  return KATA_E_INTERNAL;
}

inline kata_status to_status(Status s) noexcept { return static_cast<kata_status>(static_cast<int>(s)); }

// Runs body() and turns any exception into a status, storing the message with `store`
// (a callable taking const char*). Every exported function that can throw goes through here.
template <class Store, class Body>
kata_status guarded(Store&& store, Body&& body) noexcept {
  try {
    return body();
  } catch (const Error& e) {
    store(e.what());
    return to_status(e.kind());
  } catch (const std::bad_alloc&) {
    store("out of memory");
    return KATA_E_OUT_OF_MEMORY;
  } catch (const std::exception& e) {
    store(e.what());
    return KATA_E_INTERNAL;
  } catch (...) {
    store("unknown internal error");
    return KATA_E_INTERNAL;
  }
}

// Context-level calls: errors go to the thread's context message.
template <class Body>
kata_status guarded_context(Body&& body) noexcept {
  return guarded([](const char* m) { set_context_error(m); }, std::forward<Body>(body));
}

}  // namespace kata::capi

struct kata_context_s {
  // One message per thread that made a failed call on this context; the tick orders it against
  // the thread's context-less message. A node map: a returned c_str() stays valid until that
  // thread's next failed call on the context. Locked only on failure and when read.
  struct ErrorSlot {
    uint64_t tick = 0;
    std::string text;
  };
  std::mutex errors_mutex;
  std::unordered_map<std::thread::id, ErrorSlot> errors;
  uint64_t born = 0;  // the failure clock at creation: older context-less failures are not shown
};

struct kata_skeleton_s {
  kata::Skeleton skeleton;
};

struct kata_clip_s {
  kata::BvhClip clip;
};

// A landmark recording (kata_landmarks_load): the CLI's motion source, held whole.
struct kata_landmarks_s {
  kata::MotionSource motion;
};

struct kata_model_s {
  std::shared_ptr<const kata::metric::Metric> metric;
  kata::metric::TrainingInfo info;
  std::string layout;
};

// A stream is its pipeline (kata::pipeline::Pipeline: stream -> score -> ghost -> result ring);
// the shim adds only the error text of calls refused before they reach it.
struct kata_stream_s {
  explicit kata_stream_s(const kata::pipeline::PipelineConfig& config)
      : pipeline(config),
        landmark_xyz(3 * static_cast<size_t>(std::max(config.stream.input_joints, 0))),
        landmark_confidence(static_cast<size_t>(std::max(config.stream.input_joints, 0))) {}
  kata::pipeline::Pipeline pipeline;
  // kata_stream_push_landmarks splits interleaved channels into these (sized at open: no
  // allocation per frame).
  std::vector<float> landmark_xyz, landmark_confidence;
  // The layout the stream was opened with, as a runtime announces it to subscribers and shards
  // (kata_runtime_add_stream): a built-in layout's name, or a name map's 16 joint names in GPD
  // order (layout_name empty).
  std::string layout_name;
  std::vector<std::string> name_map;
  // kata_stream_read_repetitions: the repetitions of this counter read so far (a new teacher has a
  // new counter, read from its first).
  const void* repetitions_of = nullptr;
  int64_t repetitions_read = 0;
  char error[256] = {0};

  // Copies a message into the stream's fixed buffer (no allocation: used on the frame path).
  void set_error(const char* message) noexcept { std::snprintf(error, sizeof error, "%s", message); }
};

// A teacher built once (kata_teacher_create) and shared by any number of streams: the loaded,
// immutable Teacher (reference-counted: a stream keeps it after the handle is destroyed), how its
// frames are read for a ghost across layouts, and the per-stream options its desc gave, the
// defaults of kata_stream_attach_shared_teacher.
struct kata_teacher_s {
  std::shared_ptr<const kata::pipeline::Teacher> teacher;
  kata::retarget::MappedSide ghost_side;
  kata::pipeline::TeacherOptions options;
  bool scores_only = false;  // given as features or GPD joints: no positions for a ghost
};

// Stream-level calls: errors go to the stream's message buffer.
namespace kata::capi {
template <class Body>
kata_status guarded_stream(kata_stream stream, Body&& body) noexcept {
  return guarded([stream](const char* m) { stream->set_error(m); }, std::forward<Body>(body));
}
inline kata_status refuse(kata_stream stream, kata_status status, const char* message) noexcept {
  stream->set_error(message);
  return status;
}
}  // namespace kata::capi
