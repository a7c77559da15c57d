// The decoder of every kata message (wire.hpp): the topic, the FlatBuffers verifier, the schema
// version, the fields and the frame checksum, read in place without allocation.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/error.hpp"
#include "transport/wire.hpp"
#include "transport/wire_schema.hpp"

namespace kata::transport {

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
    o.repetition = r->repetition();
    o.repetition_progress = r->repetition_progress();
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
  if (flatbuffers::BufferHasIdentifier(payload_, fb::RepetitionIdentifier())) {
    if (!fb::VerifyRepetitionBuffer(verifier)) return fail(DecodeError::kVerifier);
    const fb::Repetition* r = fb::GetRepetition(payload_);
    if (r->schema_version() != kRepetitionVersion) return fail(DecodeError::kVersion);
    if (r->stream_id() != stream_id_) return fail(DecodeError::kTopicMismatch);
    kata_repetition& o = repetition_;
    o = kata_repetition{};
    o.struct_size = sizeof o;
    o.stream_id = r->stream_id();
    o.index = r->index();
    o.partial = r->partial() ? 1 : 0;
    o.start_time = r->start_time();
    o.end_time = r->end_time();
    o.tempo = r->tempo();
    o.score = r->score();
    o.part_to_fix = r->part_to_fix();
    o.cue_joint = r->cue_joint();
    o.cue_degrees = r->cue_degrees();
    o.cue_action = r->cue_action();
    // Fewer than eight angles (a shorter writer): the rest stay 0; more: the first eight.
    if (const auto* v = r->range())
      for (flatbuffers::uoffset_t i = 0; i < v->size() && i < KATA_ROM_JOINT_COUNT; ++i) o.range[i] = v->Get(i);
    if (const auto* v = r->teacher_range())
      for (flatbuffers::uoffset_t i = 0; i < v->size() && i < KATA_ROM_JOINT_COUNT; ++i) o.teacher_range[i] = v->Get(i);
    o.coverage = r->coverage();
    repetition_published_ns_ = r->published_time() ? r->published_time()->nanoseconds() : 0;
    return MessageKind::kRepetition;
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
  if (k->refused()) d.refused = k->refused()->str();
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

const char* Decoder::skeleton_refused(size_t* size) const {
  const auto* refused = fb::GetSkeletonDefinition(payload_)->refused();
  if (!refused) return nullptr;
  *size = refused->size();
  return refused->c_str();
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

}  // namespace kata::transport
