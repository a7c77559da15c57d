// The encoder of every kata message (wire.hpp): FlatBuffers tables behind their topic, built in
// one reused builder and buffer.
#include <climits>
#include <cmath>
#include <cstring>

#include "common/error.hpp"
#include "transport/wire.hpp"
#include "transport/wire_schema.hpp"

namespace kata::transport {

namespace {

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
  flatbuffers::Offset<flatbuffers::String> refused;
  if (!d.refused.empty()) refused = b.CreateString(d.refused);
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
  if (!d.refused.empty()) k.add_refused(refused);
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
  o.add_repetition(r.repetition);
  o.add_repetition_progress(r.repetition_progress);
  if (r.ghost) o.add_ghost(ghost);
  if (r.features) o.add_features(features);
  b.Finish(o.Finish(), fb::ResultIdentifier());
  return finish(r.stream_id, fb::ResultIdentifier());
}

Bytes Encoder::repetition(const kata_repetition& r, int64_t published_ns) {
  auto& b = impl_->builder;
  b.Clear();
  const auto range = b.CreateVector(r.range, static_cast<size_t>(KATA_ROM_JOINT_COUNT));
  const auto teacher_range = b.CreateVector(r.teacher_range, static_cast<size_t>(KATA_ROM_JOINT_COUNT));
  fb::RepetitionBuilder o(b);
  o.add_schema_version(kRepetitionVersion);
  o.add_stream_id(r.stream_id);
  o.add_index(r.index);
  o.add_partial(r.partial != 0);
  o.add_start_time(r.start_time);
  o.add_end_time(r.end_time);
  o.add_tempo(r.tempo);
  o.add_score(r.score);
  o.add_part_to_fix(static_cast<int8_t>(r.part_to_fix));
  o.add_cue_joint(static_cast<int8_t>(r.cue_joint));
  o.add_cue_degrees(r.cue_degrees);
  o.add_cue_action(static_cast<int8_t>(r.cue_action));
  o.add_range(range);
  o.add_teacher_range(teacher_range);
  o.add_coverage(r.coverage);
  const fb::Time published(published_ns);
  o.add_published_time(&published);
  b.Finish(o.Finish(), fb::RepetitionIdentifier());
  return finish(r.stream_id, fb::RepetitionIdentifier());
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

}  // namespace kata::transport
