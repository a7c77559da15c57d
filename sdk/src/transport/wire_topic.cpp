// Topics (a stream id as 16 hex digits), the shard of a stream, and the frame checksum: what
// every message's framing shares (wire.hpp).
#include "transport/wire.hpp"

namespace kata::transport {

namespace {

constexpr char kHex[] = "0123456789abcdef";

uint32_t fnv1a(uint32_t hash, const void* data, size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  for (size_t i = 0; i < size; ++i) hash = (hash ^ p[i]) * 16777619u;
  return hash;
}

uint32_t fnv1a_u64(uint32_t hash, uint64_t v) {
  uint8_t le[8];
  for (int i = 0; i < 8; ++i) le[i] = static_cast<uint8_t>(v >> (8 * i));
  return fnv1a(hash, le, 8);
}

}  // namespace

void write_topic(uint64_t stream_id, char* out) {
  for (int i = 0; i < 16; ++i) out[i] = kHex[(stream_id >> (4 * (15 - i))) & 0xF];
}

uint32_t shard_of(uint64_t stream_id, uint32_t shard_count) {
  if (shard_count <= 1) return 0;
  uint64_t hash = 14695981039346656037ULL;  // FNV-1a 64 offset basis
  for (int byte = 0; byte < 8; ++byte) {
    hash ^= (stream_id >> (8 * byte)) & 0xffu;
    hash *= 1099511628211ULL;  // FNV-1a 64 prime
  }
  return static_cast<uint32_t>(hash % shard_count);
}

bool parse_topic(const uint8_t* topic, uint64_t* stream_id) {
  uint64_t id = 0;
  for (size_t i = 0; i < kTopicBytes; ++i) {
    const uint8_t c = topic[i];
    uint64_t digit;
    if (c >= '0' && c <= '9') digit = c - '0';
    else if (c >= 'a' && c <= 'f') digit = 10 + (c - 'a');
    else return false;
    id = (id << 4) | digit;
  }
  *stream_id = id;
  return true;
}

uint32_t frame_checksum(uint64_t stream_id, uint64_t sequence, int64_t capture_ns, const float* xyz,
                        int joints, const float* confidence, const float* presence) {
  uint32_t h = 2166136261u;
  h = fnv1a_u64(h, stream_id);
  h = fnv1a_u64(h, sequence);
  h = fnv1a_u64(h, static_cast<uint64_t>(capture_ns));
  // Floats are hashed as their little-endian bytes (the wire's); x86-64 and aarch64 are LE.
  h = fnv1a(h, xyz, sizeof(float) * 3 * static_cast<size_t>(joints));
  if (confidence) h = fnv1a(h, confidence, sizeof(float) * static_cast<size_t>(joints));
  if (presence) h = fnv1a(h, presence, sizeof(float) * static_cast<size_t>(joints));
  return h;
}

}  // namespace kata::transport
