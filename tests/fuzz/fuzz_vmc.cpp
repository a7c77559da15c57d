// libFuzzer target: VMC datagrams (OSC bundles and messages, kata/vmc.h) through the reader
// (transport/vmc: the bundle's frame read by hand, each message taken apart by liblo), as a
// performer's UDP socket would deliver them. The input is a sequence of datagrams, each a 2-byte
// big-endian length + its bytes (a length past the end takes the rest). Asserts: every datagram
// counted once, and refused whole by at most one cause; a frame's joints are finite and its time
// after the previous frame's; nothing read ever moves a joint beyond the reader's bounds.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "transport/vmc/vmc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  kata::vmc::Reader reader(4096);
  size_t at = 0, packets = 0;
  uint64_t frames = 0;
  double last = -INFINITY;
  while (at + 2 <= size) {
    size_t n = (size_t{data[at]} << 8) | data[at + 1];
    at += 2;
    if (n > size - at) n = size - at;
    const kata::vmc::Counters before = reader.counters();
    const bool frame = reader.read(data + at, n, 0.001 * static_cast<double>(packets));
    at += n;
    ++packets;
    const kata::vmc::Counters& c = reader.counters();
    if (c.packets != packets) std::abort();
    const uint64_t refused = (c.malformed - before.malformed) + (c.oversized - before.oversized) +
                             (c.out_of_order - before.out_of_order);
    if (refused > 1 || (refused && frame)) std::abort();
    if (frame) {
      ++frames;
      if (!(reader.capture_time() > last) || !std::isfinite(reader.capture_time())) std::abort();
      last = reader.capture_time();
      const float* xyz = reader.positions();
      for (int k = 0; k < 3 * kata::kVrmJointCount; ++k)
        if (!std::isfinite(xyz[k]) || std::fabs(xyz[k]) > 2.0f * kata::kVrmJointCount * kata::vmc::Reader::kMaxCoordinate)
          std::abort();
    }
    if (c.frames != frames) std::abort();
  }
  return 0;
}
