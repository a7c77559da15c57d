// Results on NATS: a stream's result messages (the FlatBuffers bytes ZeroMQ carries, wire.hpp)
// go out on `<prefix>.out.<topic>.<epoch>.<owner>`: the subject itself says which shard computed
// them under which lease tenure (lease.hpp), so a subscriber of `<prefix>.out.<topic>.>` (one
// stream) or `<prefix>.out.>` (all) can drop what a former holder sent after a newer holder began
// (EpochFilter), with no header to parse and nothing allocated per message by the publisher.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>

namespace kata::transport::nats {

// Writes `<prefix>.out.<topic>.<epoch>.<owner>` into out (NUL-terminated); false when it does not
// fit in capacity bytes. Allocation-free.
bool format_result_subject(char* out, size_t capacity, const std::string& prefix, uint64_t stream_id,
                           uint64_t epoch, const std::string& owner);
// Reads a result subject; owner receives a pointer into subject (to its end). False when the
// subject is not one.
bool parse_result_subject(const std::string& prefix, const char* subject, uint64_t* stream_id, uint64_t* epoch,
                          const char** owner);

// Keeps, per stream, the newest epoch seen; a result of an older epoch came from a shard that held
// the stream's partition before the current holder and is dropped. Bounded: beyond max_streams
// streams a new stream is accepted without being remembered (counted in untracked).
class EpochFilter {
 public:
  explicit EpochFilter(size_t max_streams = 1 << 16) : max_streams_(max_streams) {}
  // true: deliver the result. [one thread]
  bool accept(uint64_t stream_id, uint64_t epoch);
  uint64_t stale() const { return stale_; }
  uint64_t untracked() const { return untracked_; }
  // Epoch changes seen (a stream moved to another shard, or back after a lapse).
  uint64_t handovers() const { return handovers_; }

 private:
  size_t max_streams_;
  std::unordered_map<uint64_t, uint64_t> newest_;
  uint64_t stale_ = 0, untracked_ = 0, handovers_ = 0;
};

}  // namespace kata::transport::nats
