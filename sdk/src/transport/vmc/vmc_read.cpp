// VMC in: datagrams -> the pose of a VRM skeleton -> joint positions (vmc.hpp says what is read
// and how a bad packet is counted). OSC messages are taken apart by liblo
// (lo_message_deserialise validates the address, the type tags, the strings and every argument's
// size); the bundle's frame (its "#bundle" header, timetag and the size of each element) is read
// here so that its elements and nesting are bounded before liblo sees them.
#include <lo/lo.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>

#include "transport/vmc/vmc.hpp"

namespace kata::vmc {

namespace {

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

// The index of a VRM bone by its Unity name, -1 for another name.
int bone_index(const char* name) {
  for (int j = 0; j < kVrmJointCount; ++j)
    if (std::strcmp(name, kVrmJoints[static_cast<size_t>(j)]) == 0) return j;
  return -1;
}

// liblo's lo_arg pointers point into the message at 4-byte alignment, but lo_arg is a union with
// 8-byte members: its fields are read by copying, never through the union (UBSan: misaligned).
float float_arg(const lo_arg* a) {
  float v;
  std::memcpy(&v, a, sizeof v);
  return v;
}
const char* string_arg(const lo_arg* a) { return reinterpret_cast<const char*>(a); }

bool finite_all(const float* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

// Seven floats (a position and a quaternion) from argv[1..7], checked: finite, the position within
// Reader::kMaxCoordinate, the quaternion not zero (normalised here). False: a bad value.
bool pose_args(lo_arg** argv, float* p, float* q) {
  for (int k = 0; k < 3; ++k) p[k] = float_arg(argv[1 + k]);
  for (int k = 0; k < 4; ++k) q[k] = float_arg(argv[4 + k]);
  if (!finite_all(p, 3) || !finite_all(q, 4)) return false;
  for (int k = 0; k < 3; ++k)
    if (std::fabs(p[k]) > Reader::kMaxCoordinate) return false;
  const double n = std::sqrt(double{q[0]} * q[0] + double{q[1]} * q[1] + double{q[2]} * q[2] + double{q[3]} * q[3]);
  if (!(n > 1e-6) || !std::isfinite(n)) return false;
  for (int k = 0; k < 4; ++k) q[k] = static_cast<float>(q[k] / n);
  return true;
}

}  // namespace

Reader::Reader(size_t max_packet_bytes) : max_packet_bytes_(max_packet_bytes), copy_(max_packet_bytes) {
  for (auto& q : state_.rotation) q = {0.0f, 0.0f, 0.0f, 1.0f};
  state_.root_rotation = {0.0f, 0.0f, 0.0f, 1.0f};
  forward_kinematics();
}

bool Reader::read(const void* packet, size_t size, double arrival_time) {
  ++counters_.packets;
  if (size > max_packet_bytes_) {
    ++counters_.oversized;
    return false;
  }
  if (size == 0 || !packet) {
    ++counters_.malformed;
    return false;
  }
  std::memcpy(copy_.data(), packet, size);
  pending_ = state_;
  pending_counts_ = Counters{};
  Packet p;
  size_t elements = 0;
  if (!element(copy_.data(), size, 0, elements, p)) {
    if (elements > kMaxElements) ++counters_.oversized;
    else ++counters_.malformed;
    return false;
  }
  // The packet is well-formed: its skipped messages count now, whatever happens to the frame.
  counters_.wrong_type += pending_counts_.wrong_type;
  counters_.unknown_bone += pending_counts_.unknown_bone;
  counters_.bad_value += pending_counts_.bad_value;
  counters_.ignored += pending_counts_.ignored;
  if (p.has_time) seen_time_ = true;
  const bool ends_frame = p.has_time || (p.framed && !seen_time_);
  if (!ends_frame) {
    if (p.framed) state_ = pending_;  // bones of a frame a later packet ends
    return false;
  }
  const double source = p.has_time ? p.time : p.has_timetag ? p.timetag : arrival_time;
  if (!std::isfinite(source) || std::fabs(source) > kMaxTime) {
    ++counters_.bad_value;
    return false;
  }
  double t = source + shift_;
  if (has_frame_ && !(t > capture_time_)) {
    if (capture_time_ - t < 1.0) {
      ++counters_.out_of_order;
      return false;
    }
    const double before = shift_;
    shift_ += capture_time_ + last_step_ - t;  // the sender restarted its clock: follow on
    t = source + shift_;
    if (!(t > capture_time_) || std::fabs(shift_) > 4.0 * kMaxTime) {  // rounding near the bound: never back
      shift_ = before;
      ++counters_.out_of_order;
      return false;
    }
  }
  if (has_frame_) last_step_ = std::min(std::max(t - capture_time_, 1e-4), 1.0);
  last_source_time_ = source;
  state_ = pending_;
  capture_time_ = t;
  has_frame_ = true;
  forward_kinematics();
  ++counters_.frames;
  return true;
}

// One bundle element (or the whole packet): a bundle or a message. False: malformed (or more than
// kMaxElements elements: `elements` says so).
bool Reader::element(const uint8_t* data, size_t size, int depth, size_t& elements, Packet& p) {
  if (++elements > kMaxElements) return false;
  if (size >= 8 && std::memcmp(data, "#bundle", 8) == 0) {
    if (depth >= kMaxDepth || size < 16) return false;
    const uint32_t sec = be32(data + 8), frac = be32(data + 12);
    if (depth == 0 && !(sec == 0 && frac == 1)) {
      p.has_timetag = true;
      p.timetag = sec + frac / 4294967296.0;
    }
    size_t at = 16;
    while (at < size) {
      if (size - at < 4) return false;
      const uint32_t n = be32(data + at);
      at += 4;
      if (n == 0 || n % 4 != 0 || n > size - at) return false;
      if (!element(data + at, n, depth + 1, elements, p)) return false;
      at += n;
    }
    return true;
  }
  if (size < 4 || size % 4 != 0 || data[0] != '/') return false;
  message(data, size, p);
  return true;
}

// One OSC message: liblo takes it apart; what kata uses goes into pending_.
void Reader::message(const uint8_t* data, size_t size, Packet& p) {
  int result = 0;
  lo_message m = lo_message_deserialise(const_cast<uint8_t*>(data), size, &result);
  if (!m) {
    ++pending_counts_.wrong_type;  // a message liblo refuses: bad type tags or arguments
    return;
  }
  // liblo validated the address as a padded, terminated OSC string at the start of data.
  const char* address = reinterpret_cast<const char*>(data);
  const char* types = lo_message_get_types(m);
  const int argc = lo_message_get_argc(m);
  lo_arg** argv = lo_message_get_argv(m);
  const bool bone = std::strcmp(address, "/VMC/Ext/Bone/Pos") == 0;
  const bool root = std::strcmp(address, "/VMC/Ext/Root/Pos") == 0;
  if (bone || root) {
    // s + 7 floats; the root may carry v2.1's 6 more (scale, offset).
    bool typed = types && argc >= 8 && std::strncmp(types, "sfffffff", 8) == 0 && (argc == 8 || (root && argc == 14));
    for (int k = 8; typed && k < argc; ++k) typed = types[k] == 'f';
    if (!typed) {
      ++pending_counts_.wrong_type;
    } else {
      float pos[3], q[4];
      const int j = bone ? bone_index(string_arg(argv[0])) : 0;
      if (bone && j < 0) {
        ++pending_counts_.unknown_bone;
      } else if (!pose_args(argv, pos, q)) {
        ++pending_counts_.bad_value;
      } else if (root) {
        pending_.root_position = {pos[0], pos[1], pos[2]};
        pending_.root_rotation = {q[0], q[1], q[2], q[3]};
        p.framed = true;
      } else {
        const auto u = static_cast<size_t>(j);
        pending_.rotation[u] = {q[0], q[1], q[2], q[3]};
        pending_.position[u] = {pos[0], pos[1], pos[2]};
        pending_.named[u] = 1;
        if (j != 0 && (pos[0] != 0.0f || pos[1] != 0.0f || pos[2] != 0.0f)) pending_.positions_given = true;
        p.framed = true;
      }
    }
  } else if (std::strcmp(address, "/VMC/Ext/T") == 0) {
    if (types && argc == 1 && types[0] == 'f' && std::isfinite(float_arg(argv[0]))) {
      p.has_time = true;
      p.time = float_arg(argv[0]);
    } else if (types && argc == 1 && types[0] == 'f') {
      ++pending_counts_.bad_value;
    } else {
      ++pending_counts_.wrong_type;
    }
  } else {
    ++pending_counts_.ignored;  // blend shapes, devices, /VMC/Ext/OK, another protocol's address
  }
  lo_message_free(m);
}

void Reader::forward_kinematics() {
  using Q = Eigen::Quaternionf;
  using V = Eigen::Vector3f;
  std::array<Q, kVrmJointCount> world;
  std::array<V, kVrmJointCount> at;
  for (int j = 0; j < kVrmJointCount; ++j) {
    const auto u = static_cast<size_t>(j);
    const auto& r = state_.rotation[u];
    Q local(r[3], r[0], r[1], r[2]);
    V offset;
    if (state_.named[u] && (j == 0 || state_.positions_given)) {
      offset = V(state_.position[u][0], state_.position[u][1], state_.position[u][2]);
    } else if (!state_.named[u] && kVrmOptional[u]) {
      offset = V::Zero();  // a bone the sender's avatar lacks
      local = Q::Identity();
    } else {
      offset = V(kVrmRestOffsets[u][0], kVrmRestOffsets[u][1], kVrmRestOffsets[u][2]);
    }
    offsets_[u] = {offset.x(), offset.y(), offset.z()};
    const int parent = kVrmParents[u];
    if (parent < 0) {
      const Q root(state_.root_rotation[3], state_.root_rotation[0], state_.root_rotation[1], state_.root_rotation[2]);
      const V root_at(state_.root_position[0], state_.root_position[1], state_.root_position[2]);
      world[u] = root * local;
      at[u] = root_at + root * offset;
    } else {
      const auto pu = static_cast<size_t>(parent);
      world[u] = world[pu] * local;
      at[u] = at[pu] + world[pu] * offset;
    }
    // Unity's left-handed frame -> right-handed: x negated.
    positions_[3 * u] = -at[u].x();
    positions_[3 * u + 1] = at[u].y();
    positions_[3 * u + 2] = at[u].z();
  }
}

}  // namespace kata::vmc
