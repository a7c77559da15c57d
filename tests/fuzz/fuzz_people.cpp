// libFuzzer target: frames of unlabeled poses through the people tracker (kata::people::Tracker,
// what kata_people_track runs). Layout of the input:
//   byte 0: joints - 1 (mod 40); byte 1: max_people - 1 (mod 8); byte 2: max_poses - 1 (mod 8);
//   byte 3: bit 0 confidences given, bits 1-2 the gate (0.25, 1, 4, 64 body sizes), bit 3 no coast;
//   then frames: a time step byte (0: the same time again, 255: NaN, else step / 100 s), a pose
//   count byte (mod 16, may exceed max_poses), then per pose a mode byte (bit 0: raw float32
//   coordinates, else int16 / 256; bit 1: a NaN confidence) and its joints x 3 coordinates, then
//   (when given) one confidence byte per joint (/ 255).
// Asserts, after every frame: a pose's id is 0 or an open stream, no two poses of a frame share a
// stream, at most max_people streams are open, every pose is counted once (assigned or one
// refusal), a pose with a non-finite confident joint got no stream, every prediction is finite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "people/tracker.hpp"

namespace {

struct Reader {
  const uint8_t* p;
  size_t n;
  bool has(size_t k) const { return n >= k; }
  uint8_t byte() { return n ? (--n, *p++) : 0; }
  float coordinate(bool raw) {
    if (raw) {
      float f = 0.0f;
      if (n >= 4) std::memcpy(&f, p, 4), p += 4, n -= 4;
      else n = 0;
      return f;
    }
    const uint8_t lo = byte(), hi = byte();
    return static_cast<float>(static_cast<int16_t>(static_cast<uint16_t>(lo | (hi << 8)))) / 256.0f;
  }
};

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 4) return 0;
  Reader in{data, size};
  kata::people::TrackerConfig c;
  c.joints = 1 + in.byte() % 40;
  c.max_people = 1 + in.byte() % 8;
  c.max_poses = 1 + in.byte() % 8;
  const uint8_t flags = in.byte();
  const bool with_confidence = flags & 1;
  const double gates[4] = {0.25, 1.0, 4.0, 64.0};
  c.gate = gates[(flags >> 1) & 3];
  if (flags & 8) c.coast_seconds = 0.0;
  kata::people::Tracker tracker(c);
  const size_t joints = static_cast<size_t>(c.joints);
  std::vector<float> xyz, confidence;
  std::vector<uint32_t> ids(16), open(kata::people::kMaxPeople);
  std::vector<char> poisoned;
  double time = 0.0;
  bool has_time = false;
  while (in.has(2)) {
    const uint8_t step = in.byte();
    const double t = step == 255 ? std::nan("") : time + step / 100.0;
    const int poses = in.byte() % 16;
    xyz.assign(static_cast<size_t>(poses) * joints * 3, 0.0f);
    confidence.assign(static_cast<size_t>(poses) * joints, 1.0f);
    poisoned.assign(static_cast<size_t>(poses), 0);
    std::vector<uint8_t> modes(static_cast<size_t>(poses));
    for (int i = 0; i < poses; ++i) {
      const uint8_t mode = modes[static_cast<size_t>(i)] = in.byte();
      for (size_t k = 0; k < joints * 3; ++k) xyz[static_cast<size_t>(i) * joints * 3 + k] = in.coordinate(mode & 1);
    }
    if (with_confidence) {
      for (int i = 0; i < poses; ++i) {
        for (size_t j = 0; j < joints; ++j) confidence[static_cast<size_t>(i) * joints + j] = in.byte() / 255.0f;
        if (modes[static_cast<size_t>(i)] & 2) confidence[static_cast<size_t>(i) * joints] = std::nanf("");
      }
    }
    for (int i = 0; i < poses; ++i) {
      for (size_t j = 0; j < joints; ++j) {
        const float w = confidence[static_cast<size_t>(i) * joints + j];
        if (!std::isfinite(w)) poisoned[static_cast<size_t>(i)] = 1;
        if (std::isfinite(w) && w < c.min_confidence) continue;
        for (size_t k = 0; k < 3; ++k)
          if (!std::isfinite(xyz[(static_cast<size_t>(i) * joints + j) * 3 + k])) poisoned[static_cast<size_t>(i)] = 1;
      }
    }
    const kata::people::Frame f =
        tracker.track(t, xyz.data(), with_confidence ? confidence.data() : nullptr, poses, ids.data());
    const bool accepted = std::isfinite(t) && (!has_time || t > time);
    check((f == kata::people::Frame::kTaken) == accepted);
    if (!accepted) continue;
    time = t;
    has_time = true;
    const int n_open = tracker.open_streams(open.data(), kata::people::kMaxPeople);
    check(n_open <= c.max_people);
    for (int i = 0; i < poses; ++i) {
      const uint32_t id = ids[static_cast<size_t>(i)];
      if (id == 0) continue;
      check(!poisoned[static_cast<size_t>(i)]);
      bool is_open = false;
      for (int s = 0; s < n_open; ++s) is_open = is_open || open[static_cast<size_t>(s)] == id;
      check(is_open);
      for (int k = i + 1; k < poses; ++k) check(ids[static_cast<size_t>(k)] != id);
    }
    for (int s = 0; s < n_open; ++s) {
      double centroid[3];
      check(tracker.predicted(open[static_cast<size_t>(s)], time + 0.5, centroid));
      for (double v : centroid) check(std::isfinite(v));
    }
    const kata::people::TrackerCounters& k = tracker.counters();
    check(k.poses == k.assigned + k.refused_non_finite + k.refused_out_of_range + k.refused_few_joints +
                         k.refused_too_many_poses + k.refused_table_full);
    check(k.opened - k.closed == static_cast<uint64_t>(n_open));
  }
  return 0;
}
