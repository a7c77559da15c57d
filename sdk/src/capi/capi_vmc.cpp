// C ABI: VMC out (a humanoid pose -> one OSC bundle) and VMC in (datagrams -> the "vrm" layout's
// joints) over transport/vmc (kata/vmc.h).
#include <chrono>
#include <cmath>
#include <string>

#include "capi/capi_internal.hpp"
#include "kata/vmc.h"
#include "transport/vmc/vmc.hpp"

struct kata_vmc_reader_s {
  explicit kata_vmc_reader_s(size_t max_packet) : reader(max_packet) {}
  kata::vmc::Reader reader;
  char error[256] = {0};
  void set_error(const char* message) noexcept { std::snprintf(error, sizeof error, "%s", message); }
};

namespace {

constexpr uint32_t kMaxVmcPacket = 1u << 20;
// The pose struct as it was first released (every field of it: the struct is 1.1's).
constexpr uint32_t kHumanoidPose11 = KATA_CAPI_END_OF(kata_humanoid_pose, offset);

kata_status refuse(kata_status status, size_t* size, const std::string& message) {
  if (size) *size = 0;
  kata::capi::set_context_error(message.c_str());
  return status;
}

bool finite3(const float* v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// NTP time now, 32.32 fixed point (seconds since 1900).
uint64_t ntp_now() {
  const auto since = std::chrono::system_clock::now().time_since_epoch();
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(since).count();
  const uint64_t sec = static_cast<uint64_t>(ns / 1000000000) + 2208988800ull;
  const uint64_t frac = (static_cast<uint64_t>(ns % 1000000000) << 32) / 1000000000ull;
  return (sec << 32) | (frac & 0xffffffffull);
}

}  // namespace

KATA_API kata_status kata_vmc_write_pose(const kata_humanoid_pose* pose, double time, float metres_per_unit,
                                         void* buffer, size_t capacity, size_t* size) {
  static const char* const call = "kata_vmc_write_pose";
  if (!pose || !size || (!buffer && capacity))
    return refuse(KATA_E_NULL_POINTER, size, std::string(call) + ": pose, size or buffer is NULL");
  kata_humanoid_pose p{};
  if (!kata::capi::read_sized(pose, p, kHumanoidPose11, &p))
    return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": pose->struct_size is below the struct's");
  if (p.frame != KATA_HUMANOID_RIGHT_HANDED && p.frame != KATA_HUMANOID_UNITY)
    return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": unknown frame " + std::to_string(p.frame));
  if (!(metres_per_unit > 0.0f) || !std::isfinite(metres_per_unit))
    return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": metres_per_unit must be > 0 and finite");
  if (!(p.placed & (1u << KATA_BONE_HIPS)))
    return refuse(KATA_E_INVALID_ARGUMENT, size, std::string(call) + ": the Hips are not placed");
  if (!std::isfinite(time)) return refuse(KATA_E_NON_FINITE, size, std::string(call) + ": time is not finite");
  if (!finite3(p.hips_position))
    return refuse(KATA_E_NON_FINITE, size, std::string(call) + ": hips_position is not finite");
  // Parents before children: bones by their depth in the humanoid tree.
  int depth[KATA_BONE_COUNT];
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    depth[b] = 0;
    for (int a = kata_humanoid_bone_parent(b); a >= 0 && depth[b] < KATA_BONE_COUNT;
         a = kata_humanoid_bone_parent(a))
      ++depth[b];
  }
  // Sent: the placed bones, and every bone between two of them (not placed: the identity and a
  // zero offset, as the rig's forward kinematics passes through it, so that a receiver's does too).
  uint32_t sent = p.placed;
  for (int b = 0; b < KATA_BONE_COUNT; ++b)
    if (p.placed & (1u << b))
      for (int a = kata_humanoid_bone_parent(b); a >= 0; a = kata_humanoid_bone_parent(a)) sent |= 1u << a;
  static const float kIdentity[4] = {0.0f, 0.0f, 0.0f, 1.0f}, kZero[3] = {0.0f, 0.0f, 0.0f};
  const bool mirror = p.frame == KATA_HUMANOID_RIGHT_HANDED;
  kata::vmc::Bone bones[KATA_BONE_COUNT];
  size_t count = 0;
  for (int d = 0; d <= KATA_BONE_COUNT; ++d)
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      if (depth[b] != d || !(sent & (1u << b))) continue;
      const bool placed = (p.placed & (1u << b)) != 0;
      const float* q = placed ? p.rotation[b] : kIdentity;
      const float* at = b == KATA_BONE_HIPS ? p.hips_position : placed ? p.offset[b] : kZero;
      if (!finite3(at) || !finite3(q) || !std::isfinite(q[3]))
        return refuse(KATA_E_NON_FINITE, size,
                      std::string(call) + ": bone " + kata_humanoid_bone_name(b) +
                          " has a NaN or infinite value");
      kata::vmc::Bone& out = bones[count++];
      out.name = kata_humanoid_bone_name(b);
      out.position[0] = (mirror ? -at[0] : at[0]) * metres_per_unit;
      out.position[1] = at[1] * metres_per_unit;
      out.position[2] = at[2] * metres_per_unit;
      out.rotation[0] = q[0];
      out.rotation[1] = mirror ? -q[1] : q[1];
      out.rotation[2] = mirror ? -q[2] : q[2];
      out.rotation[3] = q[3];
    }
  return kata::capi::guarded_context([&] {
    const size_t need = kata::vmc::write_bundle(bones, count, time, ntp_now(), buffer, capacity);
    *size = need;
    if (need > capacity) {
      kata::capi::set_context_error((std::string(call) + ": the bundle needs " + std::to_string(need) + " bytes").c_str());
      return KATA_E_BUFFER_TOO_SMALL;
    }
    return KATA_OK;
  });
}

KATA_API kata_status kata_vmc_reader_create(kata_context context, uint32_t max_packet_bytes, kata_vmc_reader* out) {
  if (!context || !out) return KATA_E_NULL_POINTER;
  *out = nullptr;
  kata::capi::ContextScope scope(context);
  return kata::capi::guarded_context([&] {
    if (max_packet_bytes > kMaxVmcPacket)
      throw kata::Error(kata::ErrorKind::kInvalidArgument, "kata_vmc_reader_create: max_packet_bytes above 1 MiB");
    *out = new kata_vmc_reader_s(max_packet_bytes ? max_packet_bytes : KATA_VMC_DEFAULT_MAX_PACKET);
    return KATA_OK;
  });
}

KATA_API void kata_vmc_reader_destroy(kata_vmc_reader reader) { delete reader; }

KATA_API kata_status kata_vmc_reader_read(kata_vmc_reader reader, const void* packet, size_t size, double arrival_time,
                                          int32_t* frame) {
  if (!reader || !frame) return KATA_E_NULL_POINTER;
  *frame = 0;
  if (!packet && size) {
    reader->set_error("kata_vmc_reader_read: packet is NULL");
    return KATA_E_NULL_POINTER;
  }
  return kata::capi::guarded([reader](const char* m) { reader->set_error(m); }, [&] {
    *frame = reader->reader.read(packet, size, arrival_time) ? 1 : 0;
    return KATA_OK;
  });
}

KATA_API kata_status kata_vmc_reader_positions(kata_vmc_reader reader, float* out, size_t capacity,
                                               double* capture_time) {
  if (!reader || !out) return KATA_E_NULL_POINTER;
  if (capacity < 3 * static_cast<size_t>(KATA_VMC_JOINTS)) {
    reader->set_error("kata_vmc_reader_positions: capacity below 3 x KATA_VMC_JOINTS floats");
    return KATA_E_BUFFER_TOO_SMALL;
  }
  if (reader->reader.counters().frames == 0) return KATA_NO_DATA;
  std::memcpy(out, reader->reader.positions(), sizeof(float) * 3 * KATA_VMC_JOINTS);
  if (capture_time) *capture_time = reader->reader.capture_time();
  return KATA_OK;
}

KATA_API kata_status kata_vmc_reader_get_counters(kata_vmc_reader reader, kata_vmc_counters* out) {
  if (!reader || !out) return KATA_E_NULL_POINTER;
  const kata::vmc::Counters& c = reader->reader.counters();
  kata_vmc_counters v{};
  v.struct_size = sizeof v;
  v.packets = c.packets;
  v.frames = c.frames;
  v.malformed = c.malformed;
  v.oversized = c.oversized;
  v.wrong_type = c.wrong_type;
  v.unknown_bone = c.unknown_bone;
  v.bad_value = c.bad_value;
  v.out_of_order = c.out_of_order;
  v.ignored = c.ignored;
  if (!kata::capi::write_sized(v, KATA_CAPI_END_OF(kata_vmc_counters, ignored), out)) {
    reader->set_error("kata_vmc_reader_get_counters: out->struct_size is below the struct's");
    return KATA_E_INVALID_ARGUMENT;
  }
  return KATA_OK;
}

KATA_API const char* kata_vmc_reader_last_error(kata_vmc_reader reader) { return reader ? reader->error : ""; }

static_assert(KATA_VMC_JOINTS == kata::kVrmJointCount, "kata/vmc.h's joint count is the vrm layout's");
