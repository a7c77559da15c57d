// C ABI of the ingest message writers (kata/runtime.h "Writing ingest messages"): the caller's
// message struct -> checked values -> the runtime's own wire codec (transport::Encoder) -> the
// caller's buffer. The bytes are the Encoder's: what kata's senders put on the wire.
#include <cmath>
#include <string>
#include <vector>

#include "capi/capi_internal.hpp"
#include "common/text.hpp"
#include "pipeline/record.hpp"
#include "transport/wire.hpp"

namespace {

using kata::capi::set_context_error;

// One encoder per thread, grown to the largest message it wrote.
kata::transport::Encoder& thread_encoder() {
  thread_local kata::transport::Encoder encoder;
  return encoder;
}

// A refused message: nothing written, *size 0, the reason on the thread.
kata_status refuse(kata_status status, size_t* size, const std::string& why) {
  *size = 0;
  set_context_error(why.c_str());
  return status;
}

// The encoded message into the caller's buffer, or its size when the buffer is too small.
kata_status deliver(const char* call, kata::transport::Bytes m, void* buffer, size_t capacity, size_t* size) {
  *size = m.size;
  if (capacity < m.size) {
    set_context_error((std::string(call) + ": the message needs " + std::to_string(m.size) + " bytes, the buffer holds " +
                       std::to_string(capacity))
                          .c_str());
    return KATA_E_BUFFER_TOO_SMALL;
  }
  std::memcpy(buffer, m.data, m.size);
  return KATA_OK;
}

// The checks every writer starts with: NULL pointers, then the struct's size (1.1's or more).
template <typename T>
kata_status check_call(const char* call, const T* message, const void* buffer, size_t capacity, size_t* size,
                       uint32_t released, const T& defaults, T* out) {
  if (!size) return KATA_E_NULL_POINTER;
  *size = 0;
  if (!message || (!buffer && capacity > 0))
    return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": message and size must not be NULL, nor buffer with a capacity");
  if (!kata::capi::read_sized(message, defaults, released, out))
    return refuse(KATA_E_INVALID_ARGUMENT, size,
                  std::string(call) + ": struct_size " + std::to_string(message->struct_size) +
                      " is below the struct's first size (fill it with its _init macro)");
  return KATA_OK;
}

kata_skeleton_message skeleton_message_defaults() {
  kata_skeleton_message d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.revision = 1;
  d.up_axis = KATA_UP_Y;
  return d;
}

kata_frame_message frame_message_defaults() {
  kata_frame_message d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  return d;
}

kata_practice_message practice_message_defaults() {
  kata_practice_message d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  d.revision = 1;
  return d;
}

constexpr uint32_t kMaxFrameJoints = 1u << 20;  // as kata_runtime_push
constexpr uint32_t kMaxSkeletonJoints = 32767;  // parents travel as int16
constexpr double kMaxCaptureSeconds = 9.2e9;    // int64 nanoseconds hold +-9.22e9 s

// A frame message's values as kata_message_write_frame documents them (NULL pointers, joint
// count, finite values): KATA_OK, or the refusal with the reason, naming `call`.
kata_status check_frame(const char* call, const kata_frame_message& m, size_t* size) {
  if (!m.positions) return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": no positions");
  if (m.joint_count < 1 || m.joint_count > kMaxFrameJoints)
    return refuse(KATA_E_WRONG_JOINT_COUNT, size,
                  std::string(call) + ": joint_count " + std::to_string(m.joint_count) + " (1..1048576)");
  if (!std::isfinite(m.capture_time))
    return refuse(KATA_E_NON_FINITE, size, std::string(call) + ": capture_time is not finite");
  if (std::fabs(m.capture_time) > kMaxCaptureSeconds)
    return refuse(KATA_E_INVALID_ARGUMENT, size,
                  std::string(call) + ": capture_time beyond +-9.2e9 s (the wire's int64 nanoseconds)");
  for (uint32_t j = 0; j < m.joint_count; ++j) {
    const float* p = m.positions + 3 * static_cast<size_t>(j);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      return refuse(KATA_E_NON_FINITE, size,
                    std::string(call) + ": joint " + std::to_string(j) + " has a NaN or infinite coordinate");
    if (m.confidences && std::isinf(m.confidences[j]))
      return refuse(KATA_E_NON_FINITE, size,
                    std::string(call) + ": joint " + std::to_string(j) + " has an infinite confidence");
    if (m.presences && std::isinf(m.presences[j]))
      return refuse(KATA_E_NON_FINITE, size,
                    std::string(call) + ": joint " + std::to_string(j) + " has an infinite presence");
  }
  return KATA_OK;
}

// A checked frame message as the encoder takes it: the capture time as the wire's nanoseconds,
// rounded (as a result record's: wire_encode.cpp).
kata::transport::Encoder::BatchFrame batch_frame_of(const kata_frame_message& m) {
  kata::transport::Encoder::BatchFrame f;
  f.stream_id = m.stream_id;
  f.sequence = m.sequence;
  f.capture_ns = static_cast<int64_t>(std::round(m.capture_time * 1e9));
  f.xyz = m.positions;
  f.joints = static_cast<int>(m.joint_count);
  f.confidence = m.confidences;
  f.presence = m.presences;
  return f;
}

}  // namespace

extern "C" {

KATA_API void kata_skeleton_message_init_sized(kata_skeleton_message* message, uint32_t struct_size) {
  kata::capi::init_sized(message, struct_size, skeleton_message_defaults());
}

KATA_API void kata_frame_message_init_sized(kata_frame_message* message, uint32_t struct_size) {
  kata::capi::init_sized(message, struct_size, frame_message_defaults());
}

KATA_API void kata_practice_message_init_sized(kata_practice_message* message, uint32_t struct_size) {
  kata::capi::init_sized(message, struct_size, practice_message_defaults());
}

KATA_API kata_status kata_message_write_skeleton(const kata_skeleton_message* message, void* buffer, size_t capacity,
                                                 size_t* size) {
  static const char* const call = "kata_message_write_skeleton";
  kata_skeleton_message m;
  if (const kata_status s = check_call(call, message, buffer, capacity, size, kata::capi::kSkeletonMessage11,
                                       skeleton_message_defaults(), &m))
    return s;
  if (!m.skeleton) return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": no skeleton");
  return kata::capi::guarded_context([&] {
    const kata::Skeleton& skeleton = m.skeleton->skeleton;
    const std::string layout = kata::c_string(m.layout, "layout");
    if (layout.empty() == (m.name_map == nullptr))
      return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": give a layout or a name map (one of the two)");
    if (m.up_axis != KATA_UP_Y && m.up_axis != KATA_UP_Z)
      return refuse(KATA_E_INVALID_ARGUMENT, size,
                    std::string(call) + ": up_axis " + std::to_string(static_cast<int>(m.up_axis)) +
                        ": a skeleton message carries KATA_UP_Y or KATA_UP_Z only");
    if (!std::isfinite(m.metres_per_unit) || !std::isfinite(m.frame_rate))
      return refuse(KATA_E_NON_FINITE, size, std::string(call) + ": metres_per_unit and frame_rate must be finite");
    if (m.metres_per_unit < 0.0f || m.frame_rate < 0.0f)
      return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": metres_per_unit and frame_rate must not be negative");
    if (m.closed != 0 && m.closed != 1)
      return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": closed is 0 or 1");
    if (skeleton.joint_count() > static_cast<int>(kMaxSkeletonJoints))
      return refuse(KATA_E_INVALID_ARGUMENT, size,
                    std::string(call) + ": " + std::to_string(skeleton.joint_count()) +
                        " joints; a skeleton message carries at most 32767");
    if (skeleton.has_rest_pose)
      for (size_t j = 0; j < skeleton.offsets.size(); ++j)
        if (!skeleton.offsets[j].allFinite())
          return refuse(KATA_E_NON_FINITE, size,
                        std::string(call) + ": the rest offset of joint " + std::to_string(j) + " is not finite");
    kata::transport::SkeletonDefinition d;
    d.stream_id = m.stream_id;
    d.revision = m.revision;
    d.skeleton = skeleton;
    d.layout = layout;
    if (m.name_map) {
      for (int g = 0; g < KATA_GPD_JOINTS; ++g) {
        const std::string name = kata::c_string(m.name_map[g], "name_map entry");
        if (name.empty())
          return refuse(KATA_E_INVALID_ARGUMENT, size,
                        std::string(call) + ": name_map[" + std::to_string(g) + "] is NULL or empty");
        d.name_map.push_back(name);
      }
    }
    d.up_axis = m.up_axis == KATA_UP_Z ? kata::UpAxis::kZ : kata::UpAxis::kY;
    d.metres_per_unit = m.metres_per_unit;
    d.frame_rate = m.frame_rate;
    d.closed = m.closed != 0;
    return deliver(call, thread_encoder().skeleton(d), buffer, capacity, size);
  });
}

KATA_API kata_status kata_message_write_frame(const kata_frame_message* message, void* buffer, size_t capacity,
                                              size_t* size) {
  static const char* const call = "kata_message_write_frame";
  kata_frame_message m;
  if (const kata_status s = check_call(call, message, buffer, capacity, size, kata::capi::kFrameMessage11,
                                       frame_message_defaults(), &m))
    return s;
  if (const kata_status s = check_frame(call, m, size)) return s;
  return kata::capi::guarded_context([&] {
    const kata::transport::Encoder::BatchFrame f = batch_frame_of(m);
    return deliver(call, thread_encoder().frame(f.stream_id, f.sequence, f.capture_ns, f.xyz, f.joints, f.confidence, f.presence),
                   buffer, capacity, size);
  });
}

KATA_API kata_status kata_message_write_frame_batch(const kata_frame_message* const* frames, size_t frame_count,
                                                    void* buffer, size_t capacity, size_t* size) {
  static const char* const call = "kata_message_write_frame_batch";
  if (!size) return KATA_E_NULL_POINTER;
  *size = 0;
  if (!frames || (!buffer && capacity > 0))
    return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": frames and size must not be NULL, nor buffer with a capacity");
  if (frame_count < 1 || frame_count > kata::transport::kMaxBatchFrames)
    return refuse(KATA_E_INVALID_ARGUMENT, size,
                  std::string(call) + ": frame_count " + std::to_string(frame_count) + " (1.." +
                      std::to_string(kata::transport::kMaxBatchFrames) + ")");
  return kata::capi::guarded_context([&] {
    // The thread's list of frames, grown to its largest batch (as its encoder is).
    thread_local std::vector<kata::transport::Encoder::BatchFrame> batch;
    batch.resize(frame_count);
    for (size_t i = 0; i < frame_count; ++i) {
      const std::string frame_call = std::string(call) + ": frame " + std::to_string(i);
      kata_frame_message m;
      if (!frames[i])
        return refuse(KATA_E_NULL_POINTER, size, frame_call + " is NULL");
      if (const kata_status s = check_call(frame_call.c_str(), frames[i], buffer, capacity, size,
                                           kata::capi::kFrameMessage11, frame_message_defaults(), &m))
        return s;
      if (const kata_status s = check_frame(frame_call.c_str(), m, size)) return s;
      batch[i] = batch_frame_of(m);
    }
    return deliver(call, thread_encoder().frame_batch(batch.data(), frame_count), buffer, capacity, size);
  });
}

KATA_API kata_status kata_message_write_result(const kata_result_record* record, void* buffer, size_t capacity,
                                               size_t* size) {
  static const char* const call = "kata_message_write_result";
  if (!size) return KATA_E_NULL_POINTER;
  *size = 0;
  if (!record || (!buffer && capacity > 0))
    return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": record and size must not be NULL, nor buffer with a capacity");
  if (record->struct_size < kata::capi::kResultRecord10)
    return refuse(KATA_E_INVALID_ARGUMENT, size,
                  std::string(call) + ": record->struct_size " + std::to_string(record->struct_size) +
                      " is below 1.0's kata_result_record (" + std::to_string(kata::capi::kResultRecord10) + ")");
  kata::transport::ResultFields f;  // a smaller record's later fields keep their "none" defaults
  kata::pipeline::copy_record_in(record, &f);
  if (f.ghost_joint_count > 0 && !f.ghost)
    return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": ghost_joint_count " +
                                                 std::to_string(f.ghost_joint_count) + " with no ghost");
  if (f.ghost_joint_count > (1u << 20))
    return refuse(KATA_E_INVALID_ARGUMENT, size,
                  std::string(call) + ": ghost_joint_count " + std::to_string(f.ghost_joint_count) + " (at most 1048576)");
  if (!f.ghost) f.ghost_joint_count = 0;
  for (uint32_t i = 0; i < 3 * f.ghost_joint_count; ++i)
    if (!std::isfinite(f.ghost[i]))
      return refuse(KATA_E_NON_FINITE, size,
                    std::string(call) + ": ghost joint " + std::to_string(i / 3) + " is not finite");
  if (!std::isfinite(f.distance) || !std::isfinite(f.score) || !std::isfinite(f.matched_teacher_time) ||
      !std::isfinite(f.practice_start_time) || !std::isfinite(f.practice_end_time))
    return refuse(KATA_E_NON_FINITE, size, std::string(call) + ": a time, distance or score is not finite");
  return kata::capi::guarded_context([&] { return deliver(call, thread_encoder().result(f), buffer, capacity, size); });
}

KATA_API kata_status kata_message_write_repetition(const kata_repetition* repetition, void* buffer, size_t capacity,
                                                   size_t* size) {
  static const char* const call = "kata_message_write_repetition";
  kata_repetition r;
  kata_repetition defaults{};
  defaults.part_to_fix = defaults.cue_joint = defaults.cue_action = -1;
  // kata_repetition's first size is its whole struct as first released.
  if (const kata_status s = check_call(call, repetition, buffer, capacity, size,
                                       static_cast<uint32_t>(sizeof(kata_repetition)), defaults, &r))
    return s;
  bool finite = std::isfinite(r.start_time) && std::isfinite(r.end_time) && std::isfinite(r.tempo) &&
                std::isfinite(r.score) && std::isfinite(r.cue_degrees) && std::isfinite(r.coverage);
  for (int i = 0; i < KATA_ROM_JOINT_COUNT; ++i) finite = finite && std::isfinite(r.range[i]) && std::isfinite(r.teacher_range[i]);
  if (!finite) return refuse(KATA_E_NON_FINITE, size, std::string(call) + ": a time, tempo, score or range is not finite");
  return kata::capi::guarded_context(
      [&] { return deliver(call, thread_encoder().repetition(r, kata::pipeline::now_ns()), buffer, capacity, size); });
}

KATA_API kata_status kata_message_write_practice(const kata_practice_message* message, void* buffer, size_t capacity,
                                                 size_t* size) {
  static const char* const call = "kata_message_write_practice";
  kata_practice_message m;
  if (const kata_status s = check_call(call, message, buffer, capacity, size, kata::capi::kPracticeMessage11,
                                       practice_message_defaults(), &m))
    return s;
  if (m.loop != 0 && m.loop != 1) return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": loop is 0 or 1");
  kata::transport::PracticeSetting p;
  p.stream_id = m.stream_id;
  p.revision = m.revision;
  p.teacher_start = m.teacher_start;
  p.loop = m.loop != 0;
  p.loop_start = m.loop_start;
  p.loop_end = m.loop_end;
  char why[192];
  if (kata::transport::practice_values_problem(p, why, sizeof why))
    return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": " + why);
  return kata::capi::guarded_context(
      [&] { return deliver(call, thread_encoder().practice(p), buffer, capacity, size); });
}

}  // extern "C"
