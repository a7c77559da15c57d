// A message's topic, as kata/runtime.h documents it: the stream id as 16 lowercase hex digits,
// most significant first (the first bytes of every message a runtime reads or publishes, and the
// last token of a NATS subject here). Written from that documented format rather than taken from
// the core's wire.hpp, so that the NATS layer reads messages as any client of the C ABI would.
#pragma once

#include <cstddef>
#include <cstdint>

namespace kata::transport::nats {

inline constexpr size_t kStreamTopicBytes = 16;

// Writes the 16 digits of a stream id's topic into out (no terminator).
inline void write_stream_topic(uint64_t stream_id, char* out) {
  constexpr char kHex[] = "0123456789abcdef";
  for (size_t i = 0; i < kStreamTopicBytes; ++i) out[i] = kHex[(stream_id >> (4 * (kStreamTopicBytes - 1 - i))) & 0xF];
}

// Reads 16 topic bytes into *stream_id; false (and *stream_id untouched) when any byte is not a
// lowercase hex digit.
inline bool read_stream_topic(const char* topic, uint64_t* stream_id) {
  uint64_t id = 0;
  for (size_t i = 0; i < kStreamTopicBytes; ++i) {
    const char c = topic[i];
    uint64_t digit;
    if (c >= '0' && c <= '9') digit = static_cast<uint64_t>(c - '0');
    else if (c >= 'a' && c <= 'f') digit = static_cast<uint64_t>(10 + (c - 'a'));
    else return false;
    id = (id << 4) | digit;
  }
  *stream_id = id;
  return true;
}

}  // namespace kata::transport::nats
