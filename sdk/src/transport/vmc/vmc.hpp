// The VMC protocol (protocol.vmc.info, "Virtual Motion Capture Protocol"): OSC over UDP, one
// bundle per frame, built and taken apart with liblo (OSC messages: lo_message_* and
// lo_bundle_*). kata/vmc.h is the public face; this is the C++ behind it.
//
// What kata reads and writes of the protocol (the rest, blend shapes, devices, cameras, is
// counted as ignored):
//   /VMC/Ext/Root/Pos  s name, f p.x p.y p.z, f q.x q.y q.z q.w  (v2.1's 6 more floats: scale and
//                      offset, read and not used)
//   /VMC/Ext/Bone/Pos  s bone (Unity HumanBodyBones name), f p.x p.y p.z (local position: the
//                      offset from the parent bone's joint), f q.x q.y q.z q.w (local rotation)
//   /VMC/Ext/OK        i 1 (loaded)
//   /VMC/Ext/T         f time, seconds
// Positions and rotations are in Unity's frame: left-handed, +Y up, an avatar facing +Z with its
// left side at -X; rotations are relative to the avatar's T-pose (VRM's normalised bones).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "skeleton/skeleton.hpp"

namespace kata::vmc {

// What a reader counted since it was made (kata_vmc_counters says each).
struct Counters {
  uint64_t packets = 0, frames = 0, malformed = 0, oversized = 0, wrong_type = 0, unknown_bone = 0, bad_value = 0,
           out_of_order = 0, ignored = 0;
};

// Reads VMC packets (UDP datagrams: one OSC bundle or message each) into the pose of a VRM
// skeleton (kVrmJoints) and its joint positions by forward kinematics.
// Frames: a packet that carries /VMC/Ext/T ends a frame (a performer sends it once per frame); a
// sender that never sends it ends one with every packet that carries a bone or the root.
// A frame's time: the packet's /VMC/Ext/T, else its bundle's timetag (not "immediately"), else the
// arrival time; a time beyond +-1e10 s is a bad value; a time not after the previous frame's
// (within 1 s) is out of order: the packet is dropped whole; a jump back of more than 1 s is a
// restarted sender: its times are shifted to follow on.
// A malformed packet (not OSC, truncated, bundles nested deeper than 8) or an oversized one
// (above max_packet_bytes, or more than 1024 elements) changes nothing. Within a good packet, a
// message with unexpected argument types, an unknown bone, or a value that is not finite (or a
// zero quaternion, a coordinate beyond 10 km) is skipped and counted; the others are taken.
// Bones never named by the sender keep the T-pose (identity). Offsets: the local positions the
// sender sends, once it has sent one that is not zero (the Hips' aside: its avatar's own
// proportions; a zero one then places a joint on its parent); a sender that sends only zeros
// sends rotations only, and gets kVrmRestOffsets. An optional bone the sender never names is
// collapsed onto its parent (its avatar lacks it). The Hips' position is always the sender's.
// Memory: everything is allocated by the constructor except what liblo allocates while it takes
// a message apart (lo_message_deserialise). One thread at a time.
class Reader {
 public:
  static constexpr size_t kMaxElements = 1024;
  static constexpr int kMaxDepth = 8;
  static constexpr float kMaxCoordinate = 1.0e4f;  // metres
  static constexpr double kMaxTime = 1.0e10;       // seconds: a sender's time beyond is a bad value

  explicit Reader(size_t max_packet_bytes);

  // Reads one datagram; true when it ended a frame (positions() and capture_time() are then its).
  // arrival_time: seconds on the caller's clock (for senders without times).
  bool read(const void* packet, size_t size, double arrival_time);

  // The newest frame: kVrmJointCount x 3 floats, metres, in a right-handed +Y-up frame (Unity's x
  // negated: the avatar faces +Z with its left side at +X, as a CMU BVH), the "vrm" layout's joint
  // order.
  const float* positions() const { return positions_.data(); }
  double capture_time() const { return capture_time_; }
  // The newest frame's local rotations (x y z w) and offsets (metres), Unity's frame, per joint.
  const std::array<std::array<float, 4>, kVrmJointCount>& rotations() const { return state_.rotation; }
  const std::array<std::array<float, 3>, kVrmJointCount>& offsets() const { return offsets_; }
  const Counters& counters() const { return counters_; }
  size_t max_packet_bytes() const { return max_packet_bytes_; }

 private:
  struct State {
    std::array<std::array<float, 4>, kVrmJointCount> rotation{};
    std::array<std::array<float, 3>, kVrmJointCount> position{};
    std::array<uint8_t, kVrmJointCount> named{};  // 1: the sender named the bone
    bool positions_given = false;  // the sender has sent a non-zero local position (not the Hips')
    std::array<float, 3> root_position{};
    std::array<float, 4> root_rotation{};
  };
  struct Packet {  // what one packet says, before it is taken
    bool framed = false;     // carries bone or root data
    bool has_time = false;   // /VMC/Ext/T
    double time = 0.0;
    bool has_timetag = false;
    double timetag = 0.0;
  };
  bool element(const uint8_t* data, size_t size, int depth, size_t& elements, Packet& p);
  void message(const uint8_t* data, size_t size, Packet& p);
  void forward_kinematics();

  size_t max_packet_bytes_;
  std::vector<uint8_t> copy_;  // the datagram, copied (max_packet_bytes_)
  State state_, pending_;
  std::array<std::array<float, 3>, kVrmJointCount> offsets_{};
  std::array<float, 3 * kVrmJointCount> positions_{};
  Counters counters_, pending_counts_;
  bool seen_time_ = false;  // the sender sends /VMC/Ext/T
  bool has_frame_ = false;
  double capture_time_ = 0.0, last_source_time_ = 0.0, shift_ = 0.0, last_step_ = 1.0 / 60.0;
};

// One VMC frame to write: the pose of a humanoid's bones in Unity's frame.
struct Bone {
  const char* name;      // Unity HumanBodyBones name
  float position[3];     // local position (offset from the parent's joint), metres
  float rotation[4];     // local rotation x y z w
};

// Writes one frame's bundle (timetag `timetag_ntp`, NTP 32.32 fixed point; 1 = immediately):
// /VMC/Ext/Root/Pos "root" at the origin, /VMC/Ext/Bone/Pos per bone, /VMC/Ext/OK 1,
// /VMC/Ext/T time. Returns the bundle's size; writes it when it fits in capacity (else nothing).
// Throws kata::Error(kInvalidArgument) when liblo cannot build it (out of memory).
size_t write_bundle(const Bone* bones, size_t count, double time, uint64_t timetag_ntp, void* buffer, size_t capacity);

}  // namespace kata::vmc
