// The wire format of every kata message (schemas/frame.fbs, skeleton.fbs, result.fbs): one
// ZeroMQ frame holding a 16-byte topic (the stream id as 16 lowercase hex digits, so a SUB
// prefix filter selects exactly one stream) followed by a FlatBuffer whose file identifier says
// which table it is. Single-part on purpose: a renderer may set ZMQ_CONFLATE on its SUB socket
// (latest-only delivery), which keeps only one part of a multi-part message.
//
// Encoders reuse one FlatBufferBuilder and one output buffer each (no allocation once they have
// grown to the largest message). The decoder verifies every buffer with the FlatBuffers
// Verifier before reading a field; generated types never leave transport/.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "skeleton/skeleton.hpp"
#include "stream/stream.hpp"

#include "kata/result.h"

namespace kata::transport {

inline constexpr size_t kTopicBytes = 16;

// The topic of a frame batch (schemas/frame_batch.fbs): stream id 2^64-2, which no stream can have
// (the runtime reserves it), since a batch's frames belong to many streams.
inline constexpr uint64_t kBatchStreamId = ~0ULL - 1;
// The most frames one batch may carry (a larger one is refused whole, as the verifier's table
// limit): a tick of 4096 streams from one source.
inline constexpr size_t kMaxBatchFrames = 4096;

// Writes the topic of a stream (16 hex digits, no terminator) into out.
void write_topic(uint64_t stream_id, char* out);
// Parses a 16-hex-digit topic; false when any byte is not a lowercase hex digit.
bool parse_topic(const uint8_t* topic, uint64_t* stream_id);

// The shard that owns a stream when `shard_count` `kata serve` processes split the streams
// (docs/deploy.md, kata_shard_of in kata.h): FNV-1a 64 over the stream id's 8 bytes, least
// significant first, modulo shard_count (0 when shard_count is 0 or 1). Stable across versions
// and machines: a producer computes it to know which shard scores a stream.
uint32_t shard_of(uint64_t stream_id, uint32_t shard_count);

// FNV-1a 32 over a frame's values, as schemas/frame.fbs documents for Frame.checksum.
uint32_t frame_checksum(uint64_t stream_id, uint64_t sequence, int64_t capture_ns, const float* xyz,
                        int joints, const float* confidence, const float* presence = nullptr);

// A stream's skeleton as carried by a SkeletonDefinition message.
struct SkeletonDefinition {
  uint64_t stream_id = 0;
  uint32_t revision = 0;
  Skeleton skeleton;           // has_rest_pose when rest offsets were sent
  std::string layout;          // a built-in layout's name, or empty when name_map is used
  std::vector<std::string> name_map;  // 16 names in GPD joint order, or empty
  UpAxis up_axis = UpAxis::kY;
  float metres_per_unit = 0.0f;  // 0 = unknown
  float frame_rate = 0.0f;       // Hz, 0 = unknown
  bool closed = false;           // the source ends the stream (schemas/skeleton.fbs)
  std::string refused;           // a receiver's refusal of it, on its results channel; empty otherwise
};

// A stream's practice setting as carried by a Practice message (schemas/practice.fbs documents
// each field): teacher seconds from the teacher's first frame, the axis of matched_teacher_time.
struct PracticeSetting {
  uint64_t stream_id = 0;
  uint32_t revision = 0;
  double teacher_start = 0.0;  // the lesson starts here (0: the clip's first frame)
  bool loop = false;           // loop loop_start..loop_end (teacher_start is then 0)
  double loop_start = 0.0, loop_end = 0.0;
};

// What a practice setting may not hold, whatever the clip (the rest is judged against the
// stream's teacher by the runtime): null when the values are usable, else why not ("loop_end 2
// is not after loop_start 4"), written into `why` (at least 128 bytes). Allocation-free.
const char* practice_values_problem(const PracticeSetting& practice, char* why, size_t size);

// The section a result was computed under (schemas/result.fbs PracticeSection), in teacher seconds.
struct PracticeSection {
  double start_time = 0.0, end_time = 0.0;
  bool loop = false;
  uint32_t revision = 0;
};

// The published fields of one result: the public record (kata/result.h, which schemas/result.fbs
// mirrors field by field) plus the features, which only the wire carries. Encoder::result and
// Decoder::decode are the record's only translations to and from the wire.
struct ResultFields : kata_result_record {
  // An unscored result of no stream: every field 0 but the "none" markers.
  ResultFields() : kata_result_record{} {
    struct_size = sizeof(kata_result_record);
    matched_teacher_frame = -1;
    matched_teacher_time = -1.0;
    part_to_fix = -1;
    cue_joint = -1;
    cue_action = -1;
  }
  const float* features = nullptr;  // feature_count floats, or null
  int feature_count = 0;
};

// The counters a runtime publishes (schemas/stats.fbs documents each), on the topic of stream id
// kStatsStreamId.
inline constexpr uint64_t kStatsStreamId = ~0ULL;
struct StreamStatsFields {
  uint64_t stream_id = 0, frames_in = 0, queue_full = 0, refused = 0, results = 0, results_dropped = 0, published = 0;
};
struct StatsFields {
  int64_t published_ns = 0;
  uint64_t streams = 0, closed_streams = 0;
  uint64_t received = 0, frames = 0, definitions = 0, repeated_definitions = 0, closes = 0, other_shard = 0, dropped = 0;
  uint64_t malformed = 0, not_owner = 0, refused_limit = 0, refused_definitions = 0, unknown_stream = 0,
           wrong_joint_count = 0, out_of_order = 0, out_of_window = 0, stale = 0, other_kind = 0;
  uint64_t sequence_gaps = 0, restarts = 0, connections = 0, connections_refused = 0;
  uint64_t frames_in = 0, queue_full = 0, refused = 0, results = 0, results_dropped = 0, published = 0, send_failed = 0;
  std::vector<StreamStatsFields> per_stream;
  uint64_t practices = 0, repeated_practices = 0, practice_bad_values = 0, practice_outside_clip = 0, practice_no_clip = 0,
           practice_queue_full = 0;
  uint64_t batches = 0, batch_frames = 0;
};

// A view of one message's bytes (topic included); valid until the encoder's next call.
struct Bytes {
  const uint8_t* data = nullptr;
  size_t size = 0;
};

// Builds messages with one reused builder. One encoder per thread.
class Encoder {
 public:
  Encoder();
  ~Encoder();
  Encoder(const Encoder&) = delete;
  Encoder& operator=(const Encoder&) = delete;

  // A Frame message (checksum filled in). confidence may be null.
  Bytes frame(uint64_t stream_id, uint64_t sequence, int64_t capture_ns, const float* xyz, int joints,
              const float* confidence = nullptr, const float* presence = nullptr);
  // A FrameBatch message (schemas/frame_batch.fbs): frames of many streams, each with its own
  // checksum, in this order. Grown to the largest batch, then allocation-free. Throws
  // kata::Error(kInvalidArgument) for no frame or more than kMaxBatchFrames.
  struct BatchFrame {
    uint64_t stream_id = 0, sequence = 0;
    int64_t capture_ns = 0;
    const float* xyz = nullptr;  // joints x 3
    int joints = 0;
    const float* confidence = nullptr;  // joints, or null
    const float* presence = nullptr;    // joints, or null
  };
  Bytes frame_batch(const BatchFrame* frames, size_t count);
  // A SkeletonDefinition message.
  Bytes skeleton(const SkeletonDefinition& definition);
  // A Practice message.
  Bytes practice(const PracticeSetting& practice);
  // A Result message.
  Bytes result(const ResultFields& fields);
  // A Stats message (topic: kStatsStreamId).
  Bytes stats(const StatsFields& fields);
  // A Repetition message (schemas/repetition.fbs) of repetition.stream_id, published_ns its
  // published time.
  Bytes repetition(const kata_repetition& repetition, int64_t published_ns);

 private:
  Bytes finish(uint64_t stream_id, const char* identifier);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Why a message was refused (each is counted by the ingest).
enum class DecodeError {
  kNone = 0,
  kTooShort,           // shorter than a topic plus a FlatBuffer header
  kOversized,          // larger than the decoder's limit (bytes; a batch: frames, kMaxBatchFrames)
  kBadTopic,           // the topic is not 16 lowercase hex digits
  kUnknownIdentifier,  // no kata table's file identifier
  kVerifier,           // the FlatBuffers verifier refused the buffer
  kVersion,            // a schema_version this reader does not know
  kTopicMismatch,      // the table's stream_id differs from the topic
  kMissingField,       // a required field (positions, joint names, checksum) is absent
  kChecksum,           // Frame.checksum does not match its values
  kCount
};
const char* decode_error_name(DecodeError error);

enum class MessageKind { kNone, kFrame, kSkeleton, kResult, kStats, kPractice, kFrameBatch, kRepetition };

// A verified frame; pointers are valid until the decoder's next call.
struct FrameView {
  uint64_t stream_id = 0, sequence = 0;
  int64_t capture_ns = 0;
  int joints = 0;
  const float* xyz = nullptr;         // joints x 3
  const float* confidence = nullptr;  // joints, or null; with a presence field: the smaller of the two
};

// A verified result; pointers valid until the decoder's next call.
struct ResultView {
  ResultFields fields;
};

// Verifies and reads messages. Owns an aligned scratch buffer (allocated once, at the size
// limit) that a message is copied into when ZeroMQ hands it over misaligned.
class Decoder {
 public:
  explicit Decoder(size_t max_message_bytes = 1 << 20, bool require_checksum = true);
  ~Decoder();
  Decoder(const Decoder&) = delete;
  Decoder& operator=(const Decoder&) = delete;

  // Verifies a message and says what it holds; on kNone, error() says why. Reads no field
  // before the verifier passed.
  MessageKind decode(const void* data, size_t size);
  DecodeError error() const { return error_; }
  uint64_t stream_id() const { return stream_id_; }

  // The verified content of the last decode(), for the kind it returned.
  const FrameView& frame() const { return frame_; }
  // A kFrameBatch: how many frames it carries (1..kMaxBatchFrames), the stream id of frame i
  // (read from the verified table, before the frame's own checks: a shard keeps only its own), and
  // frame i's own checks (version, fields, checksum, as a Frame message's but for the topic):
  // kNone and frame() holds it until the next decode or batch_frame, else why it is refused.
  // Allocation-free.
  size_t batch_size() const { return batch_size_; }
  uint64_t batch_stream_id(size_t i) const;
  DecodeError batch_frame(size_t i);
  // Copies the definition out (allocates: skeleton definitions are rare). Throws
  // kata::Error(kInvalidArgument) when the skeleton itself is inconsistent.
  SkeletonDefinition skeleton() const;
  // The last decoded definition's revision, joint count and closed flag, read without copying
  // (the ingest judges limits and ownership before it allocates anything).
  uint32_t skeleton_revision() const;
  int skeleton_joints() const;
  bool skeleton_closed() const;
  // A skeleton message's refusal by a receiver (schemas/skeleton.fbs `refused`): its text, or
  // null (absent, or not a skeleton). Valid while the message is.
  const char* skeleton_refused(size_t* size) const;
  const ResultFields& result() const { return result_; }
  // The last decoded Repetition message (published_ns: its published time). Allocation-free.
  const kata_repetition& repetition() const { return repetition_; }
  int64_t repetition_published_ns() const { return repetition_published_ns_; }
  // The last decoded Practice message (verified structure; its values are judged by
  // practice_values_problem). Allocation-free.
  PracticeSetting practice() const;
  // Copies a verified Stats message out (allocates: a monitor's path, once a second).
  StatsFields stats() const;

  size_t max_message_bytes() const { return max_bytes_; }

 private:
  MessageKind fail(DecodeError error);
  // A verified Frame table's own checks into frame_ (the single message's and a batch's frames).
  DecodeError read_frame(const void* table);
  size_t max_bytes_;
  bool require_checksum_;
  std::vector<uint64_t> scratch_;  // 8-byte aligned
  std::vector<float> combined_;    // min(confidence, presence) per joint (sized at the limit)
  const uint8_t* payload_ = nullptr;
  size_t payload_size_ = 0;
  DecodeError error_ = DecodeError::kNone;
  uint64_t stream_id_ = 0;
  FrameView frame_;
  const void* batch_ = nullptr;  // the verified FrameBatch's frames vector
  size_t batch_size_ = 0;
  ResultFields result_;
  kata_repetition repetition_{};
  int64_t repetition_published_ns_ = 0;
};

}  // namespace kata::transport
