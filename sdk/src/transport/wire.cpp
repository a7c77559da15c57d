// FlatBuffers encode / verify + decode of kata messages (see wire.hpp for the framing).
#include "transport/wire.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <climits>
#include <limits>

#include "common/error.hpp"
#include "kata_schemas/frame_batch_generated.h"
#include "kata_schemas/frame_generated.h"
#include "kata_schemas/practice_generated.h"
#include "kata_schemas/result_generated.h"
#include "kata_schemas/skeleton_generated.h"
#include "kata_schemas/stats_generated.h"

namespace kata::transport {

namespace {

constexpr char kHex[] = "0123456789abcdef";
constexpr uint16_t kFrameVersion = 1, kSkeletonVersion = 1, kResultVersion = 1, kPracticeVersion = 1,
                   kFrameBatchVersion = 1;

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

// Vec3 is a struct of three floats (12 bytes, 4-aligned): a vector of them is xyz interleaved.
static_assert(sizeof(fb::Vec3) == 3 * sizeof(float), "Vec3 must be three packed floats");

// A [Vec3] from interleaved xyz floats. CreateVectorOfStructs aligns to the struct's alignment
// (4); flatbuffers 2.0.8's CreateUninitializedVectorOfStructs would align to its size (12, not a
// power of two) and misalign the whole buffer. It copies the bytes only (PushBytes).
flatbuffers::Offset<flatbuffers::Vector<const fb::Vec3*>> vec3_vector(flatbuffers::FlatBufferBuilder& b,
                                                                      const float* xyz, int count) {
  return b.CreateVectorOfStructs(reinterpret_cast<const fb::Vec3*>(xyz), static_cast<size_t>(count));
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

// ---------------------------------------------------------------------------------------------
// Encoder

struct Encoder::Impl {
  flatbuffers::FlatBufferBuilder builder{4096};
  std::vector<uint8_t> message;  // topic + buffer, grown to the largest message, then reused
  std::vector<flatbuffers::Offset<fb::Frame>> batch_tables;  // a batch's frames, grown to the largest
};

Encoder::Encoder() : impl_(std::make_unique<Impl>()) {}
Encoder::~Encoder() = default;

Bytes Encoder::finish(uint64_t stream_id, const char* /*identifier*/) {
  auto& b = impl_->builder;
  const size_t size = b.GetSize();
  auto& m = impl_->message;
  if (m.size() < kTopicBytes + size) m.resize(kTopicBytes + size);
  write_topic(stream_id, reinterpret_cast<char*>(m.data()));
  std::memcpy(m.data() + kTopicBytes, b.GetBufferPointer(), size);
  return Bytes{m.data(), kTopicBytes + size};
}

namespace {

// One Frame table (its checksum filled in), for a Frame message or a batch's frame.
flatbuffers::Offset<fb::Frame> frame_table(flatbuffers::FlatBufferBuilder& b, uint64_t stream_id, uint64_t sequence,
                                           int64_t capture_ns, const float* xyz, int joints, const float* confidence,
                                           const float* presence) {
  const auto positions = vec3_vector(b, xyz, joints);
  flatbuffers::Offset<flatbuffers::Vector<float>> conf, pres;
  if (confidence) conf = b.CreateVector(confidence, static_cast<size_t>(joints));
  if (presence) pres = b.CreateVector(presence, static_cast<size_t>(joints));
  fb::FrameBuilder f(b);
  f.add_schema_version(kFrameVersion);
  f.add_stream_id(stream_id);
  f.add_sequence(sequence);
  const fb::Time capture(capture_ns);
  f.add_capture_time(&capture);
  f.add_positions(positions);
  if (confidence) f.add_confidence(conf);
  if (presence) f.add_presence(pres);
  f.add_checksum(frame_checksum(stream_id, sequence, capture_ns, xyz, joints, confidence, presence));
  return f.Finish();
}

}  // namespace

Bytes Encoder::frame(uint64_t stream_id, uint64_t sequence, int64_t capture_ns, const float* xyz, int joints,
                     const float* confidence, const float* presence) {
  auto& b = impl_->builder;
  b.Clear();
  b.Finish(frame_table(b, stream_id, sequence, capture_ns, xyz, joints, confidence, presence), fb::FrameIdentifier());
  return finish(stream_id, fb::FrameIdentifier());
}

Bytes Encoder::frame_batch(const BatchFrame* frames, size_t count) {
  if (count == 0 || count > kMaxBatchFrames)
    throw Error(ErrorKind::kInvalidArgument, "frame batch: " + std::to_string(count) + " frames (1.." +
                                                 std::to_string(kMaxBatchFrames) + ")");
  auto& b = impl_->builder;
  b.Clear();
  auto& tables = impl_->batch_tables;
  tables.clear();
  for (size_t i = 0; i < count; ++i) {
    const BatchFrame& f = frames[i];
    tables.push_back(frame_table(b, f.stream_id, f.sequence, f.capture_ns, f.xyz, f.joints, f.confidence, f.presence));
  }
  const auto frames_v = b.CreateVector(tables.data(), tables.size());
  fb::FrameBatchBuilder k(b);
  k.add_schema_version(kFrameBatchVersion);
  k.add_frames(frames_v);
  b.Finish(k.Finish(), fb::FrameBatchIdentifier());
  return finish(kBatchStreamId, fb::FrameBatchIdentifier());
}

Bytes Encoder::skeleton(const SkeletonDefinition& d) {
  auto& b = impl_->builder;
  b.Clear();
  const Skeleton& s = d.skeleton;
  const auto names = b.CreateVectorOfStrings(s.names);
  std::vector<int16_t> parents(s.parents.begin(), s.parents.end());
  const auto parents_v = b.CreateVector(parents);
  flatbuffers::Offset<flatbuffers::Vector<const fb::Vec3*>> offsets;
  if (s.has_rest_pose) {
    std::vector<fb::Vec3> v;
    for (const auto& o : s.offsets)
      v.emplace_back(static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z()));
    offsets = b.CreateVectorOfStructs(v);
  }
  const auto layout = b.CreateString(d.layout);
  flatbuffers::Offset<flatbuffers::Vector<flatbuffers::Offset<flatbuffers::String>>> name_map;
  if (!d.name_map.empty()) name_map = b.CreateVectorOfStrings(d.name_map);
  fb::SkeletonDefinitionBuilder k(b);
  k.add_schema_version(kSkeletonVersion);
  k.add_stream_id(d.stream_id);
  k.add_revision(d.revision);
  k.add_joint_names(names);
  k.add_parents(parents_v);
  if (s.has_rest_pose) k.add_rest_offsets(offsets);
  k.add_metres_per_unit(d.metres_per_unit);
  k.add_up_axis(d.up_axis == UpAxis::kZ ? fb::UpAxis::Z : fb::UpAxis::Y);
  k.add_layout(layout);
  if (!d.name_map.empty()) k.add_name_map(name_map);
  k.add_frame_rate(d.frame_rate);
  if (d.closed) k.add_closed(true);
  b.Finish(k.Finish(), fb::SkeletonDefinitionIdentifier());
  return finish(d.stream_id, fb::SkeletonDefinitionIdentifier());
}

Bytes Encoder::practice(const PracticeSetting& p) {
  auto& b = impl_->builder;
  b.Clear();
  fb::PracticeBuilder k(b);
  k.add_schema_version(kPracticeVersion);
  k.add_stream_id(p.stream_id);
  k.add_revision(p.revision);
  k.add_teacher_start(p.teacher_start);
  k.add_loop(p.loop);
  k.add_loop_start(p.loop_start);
  k.add_loop_end(p.loop_end);
  b.Finish(k.Finish(), fb::PracticeIdentifier());
  return finish(p.stream_id, fb::PracticeIdentifier());
}

const char* practice_values_problem(const PracticeSetting& p, char* why, size_t size) {
  if (!std::isfinite(p.teacher_start) || !std::isfinite(p.loop_start) || !std::isfinite(p.loop_end)) {
    std::snprintf(why, size, "a time is not finite (teacher_start %g, loop_start %g, loop_end %g)", p.teacher_start,
                  p.loop_start, p.loop_end);
  } else if (p.teacher_start < 0.0) {
    std::snprintf(why, size, "teacher_start %g s is before the teacher's first frame", p.teacher_start);
  } else if (!p.loop) {
    return nullptr;
  } else if (p.teacher_start != 0.0) {
    std::snprintf(why, size, "teacher_start %g s and a loop from %g s: give one or the other", p.teacher_start,
                  p.loop_start);
  } else if (p.loop_start < 0.0) {
    std::snprintf(why, size, "loop_start %g s is before the teacher's first frame", p.loop_start);
  } else if (!(p.loop_end > p.loop_start)) {
    std::snprintf(why, size, "loop_end %g s is not after loop_start %g s", p.loop_end, p.loop_start);
  } else {
    return nullptr;
  }
  return why;
}

// A record's capture time (seconds, the source's clock) as the wire's nanoseconds, rounded; a
// time outside +-292 years (no source's) saturates rather than overflow.
static int64_t seconds_to_ns(double seconds) {
  const double ns = std::round(seconds * 1e9);
  if (!(ns > -9.2e18)) return ns != ns ? 0 : INT64_MIN;
  if (ns > 9.2e18) return INT64_MAX;
  return static_cast<int64_t>(ns);
}

Bytes Encoder::result(const ResultFields& r) {
  auto& b = impl_->builder;
  b.Clear();
  flatbuffers::Offset<flatbuffers::Vector<const fb::Vec3*>> ghost;
  if (r.ghost) {
    ghost = vec3_vector(b, r.ghost, static_cast<int>(r.ghost_joint_count));
  }
  flatbuffers::Offset<flatbuffers::Vector<float>> features;
  if (r.features) features = b.CreateVector(r.features, static_cast<size_t>(r.feature_count));
  fb::ResultBuilder o(b);
  o.add_schema_version(kResultVersion);
  o.add_stream_id(r.stream_id);
  o.add_result_sequence(r.result_sequence);
  o.add_frame_sequence(r.frame_sequence);
  o.add_frame_index(r.frame_index);
  // The record's capture time is the source's seconds; the wire's Time is nanoseconds.
  const fb::Time capture(seconds_to_ns(r.capture_time)), arrival(r.arrival_ns), computed(r.computed_ns),
      published(r.published_ns);
  o.add_capture_time(&capture);
  o.add_arrival_time(&arrival);
  o.add_computed_time(&computed);
  o.add_published_time(&published);
  o.add_scored(r.scored != 0);
  o.add_distance(r.distance);
  o.add_score(r.score);
  const fb::PartBreakdown parts(r.parts[0], r.parts[1], r.parts[2], r.parts[3], r.parts[4]);
  o.add_parts(&parts);
  o.add_matched_teacher_frame(r.matched_teacher_frame);
  o.add_matched_teacher_time(r.matched_teacher_time);
  const fb::PartScores part_scores(r.part_scores[0], r.part_scores[1], r.part_scores[2], r.part_scores[3],
                                   r.part_scores[4]);
  if (r.scored) o.add_part_scores(&part_scores);
  o.add_part_to_fix(static_cast<int8_t>(r.part_to_fix));
  o.add_feedback_state(static_cast<fb::FeedbackState>(r.state));
  const fb::PracticeSection practice(r.practice_start_time, r.practice_end_time, r.practice_loop != 0,
                                     r.practice_revision);
  if (r.has_practice) o.add_practice(&practice);
  o.add_cue_joint(static_cast<int8_t>(r.cue_joint));
  o.add_cue_degrees(r.cue_degrees);
  o.add_cue_action(static_cast<int8_t>(r.cue_action));
  if (r.ghost) o.add_ghost(ghost);
  if (r.features) o.add_features(features);
  b.Finish(o.Finish(), fb::ResultIdentifier());
  return finish(r.stream_id, fb::ResultIdentifier());
}

Bytes Encoder::stats(const StatsFields& f) {
  auto& b = impl_->builder;
  b.Clear();
  std::vector<flatbuffers::Offset<fb::StreamStats>> per;
  per.reserve(f.per_stream.size());
  for (const StreamStatsFields& p : f.per_stream)
    per.push_back(fb::CreateStreamStats(b, p.stream_id, p.frames_in, p.queue_full, p.refused, p.results,
                                        p.results_dropped, p.published));
  const auto per_v = b.CreateVector(per);
  fb::StatsBuilder k(b);
  k.add_schema_version(1);
  const fb::Time published(f.published_ns);
  k.add_published_time(&published);
  k.add_streams(f.streams);
  k.add_closed_streams(f.closed_streams);
  k.add_received(f.received);
  k.add_frames(f.frames);
  k.add_definitions(f.definitions);
  k.add_repeated_definitions(f.repeated_definitions);
  k.add_closes(f.closes);
  k.add_other_shard(f.other_shard);
  k.add_dropped(f.dropped);
  k.add_malformed(f.malformed);
  k.add_not_owner(f.not_owner);
  k.add_refused_limit(f.refused_limit);
  k.add_refused_definitions(f.refused_definitions);
  k.add_unknown_stream(f.unknown_stream);
  k.add_wrong_joint_count(f.wrong_joint_count);
  k.add_out_of_order(f.out_of_order);
  k.add_out_of_window(f.out_of_window);
  k.add_stale(f.stale);
  k.add_other_kind(f.other_kind);
  k.add_sequence_gaps(f.sequence_gaps);
  k.add_restarts(f.restarts);
  k.add_connections(f.connections);
  k.add_connections_refused(f.connections_refused);
  k.add_frames_in(f.frames_in);
  k.add_queue_full(f.queue_full);
  k.add_refused(f.refused);
  k.add_results(f.results);
  k.add_results_dropped(f.results_dropped);
  k.add_published(f.published);
  k.add_send_failed(f.send_failed);
  k.add_per_stream(per_v);
  k.add_practices(f.practices);
  k.add_repeated_practices(f.repeated_practices);
  k.add_practice_bad_values(f.practice_bad_values);
  k.add_practice_outside_clip(f.practice_outside_clip);
  k.add_practice_no_clip(f.practice_no_clip);
  k.add_practice_queue_full(f.practice_queue_full);
  k.add_batches(f.batches);
  k.add_batch_frames(f.batch_frames);
  b.Finish(k.Finish(), fb::StatsIdentifier());
  return finish(kStatsStreamId, fb::StatsIdentifier());
}

StatsFields Decoder::stats() const {
  const fb::Stats* k = fb::GetStats(payload_);
  StatsFields f;
  f.published_ns = k->published_time() ? k->published_time()->nanoseconds() : 0;
  f.streams = k->streams();
  f.closed_streams = k->closed_streams();
  f.received = k->received();
  f.frames = k->frames();
  f.definitions = k->definitions();
  f.repeated_definitions = k->repeated_definitions();
  f.closes = k->closes();
  f.other_shard = k->other_shard();
  f.dropped = k->dropped();
  f.malformed = k->malformed();
  f.not_owner = k->not_owner();
  f.refused_limit = k->refused_limit();
  f.refused_definitions = k->refused_definitions();
  f.unknown_stream = k->unknown_stream();
  f.wrong_joint_count = k->wrong_joint_count();
  f.out_of_order = k->out_of_order();
  f.out_of_window = k->out_of_window();
  f.stale = k->stale();
  f.other_kind = k->other_kind();
  f.sequence_gaps = k->sequence_gaps();
  f.restarts = k->restarts();
  f.connections = k->connections();
  f.connections_refused = k->connections_refused();
  f.frames_in = k->frames_in();
  f.queue_full = k->queue_full();
  f.refused = k->refused();
  f.results = k->results();
  f.results_dropped = k->results_dropped();
  f.published = k->published();
  f.send_failed = k->send_failed();
  f.practices = k->practices();
  f.repeated_practices = k->repeated_practices();
  f.practice_bad_values = k->practice_bad_values();
  f.practice_outside_clip = k->practice_outside_clip();
  f.practice_no_clip = k->practice_no_clip();
  f.practice_queue_full = k->practice_queue_full();
  f.batches = k->batches();
  f.batch_frames = k->batch_frames();
  if (const auto* per = k->per_stream())
    for (const fb::StreamStats* p : *per)
      f.per_stream.push_back({p->stream_id(), p->frames_in(), p->queue_full(), p->refused(), p->results(),
                              p->results_dropped(), p->published()});
  return f;
}

// ---------------------------------------------------------------------------------------------
// Decoder

const char* decode_error_name(DecodeError error) {
  switch (error) {
    case DecodeError::kNone: return "none";
    case DecodeError::kTooShort: return "too short";
    case DecodeError::kOversized: return "oversized";
    case DecodeError::kBadTopic: return "bad topic";
    case DecodeError::kUnknownIdentifier: return "unknown file identifier";
    case DecodeError::kVerifier: return "refused by the FlatBuffers verifier";
    case DecodeError::kVersion: return "unknown schema version";
    case DecodeError::kTopicMismatch: return "stream id differs from the topic";
    case DecodeError::kMissingField: return "required field missing";
    case DecodeError::kChecksum: return "checksum mismatch";
    case DecodeError::kCount: break;
  }
  return "unknown";
}

Decoder::Decoder(size_t max_message_bytes, bool require_checksum)
    : max_bytes_(max_message_bytes), require_checksum_(require_checksum),
      scratch_((max_message_bytes + 7) / 8),
      combined_(max_message_bytes / 16 + 1) {}  // a joint takes >= 16 bytes (position + presence)
Decoder::~Decoder() = default;

MessageKind Decoder::fail(DecodeError error) {
  error_ = error;
  return MessageKind::kNone;
}

using BatchFrames = flatbuffers::Vector<flatbuffers::Offset<fb::Frame>>;

uint64_t Decoder::batch_stream_id(size_t i) const {
  return static_cast<const BatchFrames*>(batch_)->Get(static_cast<flatbuffers::uoffset_t>(i))->stream_id();
}

DecodeError Decoder::batch_frame(size_t i) {
  return read_frame(static_cast<const BatchFrames*>(batch_)->Get(static_cast<flatbuffers::uoffset_t>(i)));
}

DecodeError Decoder::read_frame(const void* table) {
  const auto* f = static_cast<const fb::Frame*>(table);
  if (f->schema_version() != kFrameVersion) return DecodeError::kVersion;
  const auto* positions = f->positions();
  if (!positions || !f->capture_time()) return DecodeError::kMissingField;
  frame_.stream_id = f->stream_id();
  frame_.sequence = f->sequence();
  frame_.capture_ns = f->capture_time()->nanoseconds();
  frame_.joints = static_cast<int>(positions->size());
  frame_.xyz = reinterpret_cast<const float*>(positions->Data());
  frame_.confidence = nullptr;
  if (const auto* c = f->confidence()) {
    if (c->size() != positions->size()) return DecodeError::kMissingField;
    frame_.confidence = c->data();
  }
  const float* presence = nullptr;
  if (const auto* p = f->presence()) {
    if (p->size() != positions->size() || p->size() > combined_.size()) return DecodeError::kMissingField;
    presence = p->data();
  }
  if (require_checksum_ || flatbuffers::IsFieldPresent(f, fb::Frame::VT_CHECKSUM)) {
    if (!flatbuffers::IsFieldPresent(f, fb::Frame::VT_CHECKSUM)) return DecodeError::kMissingField;
    if (f->checksum() != frame_checksum(frame_.stream_id, frame_.sequence, frame_.capture_ns, frame_.xyz,
                                        frame_.joints, frame_.confidence, presence))
      return DecodeError::kChecksum;
  }
  if (presence) {  // MediaPipe's two channels: a joint is as confident as the smaller (NaN stays NaN)
    for (int j = 0; j < frame_.joints; ++j) {
      const float c = frame_.confidence ? frame_.confidence[j] : 1.0f, q = presence[j];
      combined_[static_cast<size_t>(j)] = std::isnan(c) || std::isnan(q) ? NAN : std::fmin(c, q);
    }
    frame_.confidence = combined_.data();
  }
  return DecodeError::kNone;
}

MessageKind Decoder::decode(const void* data, size_t size) {
  error_ = DecodeError::kNone;
  batch_ = nullptr;
  batch_size_ = 0;
  // Topic + root offset + identifier.
  if (size < kTopicBytes + 8) return fail(DecodeError::kTooShort);
  if (size > max_bytes_) return fail(DecodeError::kOversized);
  const auto* bytes = static_cast<const uint8_t*>(data);
  if (!parse_topic(bytes, &stream_id_)) return fail(DecodeError::kBadTopic);
  payload_size_ = size - kTopicBytes;
  payload_ = bytes + kTopicBytes;
  // FlatBuffers reads scalars in place: the buffer must be aligned as it was built (8 bytes).
  if (reinterpret_cast<uintptr_t>(payload_) % 8 != 0) {
    std::memcpy(scratch_.data(), payload_, payload_size_);
    payload_ = reinterpret_cast<const uint8_t*>(scratch_.data());
  }
  // Depth and table limits far below the defaults: a kata message is shallow and small.
  flatbuffers::Verifier::Options options;
  options.max_depth = 8;
  options.max_tables = 64;
  flatbuffers::Verifier verifier(payload_, payload_size_, options);

  if (flatbuffers::BufferHasIdentifier(payload_, fb::FrameIdentifier())) {
    if (!fb::VerifyFrameBuffer(verifier)) return fail(DecodeError::kVerifier);
    const fb::Frame* f = fb::GetFrame(payload_);
    if (f->schema_version() == kFrameVersion && f->stream_id() != stream_id_) return fail(DecodeError::kTopicMismatch);
    const DecodeError e = read_frame(f);
    return e == DecodeError::kNone ? MessageKind::kFrame : fail(e);
  }
  if (flatbuffers::BufferHasIdentifier(payload_, fb::FrameBatchIdentifier())) {
    if (stream_id_ != kBatchStreamId) return fail(DecodeError::kTopicMismatch);
    // A batch holds a table per frame: the table limit is the frame limit (a larger batch is
    // refused whole by the verifier, before anything is read).
    flatbuffers::Verifier::Options batch_options = options;
    batch_options.max_tables = kMaxBatchFrames + 1;
    flatbuffers::Verifier batch_verifier(payload_, payload_size_, batch_options);
    if (!fb::VerifyFrameBatchBuffer(batch_verifier)) {
      // Too many frames, or broken? Only a refused batch pays for asking (its bytes are bounded).
      batch_options.max_tables = std::numeric_limits<flatbuffers::uoffset_t>::max();
      flatbuffers::Verifier unbounded(payload_, payload_size_, batch_options);
      return fail(fb::VerifyFrameBatchBuffer(unbounded) ? DecodeError::kOversized : DecodeError::kVerifier);
    }
    const fb::FrameBatch* k = fb::GetFrameBatch(payload_);
    if (k->schema_version() != kFrameBatchVersion) return fail(DecodeError::kVersion);
    if (!k->frames() || k->frames()->size() == 0) return fail(DecodeError::kMissingField);
    batch_ = k->frames();
    batch_size_ = k->frames()->size();
    return MessageKind::kFrameBatch;
  }
  if (flatbuffers::BufferHasIdentifier(payload_, fb::SkeletonDefinitionIdentifier())) {
    if (!fb::VerifySkeletonDefinitionBuffer(verifier)) return fail(DecodeError::kVerifier);
    const fb::SkeletonDefinition* k = fb::GetSkeletonDefinition(payload_);
    if (k->schema_version() != kSkeletonVersion) return fail(DecodeError::kVersion);
    if (k->stream_id() != stream_id_) return fail(DecodeError::kTopicMismatch);
    if (!k->joint_names() || !k->parents()) return fail(DecodeError::kMissingField);
    return MessageKind::kSkeleton;
  }
  if (flatbuffers::BufferHasIdentifier(payload_, fb::ResultIdentifier())) {
    if (!fb::VerifyResultBuffer(verifier)) return fail(DecodeError::kVerifier);
    const fb::Result* r = fb::GetResult(payload_);
    if (r->schema_version() != kResultVersion) return fail(DecodeError::kVersion);
    if (r->stream_id() != stream_id_) return fail(DecodeError::kTopicMismatch);
    auto ns = [](const fb::Time* t) { return t ? t->nanoseconds() : 0; };
    ResultFields& o = result_;
    o = ResultFields{};
    o.stream_id = r->stream_id();
    o.result_sequence = r->result_sequence();
    o.frame_sequence = r->frame_sequence();
    o.frame_index = r->frame_index();
    o.capture_time = static_cast<double>(ns(r->capture_time())) * 1e-9;
    o.arrival_ns = ns(r->arrival_time());
    o.computed_ns = ns(r->computed_time());
    o.published_ns = ns(r->published_time());
    o.scored = r->scored() ? 1 : 0;
    o.distance = r->distance();
    o.score = r->score();
    if (const auto* parts = r->parts()) {
      const float p[KATA_PART_COUNT] = {parts->torso_head(), parts->left_arm(), parts->right_arm(), parts->left_leg(),
                                        parts->right_leg()};
      std::copy(p, p + KATA_PART_COUNT, o.parts);
    }
    o.matched_teacher_frame = r->matched_teacher_frame();
    o.matched_teacher_time = r->matched_teacher_time();
    if (const auto* scores = r->part_scores()) {
      const float p[KATA_PART_COUNT] = {scores->torso_head(), scores->left_arm(), scores->right_arm(),
                                        scores->left_leg(), scores->right_leg()};
      std::copy(p, p + KATA_PART_COUNT, o.part_scores);
    }
    o.part_to_fix = r->part_to_fix();
    o.state = static_cast<int32_t>(r->feedback_state());
    o.ghost = r->ghost() ? reinterpret_cast<const float*>(r->ghost()->Data()) : nullptr;
    o.ghost_joint_count = r->ghost() ? r->ghost()->size() : 0u;
    if (const auto* practice = r->practice()) {
      o.has_practice = 1;
      o.practice_start_time = practice->start_time();
      o.practice_end_time = practice->end_time();
      o.practice_loop = practice->loop() ? 1 : 0;
      o.practice_revision = practice->revision();
    }
    o.cue_joint = r->cue_joint();
    o.cue_degrees = r->cue_degrees();
    o.cue_action = r->cue_action();
    o.features = r->features() ? r->features()->data() : nullptr;
    o.feature_count = r->features() ? static_cast<int>(r->features()->size()) : 0;
    return MessageKind::kResult;
  }
  if (flatbuffers::BufferHasIdentifier(payload_, fb::PracticeIdentifier())) {
    if (!fb::VerifyPracticeBuffer(verifier)) return fail(DecodeError::kVerifier);
    const fb::Practice* k = fb::GetPractice(payload_);
    if (k->schema_version() != kPracticeVersion) return fail(DecodeError::kVersion);
    if (k->stream_id() != stream_id_) return fail(DecodeError::kTopicMismatch);
    return MessageKind::kPractice;
  }
  if (flatbuffers::BufferHasIdentifier(payload_, fb::StatsIdentifier())) {
    if (!fb::VerifyStatsBuffer(verifier)) return fail(DecodeError::kVerifier);
    if (fb::GetStats(payload_)->schema_version() != 1) return fail(DecodeError::kVersion);
    if (stream_id_ != kStatsStreamId) return fail(DecodeError::kTopicMismatch);
    return MessageKind::kStats;
  }
  return fail(DecodeError::kUnknownIdentifier);
}

SkeletonDefinition Decoder::skeleton() const {
  const fb::SkeletonDefinition* k = fb::GetSkeletonDefinition(payload_);
  SkeletonDefinition d;
  d.stream_id = k->stream_id();
  d.revision = k->revision();
  const auto* names = k->joint_names();
  const auto* parents = k->parents();
  if (names->size() != parents->size())
    throw Error(ErrorKind::kInvalidArgument, "skeleton definition: " + std::to_string(names->size()) +
                                                 " joint names but " + std::to_string(parents->size()) + " parents");
  for (flatbuffers::uoffset_t i = 0; i < names->size(); ++i) {
    d.skeleton.names.push_back(names->Get(i)->str());
    d.skeleton.parents.push_back(parents->Get(i));
  }
  if (const auto* offsets = k->rest_offsets()) {
    if (offsets->size() != names->size())
      throw Error(ErrorKind::kInvalidArgument, "skeleton definition: rest offsets count differs from joints");
    for (const fb::Vec3* v : *offsets) d.skeleton.offsets.emplace_back(v->x(), v->y(), v->z());
    d.skeleton.has_rest_pose = true;
  } else {
    d.skeleton.offsets.assign(names->size(), Eigen::Vector3d::Zero());
  }
  d.skeleton.validate();
  if (k->layout()) d.layout = k->layout()->str();
  if (const auto* m = k->name_map()) {
    if (m->size() != static_cast<flatbuffers::uoffset_t>(kGpdJoints))
      throw Error(ErrorKind::kInvalidArgument, "skeleton definition: name_map must hold 16 names");
    for (const auto* s : *m) d.name_map.push_back(s->str());
  }
  d.up_axis = k->up_axis() == fb::UpAxis::Z ? UpAxis::kZ : UpAxis::kY;
  d.metres_per_unit = k->metres_per_unit();
  d.frame_rate = k->frame_rate();
  d.closed = k->closed();
  return d;
}

PracticeSetting Decoder::practice() const {
  const fb::Practice* k = fb::GetPractice(payload_);
  PracticeSetting p;
  p.stream_id = k->stream_id();
  p.revision = k->revision();
  p.teacher_start = k->teacher_start();
  p.loop = k->loop();
  p.loop_start = k->loop_start();
  p.loop_end = k->loop_end();
  return p;
}

uint32_t Decoder::skeleton_revision() const { return fb::GetSkeletonDefinition(payload_)->revision(); }
int Decoder::skeleton_joints() const {
  return static_cast<int>(fb::GetSkeletonDefinition(payload_)->joint_names()->size());
}
bool Decoder::skeleton_closed() const { return fb::GetSkeletonDefinition(payload_)->closed(); }

}  // namespace kata::transport
