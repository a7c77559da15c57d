// C shims for the people tracker (kata/people.h): a kata_people wraps one kata::people::Tracker;
// the shim checks pointers and sizes and copies out, the tracker does the rest.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "capi/capi_internal.hpp"
#include "people/tracker.hpp"
#include "transport/people_frame.hpp"

struct kata_people_s {
  explicit kata_people_s(const kata::people::TrackerConfig& config) : tracker(config) {}
  kata::people::Tracker tracker;
  char error[256] = {0};

  // Copies a message into the fixed buffer (no allocation: used on the frame path).
  void set_error(const char* message) noexcept { std::snprintf(error, sizeof error, "%s", message); }
};

namespace {

// The structs as 1.1 released them (capi/struct_size.hpp: never change these).
constexpr uint32_t kPeopleDesc11 = KATA_CAPI_END_OF(kata_people_desc, min_confidence);
constexpr uint32_t kPeopleCounters11 = KATA_CAPI_END_OF(kata_people_counters, refused_table_full);
constexpr uint32_t kPeopleFrameMessage11 = KATA_CAPI_END_OF(kata_people_frame_message, confidences);

// The defaults people.h lists for kata_people_desc.
kata_people_desc people_desc_defaults() {
  kata_people_desc d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  const kata::people::TrackerConfig c;
  d.joint_count = 0;
  d.max_people = static_cast<uint32_t>(c.max_people);
  d.max_poses = static_cast<uint32_t>(c.max_poses);
  d.forget_seconds = c.forget_seconds;
  d.coast_seconds = c.coast_seconds;
  d.gate = c.gate;
  d.gate_growth = c.gate_growth;
  d.size_gate = c.size_gate;
  d.shape_weight = c.shape_weight;
  d.min_confidence = c.min_confidence;
  return d;
}

// An id list out (opened, closed, open streams).
kata_status copy_ids(kata_people p, const uint32_t* ids, int n, uint32_t* out, size_t capacity, uint32_t* count,
                     const char* call) {
  if (count) *count = static_cast<uint32_t>(n);
  if (n > 0 && !out) {
    p->set_error((std::string(call) + ": ids must not be NULL").c_str());
    return capacity == 0 ? KATA_E_BUFFER_TOO_SMALL : KATA_E_NULL_POINTER;
  }
  const size_t k = std::min(static_cast<size_t>(n), capacity);
  if (k > 0) std::memcpy(out, ids, k * sizeof(uint32_t));
  if (k < static_cast<size_t>(n)) {
    std::snprintf(p->error, sizeof p->error, "%s: %d ids, room for %zu", call, n, capacity);
    return KATA_E_BUFFER_TOO_SMALL;
  }
  return KATA_OK;
}

}  // namespace

extern "C" {

KATA_API void kata_people_desc_init_sized(kata_people_desc* desc, uint32_t struct_size) {
  kata::capi::init_sized(desc, struct_size, people_desc_defaults());
}

KATA_API kata_status kata_people_create(kata_context context, const kata_people_desc* desc, kata_people* out) {
  const kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (!context || !desc || !out) {
      kata::capi::set_context_error("kata_people_create: context, desc and out must not be NULL");
      return KATA_E_NULL_POINTER;
    }
    *out = nullptr;
    const kata_people_desc defaults = people_desc_defaults();
    kata_people_desc d = defaults;
    if (!kata::capi::read_sized(desc, defaults, kPeopleDesc11, &d)) {
      kata::capi::set_context_error(
          "kata_people_create: desc->struct_size is below 1.1's kata_people_desc (call kata_people_desc_init)");
      return KATA_E_INVALID_ARGUMENT;
    }
    if (d.joint_count == 0) {
      kata::capi::set_context_error("kata_people_create: desc->joint_count must be set (the joints of one pose)");
      return KATA_E_INVALID_ARGUMENT;
    }
    kata::people::TrackerConfig c;
    const auto clamp = [](uint32_t v) { return static_cast<int>(std::min<uint32_t>(v, 1u << 20)); };
    c.joints = clamp(d.joint_count);
    c.max_people = clamp(d.max_people);
    c.max_poses = clamp(d.max_poses);
    c.forget_seconds = d.forget_seconds;
    c.coast_seconds = d.coast_seconds;
    c.gate = d.gate;
    c.gate_growth = d.gate_growth;
    c.size_gate = d.size_gate;
    c.shape_weight = d.shape_weight;
    c.min_confidence = d.min_confidence;
    *out = std::make_unique<kata_people_s>(c).release();  // the tracker checks the ranges (kata::Error)
    return KATA_OK;
  });
}

KATA_API void kata_people_destroy(kata_people people) { delete people; }

KATA_API const char* kata_people_last_error(kata_people people) { return people ? people->error : ""; }

KATA_API kata_status kata_people_track(kata_people people, double time, const float* xyz, const float* confidence,
                                       uint32_t pose_count, uint32_t* ids, size_t capacity) {
  if (!people) return KATA_E_NULL_POINTER;
  if (pose_count > 0 && (!xyz || !ids)) {
    people->set_error("kata_people_track: xyz and ids must not be NULL when pose_count > 0");
    return KATA_E_NULL_POINTER;
  }
  if (capacity < pose_count) {
    std::snprintf(people->error, sizeof people->error, "kata_people_track: %u poses, room for %zu ids", pose_count,
                  capacity);
    return KATA_E_BUFFER_TOO_SMALL;
  }
  if (pose_count > static_cast<uint32_t>(INT32_MAX)) {
    people->set_error("kata_people_track: pose_count is beyond any frame");
    return KATA_E_INVALID_ARGUMENT;
  }
  switch (people->tracker.track(time, xyz, confidence, static_cast<int>(pose_count), ids)) {
    case kata::people::Frame::kTaken:
      return KATA_OK;
    case kata::people::Frame::kTimeNotFinite:
      people->set_error("kata_people_track: time is not finite");
      return KATA_E_NON_FINITE;
    case kata::people::Frame::kTimeNotIncreasing:
      break;
  }
  std::snprintf(people->error, sizeof people->error, "kata_people_track: time %.9g is not after the previous frame's",
                time);
  return KATA_E_TIMESTAMP_NOT_INCREASING;
}

KATA_API kata_status kata_people_opened(kata_people people, uint32_t* ids, size_t capacity, uint32_t* count) {
  if (!people) return KATA_E_NULL_POINTER;
  const auto& t = people->tracker;
  return copy_ids(people, t.opened(), t.opened_count(), ids, capacity, count, "kata_people_opened");
}

KATA_API kata_status kata_people_closed(kata_people people, uint32_t* ids, size_t capacity, uint32_t* count) {
  if (!people) return KATA_E_NULL_POINTER;
  const auto& t = people->tracker;
  return copy_ids(people, t.closed(), t.closed_count(), ids, capacity, count, "kata_people_closed");
}

KATA_API kata_status kata_people_streams(kata_people people, uint32_t* ids, size_t capacity, uint32_t* count) {
  if (!people) return KATA_E_NULL_POINTER;
  uint32_t open[kata::people::kMaxPeople];
  const int n = people->tracker.open_streams(open, kata::people::kMaxPeople);
  return copy_ids(people, open, n, ids, capacity, count, "kata_people_streams");
}

KATA_API kata_status kata_people_predicted(kata_people people, uint32_t id, double time, double* centroid) {
  if (!people) return KATA_E_NULL_POINTER;
  if (!centroid) {
    people->set_error("kata_people_predicted: centroid must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  if (!std::isfinite(time)) {
    people->set_error("kata_people_predicted: time is not finite");
    return KATA_E_NON_FINITE;
  }
  if (!people->tracker.predicted(id, time, centroid)) {
    std::snprintf(people->error, sizeof people->error, "kata_people_predicted: no open stream %u", id);
    return KATA_E_NOT_FOUND;
  }
  return KATA_OK;
}

KATA_API kata_status kata_people_get_counters(kata_people people, kata_people_counters* counters) {
  if (!people) return KATA_E_NULL_POINTER;
  if (!counters) {
    people->set_error("kata_people_get_counters: counters must not be NULL");
    return KATA_E_NULL_POINTER;
  }
  const kata::people::TrackerCounters& c = people->tracker.counters();
  kata_people_counters v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.open_streams = static_cast<uint32_t>(people->tracker.open_streams(nullptr, 0));
  v.frames = c.frames;
  v.empty_frames = c.empty_frames;
  v.refused_frames = c.refused_frames;
  v.poses = c.poses;
  v.assigned = c.assigned;
  v.opened = c.opened;
  v.closed = c.closed;
  v.refused_non_finite = c.refused_non_finite;
  v.refused_out_of_range = c.refused_out_of_range;
  v.refused_few_joints = c.refused_few_joints;
  v.refused_too_many_poses = c.refused_too_many_poses;
  v.refused_table_full = c.refused_table_full;
  if (!kata::capi::write_sized(v, kPeopleCounters11, counters)) {
    people->set_error("kata_people_get_counters: counters->struct_size is below 1.1's kata_people_counters");
    return KATA_E_INVALID_ARGUMENT;
  }
  return KATA_OK;
}

KATA_API void kata_people_frame_message_init_sized(kata_people_frame_message* message, uint32_t struct_size) {
  kata_people_frame_message d;
  std::memset(&d, 0, sizeof d);
  d.struct_size = sizeof d;
  kata::capi::init_sized(message, struct_size, d);
}

KATA_API kata_status kata_message_write_people_frame(const kata_people_frame_message* message, void* buffer,
                                                     size_t capacity, size_t* size) {
  static const char* const call = "kata_message_write_people_frame";
  if (!size) return KATA_E_NULL_POINTER;
  *size = 0;
  const auto refuse = [&](kata_status status, const std::string& why) {
    kata::capi::set_context_error((std::string(call) + ": " + why).c_str());
    return status;
  };
  if (!message || (!buffer && capacity > 0))
    return refuse(KATA_E_NULL_POINTER, "message and size must not be NULL, nor buffer with a capacity");
  kata_people_frame_message defaults;
  std::memset(&defaults, 0, sizeof defaults);
  kata_people_frame_message m;
  if (!kata::capi::read_sized(message, defaults, kPeopleFrameMessage11, &m))
    return refuse(KATA_E_INVALID_ARGUMENT, "struct_size " + std::to_string(message->struct_size) +
                                               " is below the struct's first size (kata_people_frame_message_init)");
  if (m.joint_count < 1 || m.joint_count > (1u << 20))
    return refuse(KATA_E_WRONG_JOINT_COUNT, "joint_count " + std::to_string(m.joint_count) + " (1..1048576)");
  if (m.pose_count > KATA_MAX_PEOPLE_POSES)
    return refuse(KATA_E_INVALID_ARGUMENT, "pose_count " + std::to_string(m.pose_count) + " (0..64)");
  if (m.pose_count > 0 && !m.positions) return refuse(KATA_E_NULL_POINTER, "no positions");
  if (!std::isfinite(m.capture_time)) return refuse(KATA_E_NON_FINITE, "capture_time is not finite");
  if (std::fabs(m.capture_time) > 9.2e9)
    return refuse(KATA_E_INVALID_ARGUMENT, "capture_time beyond +-9.2e9 s (the wire's int64 nanoseconds)");
  return kata::capi::guarded_context([&] {
    thread_local std::vector<uint8_t> bytes;
    kata::transport::encode_people_frame(m.stream_id, m.sequence, static_cast<int64_t>(std::round(m.capture_time * 1e9)),
                                         static_cast<int>(m.joint_count), static_cast<int>(m.pose_count), m.positions,
                                         m.confidences, &bytes);
    *size = bytes.size();
    if (capacity < bytes.size()) {
      kata::capi::set_context_error((std::string(call) + ": the message needs " + std::to_string(bytes.size()) +
                                     " bytes, the buffer holds " + std::to_string(capacity))
                                        .c_str());
      return KATA_E_BUFFER_TOO_SMALL;
    }
    std::memcpy(buffer, bytes.data(), bytes.size());
    return KATA_OK;
  });
}

KATA_API uint64_t kata_people_stream_id(uint64_t group, uint32_t person) {
  return kata::transport::person_stream_id(group, person);
}

}  // extern "C"
