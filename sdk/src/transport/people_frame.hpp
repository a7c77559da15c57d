// The people frame message (schemas/people_frame.fbs): several unlabeled poses of one group
// stream's image. Its own decoder and encoder, beside wire.hpp's: the ingest routes a message
// whose file identifier is "KPPL" here (Ingest::handle_people, people_ingest.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "transport/wire.hpp"

namespace kata::transport {

// The most poses a people frame may carry.
inline constexpr int kMaxPeoplePoses = 64;

// A verified people frame; pointers valid until the decoder's next call.
struct PeopleFrameView {
  uint64_t stream_id = 0, sequence = 0;
  int64_t capture_ns = 0;
  int joints = 0;                     // per pose
  int poses = 0;
  const float* xyz = nullptr;         // poses x joints x 3 (null when poses is 0)
  const float* confidence = nullptr;  // poses x joints, or null
};

// Whether a message holds a people frame (the FlatBuffer's file identifier, after the topic).
bool is_people_frame(const void* data, size_t size);

// Verifies and reads people frames. Owns an aligned scratch buffer for a message ZeroMQ hands over
// misaligned, allocated at the size limit by the first such message: after it, decode()
// allocates nothing.
class PeopleFrameDecoder {
 public:
  PeopleFrameDecoder(size_t max_message_bytes, bool require_checksum);
  // kNone and *out filled, or why the message is refused. Reads no field before the verifier passed.
  DecodeError decode(const void* data, size_t size, PeopleFrameView* out);

 private:
  size_t max_bytes_;
  bool require_checksum_;
  std::vector<uint64_t> scratch_;
};

// Encodes a people frame message (topic + FlatBuffer) into *out (reused: it grows to the largest
// message written, then allocates nothing). xyz: poses x joints x 3; confidence: poses x joints or null.
void encode_people_frame(uint64_t stream_id, uint64_t sequence, int64_t capture_ns, int joints, int poses,
                         const float* xyz, const float* confidence, std::vector<uint8_t>* out);

// The stream id of person `person` (1, 2, ...) of group stream `group`: FNV-1a 64 over both as
// 8 little-endian bytes each, kept clear of the two reserved ids (2^64-2 and 2^64-1).
uint64_t person_stream_id(uint64_t group, uint32_t person);

}  // namespace kata::transport
