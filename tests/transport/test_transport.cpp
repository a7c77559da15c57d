// Wire format and ZeroMQ transport, over loopback only; every wait is bounded.
#include <gtest/gtest.h>
#include <zmq.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "common/error.hpp"
#include "kata_schemas/frame_batch_generated.h"
#include "transport/ingest_table.hpp"
#include "transport/wire.hpp"
#include "transport/zmq_io.hpp"

namespace kata::transport {
namespace {

SkeletonDefinition three_joint_definition(uint64_t stream_id, uint32_t revision = 1) {
  SkeletonDefinition d;
  d.stream_id = stream_id;
  d.revision = revision;
  d.skeleton.names = {"root", "spine", "head"};
  d.skeleton.parents = {-1, 0, 1};
  d.skeleton.offsets = {Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 0.5, 0), Eigen::Vector3d(0, 0.3, 0.1)};
  d.skeleton.has_rest_pose = true;
  d.layout = "";
  d.metres_per_unit = 1.0f;
  d.frame_rate = 120.0f;
  return d;
}

std::vector<float> pose(uint64_t stream_id, uint64_t sequence, int joints) {
  std::vector<float> xyz(static_cast<size_t>(joints) * 3);
  for (size_t i = 0; i < xyz.size(); ++i)
    xyz[i] = static_cast<float>(stream_id) * 10.0f + static_cast<float>(sequence) * 0.01f + static_cast<float>(i);
  return xyz;
}

TEST(runtime_wire, TopicIsSixteenHexDigits) {
  char topic[16];
  write_topic(0x0123456789abcdefULL, topic);
  EXPECT_EQ(std::string(topic, 16), "0123456789abcdef");
  uint64_t id = 0;
  ASSERT_TRUE(parse_topic(reinterpret_cast<const uint8_t*>(topic), &id));
  EXPECT_EQ(id, 0x0123456789abcdefULL);
  topic[3] = 'G';
  EXPECT_FALSE(parse_topic(reinterpret_cast<const uint8_t*>(topic), &id));
}

TEST(runtime_wire, ChecksumIsFnv1aOfTheDocumentedBytes) {
  // FNV-1a 32 of the empty input is the offset basis; of one zero byte it is basis * prime.
  const float xyz[3] = {1.0f, 2.0f, 3.0f};
  uint32_t expected = 2166136261u;
  auto feed = [&](const void* p, size_t n) {
    for (size_t i = 0; i < n; ++i) expected = (expected ^ static_cast<const uint8_t*>(p)[i]) * 16777619u;
  };
  const uint64_t id = 5, seq = 9;
  const int64_t t = 123456789;
  feed(&id, 8);
  feed(&seq, 8);
  feed(&t, 8);
  feed(xyz, sizeof xyz);
  EXPECT_EQ(frame_checksum(id, seq, t, xyz, 1, nullptr), expected);
}

TEST(runtime_wire, FrameRoundTrip) {
  Encoder encoder;
  Decoder decoder;
  const auto xyz = pose(3, 42, 3);
  const float confidence[3] = {1.0f, 0.5f, 0.0f};
  Bytes m = encoder.frame(3, 42, 1'000'000'007LL, xyz.data(), 3, confidence);
  ASSERT_EQ(std::string(reinterpret_cast<const char*>(m.data), 16), "0000000000000003");
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kFrame) << decode_error_name(decoder.error());
  const FrameView& f = decoder.frame();
  EXPECT_EQ(f.stream_id, 3u);
  EXPECT_EQ(f.sequence, 42u);
  EXPECT_EQ(f.capture_ns, 1'000'000'007LL);
  ASSERT_EQ(f.joints, 3);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(f.xyz[i], xyz[static_cast<size_t>(i)]);
  ASSERT_NE(f.confidence, nullptr);
  EXPECT_EQ(f.confidence[1], 0.5f);
}

// MediaPipe's presence (frame.fbs field 7): the reader sees each joint's confidence as
// the smaller of confidence and presence (presence alone without confidence), the checksum
// covers presence, and a frame without it reads as before.
TEST(runtime_wire, PresenceIsReadAsConfidenceWithVisibility) {
  Encoder encoder;
  Decoder decoder;
  const auto xyz = pose(3, 7, 3);
  const float visibility[3] = {0.9f, 0.4f, 0.8f}, presence[3] = {0.6f, 0.9f, NAN};
  Bytes m = encoder.frame(3, 7, 5'000'000LL, xyz.data(), 3, visibility, presence);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kFrame) << decode_error_name(decoder.error());
  ASSERT_NE(decoder.frame().confidence, nullptr);
  EXPECT_EQ(decoder.frame().confidence[0], 0.6f);
  EXPECT_EQ(decoder.frame().confidence[1], 0.4f);
  EXPECT_TRUE(std::isnan(decoder.frame().confidence[2]));
  m = encoder.frame(3, 8, 6'000'000LL, xyz.data(), 3, nullptr, presence);
  copy.assign(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kFrame) << decode_error_name(decoder.error());
  EXPECT_EQ(decoder.frame().confidence[1], 0.9f);
  // A flipped presence value fails the checksum.
  const float flipped[3] = {0.6f, 0.9f, 0.5f};
  const uint32_t good = frame_checksum(3, 8, 6'000'000LL, xyz.data(), 3, nullptr, presence);
  EXPECT_NE(good, frame_checksum(3, 8, 6'000'000LL, xyz.data(), 3, nullptr, flipped));
  EXPECT_NE(good, frame_checksum(3, 8, 6'000'000LL, xyz.data(), 3, nullptr, nullptr));
}

TEST(runtime_wire, MisalignedMessageIsCopiedAndRead) {
  Encoder encoder;
  Decoder decoder;
  const auto xyz = pose(1, 0, 3);
  Bytes m = encoder.frame(1, 0, 5, xyz.data(), 3);
  std::vector<uint8_t> shifted(m.size + 1);
  std::memcpy(shifted.data() + 1, m.data, m.size);
  ASSERT_EQ(decoder.decode(shifted.data() + 1, m.size), MessageKind::kFrame);
  EXPECT_EQ(decoder.frame().xyz[4], xyz[4]);
}

TEST(runtime_wire, SkeletonDefinitionRoundTrip) {
  Encoder encoder;
  Decoder decoder;
  SkeletonDefinition d = three_joint_definition(77, 4);
  d.up_axis = UpAxis::kZ;
  d.name_map.assign(16, "root");
  Bytes m = encoder.skeleton(d);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kSkeleton);
  const SkeletonDefinition back = decoder.skeleton();
  EXPECT_EQ(back.stream_id, 77u);
  EXPECT_EQ(back.revision, 4u);
  EXPECT_EQ(back.skeleton.names, d.skeleton.names);
  EXPECT_EQ(back.skeleton.parents, d.skeleton.parents);
  ASSERT_TRUE(back.skeleton.has_rest_pose);
  EXPECT_FLOAT_EQ(static_cast<float>(back.skeleton.offsets[2].z()), 0.1f);
  EXPECT_EQ(back.up_axis, UpAxis::kZ);
  EXPECT_EQ(back.name_map.size(), 16u);
  EXPECT_EQ(back.frame_rate, 120.0f);
}

TEST(runtime_wire, ResultRoundTrip) {
  Encoder encoder;
  Decoder decoder;
  ResultFields r;
  r.stream_id = 9;
  r.result_sequence = 11;
  r.frame_sequence = 12;
  r.frame_index = 13;
  r.capture_time = 1.5;
  r.arrival_ns = 2;
  r.computed_ns = 3;
  r.published_ns = 4;
  r.scored = true;
  r.distance = 0.25f;
  r.score = 75.0f;
  for (int i = 0; i < 5; ++i) r.parts[i] = 0.01f * static_cast<float>(i);
  r.matched_teacher_frame = 99;
  r.matched_teacher_time = 0.825;
  for (int i = 0; i < 5; ++i) r.part_scores[i] = 50.0f + static_cast<float>(i);
  r.part_to_fix = 3;
  r.state = 3;  // teacher finished
  const auto ghost = pose(9, 1, 4);
  r.ghost = ghost.data();
  r.ghost_joint_count = 4;
  Bytes m = encoder.result(r);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kResult);
  const ResultFields& o = decoder.result();
  EXPECT_EQ(o.result_sequence, 11u);
  EXPECT_EQ(o.frame_sequence, 12u);
  EXPECT_EQ(o.frame_index, 13);
  EXPECT_EQ(o.published_ns, 4);
  EXPECT_EQ(o.capture_time, 1.5);  // seconds in the record, nanoseconds on the wire
  EXPECT_TRUE(o.scored);
  EXPECT_EQ(o.score, 75.0f);
  EXPECT_EQ(o.parts[4], 0.04f);
  EXPECT_EQ(o.matched_teacher_frame, 99);
  EXPECT_EQ(o.matched_teacher_time, 0.825);
  EXPECT_EQ(o.part_scores[0], 50.0f);
  EXPECT_EQ(o.part_scores[4], 54.0f);
  EXPECT_EQ(o.part_to_fix, 3);
  EXPECT_EQ(o.state, 3);
  ASSERT_EQ(o.ghost_joint_count, 4u);
  EXPECT_EQ(o.ghost[11], ghost[11]);
  EXPECT_EQ(o.features, nullptr);
}

TEST(runtime_wire, UnscoredResultHasNoPartScoresAndNoPartToFix) {
  Encoder encoder;
  Decoder decoder;
  ResultFields r;
  r.stream_id = 4;
  Bytes m = encoder.result(r);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kResult);
  EXPECT_FALSE(decoder.result().scored);
  EXPECT_EQ(decoder.result().part_scores[2], 0.0f);
  EXPECT_EQ(decoder.result().part_to_fix, -1);
  EXPECT_EQ(decoder.result().state, 0);
}

// A practice setting (schemas/practice.fbs) round trip, and what no clip can hold, with its reason.
TEST(runtime_wire, PracticeRoundTripAndTheValuesNoClipCanHold) {
  Encoder encoder;
  Decoder decoder;
  PracticeSetting p;
  p.stream_id = 7;
  p.revision = 3;
  p.loop = true;
  p.loop_start = 2.5;
  p.loop_end = 4.0;
  Bytes m = encoder.practice(p);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kPractice);
  const PracticeSetting o = decoder.practice();
  EXPECT_EQ(o.stream_id, 7u);
  EXPECT_EQ(o.revision, 3u);
  EXPECT_TRUE(o.loop);
  EXPECT_EQ(o.loop_start, 2.5);
  EXPECT_EQ(o.loop_end, 4.0);
  EXPECT_EQ(o.teacher_start, 0.0);
  std::vector<uint8_t> truncated(copy.begin(), copy.end() - 8);
  EXPECT_EQ(decoder.decode(truncated.data(), truncated.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kVerifier);

  char why[192];
  EXPECT_EQ(practice_values_problem(p, why, sizeof why), nullptr);
  PracticeSetting start;
  start.teacher_start = 12.0;
  EXPECT_EQ(practice_values_problem(start, why, sizeof why), nullptr);
  EXPECT_EQ(practice_values_problem(PracticeSetting{}, why, sizeof why), nullptr) << "the whole clip";
  struct Bad {
    PracticeSetting p;
    const char* reason;
  };
  const double nan = std::nan(""), inf = INFINITY;
  const Bad bad[] = {
      {{7, 1, nan, false, 0.0, 0.0}, "a time is not finite (teacher_start nan"},
      {{7, 1, 0.0, true, 1.0, inf}, "a time is not finite (teacher_start 0, loop_start 1, loop_end inf)"},
      {{7, 1, -0.5, false, 0.0, 0.0}, "teacher_start -0.5 s is before the teacher's first frame"},
      {{7, 1, 0.0, true, 4.0, 2.0}, "loop_end 2 s is not after loop_start 4 s"},
      {{7, 1, 0.0, true, 3.0, 3.0}, "loop_end 3 s is not after loop_start 3 s"},
      {{7, 1, 0.0, true, -1.0, 3.0}, "loop_start -1 s is before the teacher's first frame"},
      {{7, 1, 5.0, true, 1.0, 3.0}, "teacher_start 5 s and a loop from 1 s: give one or the other"},
  };
  for (const Bad& b : bad) {
    const char* problem = practice_values_problem(b.p, why, sizeof why);
    ASSERT_NE(problem, nullptr) << b.reason;
    EXPECT_EQ(std::string(problem).rfind(b.reason, 0), 0u) << problem;
  }
}

// Every result of a stream with a clip teacher says the practice setting it was computed under;
// one without (or from an older runtime) carries none.
TEST(runtime_wire, ResultCarriesItsPracticeSection) {
  Encoder encoder;
  Decoder decoder;
  ResultFields r;
  r.stream_id = 5;
  r.has_practice = 1;
  r.practice_start_time = 1.25;
  r.practice_end_time = 3.5;
  r.practice_loop = 1;
  r.practice_revision = 4;
  Bytes m = encoder.result(r);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kResult);
  EXPECT_TRUE(decoder.result().has_practice);
  EXPECT_EQ(decoder.result().practice_start_time, 1.25);
  EXPECT_EQ(decoder.result().practice_end_time, 3.5);
  EXPECT_TRUE(decoder.result().practice_loop);
  EXPECT_EQ(decoder.result().practice_revision, 4u);
  r.has_practice = 0;
  m = encoder.result(r);
  copy.assign(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kResult);
  EXPECT_FALSE(decoder.result().has_practice);
  EXPECT_EQ(decoder.result().practice_revision, 0u);
}

TEST(runtime_wire, RefusalsNameTheirReason) {
  Encoder encoder;
  Decoder decoder(4096);
  const auto xyz = pose(2, 0, 3);
  Bytes m = encoder.frame(2, 0, 5, xyz.data(), 3);
  std::vector<uint8_t> good(m.data, m.data + m.size);

  EXPECT_EQ(decoder.decode(good.data(), 10), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kTooShort);

  std::vector<uint8_t> topic = good;
  topic[0] = 'x';
  EXPECT_EQ(decoder.decode(topic.data(), topic.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kBadTopic);

  std::vector<uint8_t> other = good;
  other[15] = '4';  // topic says stream 4, the table says 2
  EXPECT_EQ(decoder.decode(other.data(), other.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kTopicMismatch);

  std::vector<uint8_t> identifier = good;
  identifier[kTopicBytes + 4] = 'Z';
  EXPECT_EQ(decoder.decode(identifier.data(), identifier.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kUnknownIdentifier);

  // A position value changed after encoding: structurally valid, caught by the checksum.
  std::vector<uint8_t> value = good;
  float changed = xyz[4] + 1.0f;
  const auto at = std::search(value.begin(), value.end(), reinterpret_cast<const uint8_t*>(&xyz[4]),
                               reinterpret_cast<const uint8_t*>(&xyz[4]) + 4);
  ASSERT_NE(at, value.end());
  std::memcpy(&*at, &changed, 4);
  EXPECT_EQ(decoder.decode(value.data(), value.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kChecksum);

  std::vector<uint8_t> truncated(good.begin(), good.end() - 8);
  EXPECT_EQ(decoder.decode(truncated.data(), truncated.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kVerifier);

  std::vector<uint8_t> big(5000, '0');
  EXPECT_EQ(decoder.decode(big.data(), big.size()), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kOversized);
}

// ---------------------------------------------------------------------------------------------
// Ingest over ZeroMQ.

struct Received {
  std::vector<uint64_t> streams, sequences;
  std::vector<uint32_t> checksums;
  int restarts_seen = 0;
};

Ingest::Handlers recording(Received& into, int* skeletons) {
  Ingest::Handlers h;
  h.on_skeleton = [skeletons](const SkeletonDefinition&) {
    ++*skeletons;
    return true;
  };
  h.on_frame = [&into](const FrameView& f, bool restarted) {
    into.streams.push_back(f.stream_id);
    into.sequences.push_back(f.sequence);
    into.checksums.push_back(frame_checksum(f.stream_id, f.sequence, f.capture_ns, f.xyz, f.joints, f.confidence));
    if (restarted) ++into.restarts_seen;
  };
  return h;
}

// Polls until `done` or a deadline (bounded: every test stops by itself).
template <typename Done>
bool poll_until(Ingest& ingest, Done done, std::chrono::seconds limit = std::chrono::seconds(20)) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    zmq_pollitem_t item{ingest.socket(), 0, ZMQ_POLLIN, 0};
    zmq_poll(&item, 1, 50);
    ingest.poll(1000);
  }
  return true;
}

TEST(runtime_ingest, HostileMessagesInterleavedWithGoodFrames) {
  Context context;
  IngestOptions options;
  options.kind = IngestKind::kPull;
  options.endpoints = {"bind:tcp://127.0.0.1:*"};
  options.max_message_bytes = 64 * 1024;
  Received received;
  int skeletons = 0;
  Ingest ingest(context, options, recording(received, &skeletons));

  // Build the whole message sequence first (deterministic seed), then push it from a thread.
  std::mt19937_64 rng(20261130);
  Encoder encoder;
  std::vector<std::vector<uint8_t>> messages;
  std::vector<uint32_t> good_checksums;
  std::vector<uint64_t> good_streams, good_sequences;
  const int joints = 3, good_per_stream = 400, bad_total = 10000;
  for (uint64_t s : {1u, 2u}) {
    Bytes m = encoder.skeleton(three_joint_definition(s));
    messages.emplace_back(m.data, m.data + m.size);
  }
  uint64_t next_sequence[3] = {0, 0, 0};
  std::vector<uint8_t> last_good[3];
  int bad_sent = 0, oversized_sent = 0;
  std::uniform_int_distribution<int> pick(0, 5);
  while (bad_sent < bad_total || next_sequence[1] < good_per_stream || next_sequence[2] < good_per_stream) {
    const int choice = pick(rng);
    const uint64_t stream = 1 + (rng() & 1);
    if (choice <= 1 && next_sequence[stream] < good_per_stream) {
      const uint64_t seq = next_sequence[stream]++;
      const auto xyz = pose(stream, seq, joints);
      Bytes m = encoder.frame(stream, seq, static_cast<int64_t>(seq) * 8'333'333, xyz.data(), joints);
      messages.emplace_back(m.data, m.data + m.size);
      last_good[stream] = messages.back();
      good_checksums.push_back(frame_checksum(stream, seq, static_cast<int64_t>(seq) * 8'333'333, xyz.data(), joints,
                                              nullptr));
      good_streams.push_back(stream);
      good_sequences.push_back(seq);
      continue;
    }
    if (bad_sent >= bad_total) continue;
    std::vector<uint8_t> bad;
    const std::vector<uint8_t>& base = last_good[stream];
    switch (choice) {
      case 2: {  // random bytes, sometimes behind a valid topic
        bad.resize(rng() % 300);
        for (auto& b : bad) b = static_cast<uint8_t>(rng());
        if ((rng() & 1) && bad.size() >= 16) std::memcpy(bad.data(), "0000000000000001", 16);
        break;
      }
      case 3:  // truncated good frame (an already sent one, so no future frame is at risk)
        if (base.empty()) continue;
        bad.assign(base.begin(), base.begin() + static_cast<long>(rng() % base.size()));
        break;
      case 4: {  // one bit flipped in an already sent good frame
        if (base.empty()) continue;
        bad = base;
        const size_t bit = rng() % (bad.size() * 8);
        bad[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
        break;
      }
      default: {  // oversized: a well-formed frame of far too many joints
        const int many = 8000;  // 96 KB of positions > 64 KiB limit
        std::vector<float> xyz(static_cast<size_t>(many) * 3, 1.0f);
        Bytes m = encoder.frame(stream, 1u << 30, 0, xyz.data(), many);
        bad.assign(m.data, m.data + m.size);
        ++oversized_sent;
        break;
      }
    }
    messages.push_back(std::move(bad));
    ++bad_sent;
  }

  const std::string endpoint = ingest.endpoint();
  std::thread sender([&] {
    void* push = zmq_socket(context.get(), ZMQ_PUSH);
    int linger = 5000;
    zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
    zmq_connect(push, endpoint.c_str());
    for (const auto& m : messages) zmq_send(push, m.data(), m.size(), 0);
    zmq_close(push);
  });
  const uint64_t total = messages.size();
  const bool finished = poll_until(ingest, [&] { return ingest.counters().received >= total; });
  sender.join();
  ASSERT_TRUE(finished) << "received " << ingest.counters().received << " of " << total;

  const IngestCounters& c = ingest.counters();
  EXPECT_EQ(c.received, total);
  EXPECT_EQ(skeletons, 2);
  // Every good frame was handed on, in order, with its values.
  EXPECT_EQ(c.frames, good_checksums.size());
  EXPECT_EQ(received.checksums, good_checksums);
  EXPECT_EQ(received.streams, good_streams);
  EXPECT_EQ(received.sequences, good_sequences);
  // Every bad message was counted as dropped, each exactly once.
  EXPECT_EQ(c.dropped_total(), static_cast<uint64_t>(bad_sent));
  EXPECT_EQ(c.malformed[static_cast<int>(DecodeError::kOversized)], static_cast<uint64_t>(oversized_sent));
  EXPECT_EQ(c.restarts, 0u);
  EXPECT_EQ(c.sequence_gaps, 0u);
  EXPECT_GT(c.malformed[static_cast<int>(DecodeError::kVerifier)], 0u);
  EXPECT_GT(c.malformed[static_cast<int>(DecodeError::kChecksum)], 0u);
}

TEST(runtime_ingest, UnknownStreamsGapsAndRestartsAreCounted) {
  Context context;
  IngestOptions options;
  options.kind = IngestKind::kPull;
  options.endpoints = {"bind:tcp://127.0.0.1:*"};
  Received received;
  int skeletons = 0;
  Ingest ingest(context, options, recording(received, &skeletons));

  Encoder encoder;
  std::vector<std::vector<uint8_t>> messages;
  auto add = [&](Bytes m) { messages.emplace_back(m.data, m.data + m.size); };
  const auto xyz = pose(1, 0, 3);
  add(encoder.frame(5, 0, 0, xyz.data(), 3));                 // stream 5 never defined
  add(encoder.skeleton(three_joint_definition(5)));
  add(encoder.skeleton(three_joint_definition(5)));           // periodic re-send: not handed on
  for (uint64_t s : {0, 1, 2, 5, 6}) add(encoder.frame(5, s, static_cast<int64_t>(s) + 1, xyz.data(), 3));  // gap 3..4
  add(encoder.frame(5, 4, 100, xyz.data(), 3));               // out of order
  add(encoder.frame(5, 1, 100, pose(1, 0, 2).data(), 2));     // wrong joint count
  for (uint64_t s : {0, 1}) add(encoder.frame(5, s, static_cast<int64_t>(s) + 1000, xyz.data(), 3));  // restart

  const std::string endpoint = ingest.endpoint();
  void* push = zmq_socket(context.get(), ZMQ_PUSH);
  int linger = 2000;
  zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
  ASSERT_EQ(zmq_connect(push, endpoint.c_str()), 0);
  for (const auto& m : messages) zmq_send(push, m.data(), m.size(), 0);
  ASSERT_TRUE(poll_until(ingest, [&] { return ingest.counters().received >= messages.size(); }));
  zmq_close(push);

  const IngestCounters& c = ingest.counters();
  EXPECT_EQ(c.unknown_stream, 1u);
  EXPECT_EQ(c.skeletons, 1u);
  EXPECT_EQ(c.repeated_skeletons, 1u);
  EXPECT_EQ(c.frames, 7u);
  EXPECT_EQ(c.sequence_gaps, 2u);
  EXPECT_EQ(c.out_of_order, 1u);
  EXPECT_EQ(c.wrong_joint_count, 1u);
  EXPECT_EQ(c.restarts, 1u);
  EXPECT_EQ(received.restarts_seen, 1);
  EXPECT_EQ(received.sequences, (std::vector<uint64_t>{0, 1, 2, 5, 6, 0, 1}));
}

// A keyless sender that closes right after its last frames, read by a busy ingest that
// sees the close first. Its streams are its connection's; they used to be orphaned at the close,
// and the frames still waiting in the socket were then refused as another sender's ("not owner":
// the last frame of every stream lost under ASan). They stay the sender's until read; then the
// stream is orphaned (a new sender's definition claims it), and a refused frame of the stream is
// reported to the receiver by its cause.
TEST(runtime_ingest, AClosedSendersQueuedFramesAreStillItsOwn) {
  Context context;
  IngestOptions options;
  options.kind = IngestKind::kPull;
  options.endpoints = {"bind:tcp://127.0.0.1:*"};
  Received received;
  int skeletons = 0;
  Ingest::Handlers handlers = recording(received, &skeletons);
  handlers.on_revision = [](const SkeletonDefinition&) { return true; };  // an orphan claimed
  std::vector<TableVerdict> refused;
  handlers.on_refused_frame = [&refused](uint64_t id, TableVerdict cause) {
    EXPECT_EQ(id, 5u);
    refused.push_back(cause);
  };
  Ingest ingest(context, options, handlers);
  const std::string endpoint = ingest.endpoint();
  Encoder encoder;
  const auto xyz = pose(5, 0, 3);
  // A sender with its own context: terminating it sends everything (linger), then closes.
  auto connect = [&](void* ctx) {
    void* push = zmq_socket(ctx, ZMQ_PUSH);
    const int linger = 10000;
    zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
    EXPECT_EQ(zmq_connect(push, endpoint.c_str()), 0);
    return push;
  };
  auto send = [](void* push, Bytes m) { EXPECT_EQ(zmq_send(push, m.data, m.size, 0), static_cast<int>(m.size)); };

  void* first_ctx = zmq_ctx_new();
  void* first = connect(first_ctx);
  send(first, encoder.skeleton(three_joint_definition(5)));
  send(first, encoder.frame(5, 0, 0, xyz.data(), 3));
  ASSERT_TRUE(poll_until(ingest, [&] { return ingest.counters().frames == 1; }));  // the definition is read
  const uint64_t frames = 100;
  for (uint64_t s = 1; s < frames; ++s) send(first, encoder.frame(5, s, static_cast<int64_t>(s), xyz.data(), 3));
  zmq_close(first);
  zmq_ctx_term(first_ctx);  // every frame is on its way; the connection closes
  // The close is handled before any of those frames is read.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (ingest.counters().disconnections == 0 && std::chrono::steady_clock::now() < deadline) {
    ingest.housekeeping();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(ingest.counters().disconnections, 1u);
  ASSERT_TRUE(poll_until(ingest, [&] { return ingest.counters().received >= frames + 1; }));
  EXPECT_EQ(ingest.counters().frames, frames);
  EXPECT_EQ(ingest.counters().not_owner, 0u);
  EXPECT_TRUE(refused.empty());
  EXPECT_EQ(received.sequences.size(), frames);

  // Read, the stream is orphaned: a new sender's definition claims it, its frames are taken
  // (a restart), and a third sender's frame for it is refused and reported.
  void* second_ctx = zmq_ctx_new();
  void* second = connect(second_ctx);
  send(second, encoder.skeleton(three_joint_definition(5)));
  send(second, encoder.frame(5, 0, 1000, xyz.data(), 3));
  ASSERT_TRUE(poll_until(ingest, [&] { return ingest.counters().frames == frames + 1; }));
  void* third_ctx = zmq_ctx_new();
  void* third = connect(third_ctx);
  send(third, encoder.frame(5, 1, 1001, xyz.data(), 3));
  ASSERT_TRUE(poll_until(ingest, [&] { return ingest.counters().not_owner == 1; }));
  EXPECT_EQ(refused, (std::vector<TableVerdict>{TableVerdict::kNotOwner}));
  EXPECT_EQ(received.restarts_seen, 1);
  for (auto [socket, ctx] : {std::pair{second, second_ctx}, std::pair{third, third_ctx}}) {
    zmq_close(socket);
    zmq_ctx_term(ctx);
  }
}

// The documented hash (kata.h, kata_shard_of); the expected values come from an independent
// Python implementation of FNV-1a 64 over the id's little-endian bytes (tests/runtime/shard_check.py).
TEST(runtime_shard, ShardOfIsFnv1a64OfTheIdBytesModCount) {
  EXPECT_EQ(shard_of(0, 3), 1u);    // FNV-1a 64 = 12161962213042174405
  EXPECT_EQ(shard_of(1, 3), 0u);    // 9929646806074584996
  EXPECT_EQ(shard_of(7, 3), 1u);    // 5465015992139406178
  EXPECT_EQ(shard_of(7, 5), 3u);
  EXPECT_EQ(shard_of(100, 5), 3u);  // 879817313296471393
  EXPECT_EQ(shard_of(18446744073709551614ULL, 3), 2u);
  EXPECT_EQ(shard_of(18446744073709551614ULL, 5), 1u);
  EXPECT_EQ(shard_of(12345, 1), 0u);
  EXPECT_EQ(shard_of(12345, 0), 0u);
}

// A shard's ingest keeps its own streams and counts the others' messages apart from refusals.
TEST(runtime_shard, IngestKeepsItsShardsStreamsOnly) {
  Context context;
  IngestOptions options;
  options.endpoints = {"bind:inproc://shard-test"};
  options.shard_count = 3;
  options.shard_index = 1;  // streams 0 and 7 (shard_of above); stream 1 is shard 0's
  Received received;
  int skeletons = 0;
  Ingest ingest(context, options, recording(received, &skeletons));
  Encoder encoder;
  const auto xyz = pose(1, 0, 3);
  auto handle = [&](Bytes m) { ingest.handle(m.data, m.size); };
  for (uint64_t id : {0, 1, 7}) handle(encoder.skeleton(three_joint_definition(id)));
  for (uint64_t seq = 0; seq < 4; ++seq)
    for (uint64_t id : {0, 1, 7}) handle(encoder.frame(id, seq, static_cast<int64_t>(seq) + 1, xyz.data(), 3));
  const IngestCounters& c = ingest.counters();
  EXPECT_EQ(c.skeletons, 2u);
  EXPECT_EQ(c.frames, 8u);
  EXPECT_EQ(c.other_shard, 5u);  // stream 1: its definition and four frames
  EXPECT_EQ(c.dropped_total(), 0u);
  EXPECT_EQ(skeletons, 2);
  options.shard_index = 3;
  EXPECT_THROW(Ingest(context, options, recording(received, &skeletons)), Error);
}

// ---------------------------------------------------------------------------------------------
// Frame batches (schemas/frame_batch.fbs): many streams' frames in one message, each frame read
// and checked as its own Frame message would be.

// A batch's bytes made with the generated API, so that a test can write what kata's encoder never
// does (a wrong checksum, another version, no frames, too many).
struct HandFrame {
  uint64_t stream_id = 0, sequence = 0;
  int64_t capture_ns = 0;
  std::vector<float> xyz;
  bool good_checksum = true;
  uint16_t version = 1;
};
std::vector<uint8_t> hand_batch(const std::vector<HandFrame>& frames, uint16_t version = 1,
                                const std::string& topic = "fffffffffffffffe", bool no_frames_field = false) {
  flatbuffers::FlatBufferBuilder b;
  std::vector<flatbuffers::Offset<fb::Frame>> tables;
  for (const HandFrame& f : frames) {
    const int joints = static_cast<int>(f.xyz.size() / 3);
    const auto positions = b.CreateVectorOfStructs(reinterpret_cast<const fb::Vec3*>(f.xyz.data()), static_cast<size_t>(joints));
    fb::FrameBuilder k(b);
    k.add_schema_version(f.version);
    k.add_stream_id(f.stream_id);
    k.add_sequence(f.sequence);
    const fb::Time t(f.capture_ns);
    k.add_capture_time(&t);
    k.add_positions(positions);
    const uint32_t sum = frame_checksum(f.stream_id, f.sequence, f.capture_ns, f.xyz.data(), joints, nullptr);
    k.add_checksum(f.good_checksum ? sum : sum ^ 1u);
    tables.push_back(k.Finish());
  }
  const auto v = b.CreateVector(tables);
  fb::FrameBatchBuilder k(b);
  k.add_schema_version(version);
  if (!no_frames_field) k.add_frames(v);
  b.Finish(k.Finish(), fb::FrameBatchIdentifier());
  std::vector<uint8_t> m(16 + b.GetSize());
  std::memcpy(m.data(), topic.data(), 16);
  std::memcpy(m.data() + 16, b.GetBufferPointer(), b.GetSize());
  return m;
}

HandFrame hand_frame(uint64_t id, uint64_t seq, int joints = 3) {
  HandFrame f;
  f.stream_id = id;
  f.sequence = seq;
  f.capture_ns = static_cast<int64_t>(seq + 1) * 8'333'333;
  f.xyz = pose(id, seq, joints);
  return f;
}

TEST(runtime_wire, FrameBatchCarriesEachFrameAsItsOwnMessageWould) {
  Encoder encoder;
  Decoder batch_decoder, single;
  const auto a = pose(3, 42, 3), b = pose(9, 7, 4), c = pose(3, 43, 3);
  const float confidence[4] = {1.0f, 0.5f, 0.0f, 0.25f}, presence[3] = {0.6f, 0.9f, NAN};
  const Encoder::BatchFrame frames[3] = {{3, 42, 1'000'000'007LL, a.data(), 3, nullptr, nullptr},
                                         {9, 7, 2'000'000'000LL, b.data(), 4, confidence, nullptr},
                                         {3, 43, 1'008'333'340LL, c.data(), 3, confidence, presence}};
  const Bytes m = encoder.frame_batch(frames, 3);
  ASSERT_EQ(std::string(reinterpret_cast<const char*>(m.data), 16), "fffffffffffffffe");
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(batch_decoder.decode(copy.data(), copy.size()), MessageKind::kFrameBatch)
      << decode_error_name(batch_decoder.error());
  EXPECT_EQ(batch_decoder.stream_id(), kBatchStreamId);
  ASSERT_EQ(batch_decoder.batch_size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const Encoder::BatchFrame& e = frames[i];
    EXPECT_EQ(batch_decoder.batch_stream_id(i), e.stream_id);
    ASSERT_EQ(batch_decoder.batch_frame(i), DecodeError::kNone) << i;
    const FrameView got = batch_decoder.frame();
    // The same frame sent alone reads back the same values (confidence combined with presence).
    const Bytes alone = encoder.frame(e.stream_id, e.sequence, e.capture_ns, e.xyz, e.joints, e.confidence, e.presence);
    std::vector<uint8_t> alone_copy(alone.data, alone.data + alone.size);
    ASSERT_EQ(single.decode(alone_copy.data(), alone_copy.size()), MessageKind::kFrame);
    const FrameView& want = single.frame();
    EXPECT_EQ(got.stream_id, want.stream_id);
    EXPECT_EQ(got.sequence, want.sequence);
    EXPECT_EQ(got.capture_ns, e.capture_ns);
    ASSERT_EQ(got.joints, e.joints);
    EXPECT_EQ(std::memcmp(got.xyz, e.xyz, sizeof(float) * 3 * static_cast<size_t>(e.joints)), 0);
    ASSERT_EQ(got.confidence == nullptr, e.confidence == nullptr && e.presence == nullptr);
    for (int j = 0; got.confidence && j < e.joints; ++j) {
      const float c_in = e.confidence ? e.confidence[j] : 1.0f, p_in = e.presence ? e.presence[j] : c_in;
      const float expected = std::isnan(p_in) ? NAN : std::fmin(c_in, p_in);
      if (std::isnan(expected)) EXPECT_TRUE(std::isnan(got.confidence[j]));
      else EXPECT_EQ(got.confidence[j], expected) << "frame " << i << " joint " << j;
      if (std::isnan(expected)) EXPECT_TRUE(std::isnan(want.confidence[j]));
      else EXPECT_EQ(got.confidence[j], want.confidence[j]);
    }
  }
  // Misaligned as ZeroMQ may hand it over: copied and read the same.
  std::vector<uint8_t> shifted(copy.size() + 1);
  std::memcpy(shifted.data() + 1, copy.data(), copy.size());
  ASSERT_EQ(batch_decoder.decode(shifted.data() + 1, copy.size()), MessageKind::kFrameBatch);
  ASSERT_EQ(batch_decoder.batch_frame(1), DecodeError::kNone);
  EXPECT_EQ(batch_decoder.frame().xyz[11], b[11]);
  // The encoder refuses an empty batch and one beyond the limit.
  EXPECT_THROW(encoder.frame_batch(frames, 0), Error);
  std::vector<Encoder::BatchFrame> many(kMaxBatchFrames + 1, frames[0]);
  EXPECT_THROW(encoder.frame_batch(many.data(), many.size()), Error);
}

TEST(runtime_wire, FrameBatchRefusalsNameTheirReason) {
  Decoder decoder(1 << 20);
  // The decoder reads the message in place: the last one decoded is kept alive here.
  std::vector<uint8_t> held;
  auto kind = [&](std::vector<uint8_t> m) {
    held = std::move(m);
    return decoder.decode(held.data(), held.size());
  };
  // A good batch, then the same with one frame's checksum wrong: the batch is read, that frame alone refused.
  std::vector<HandFrame> frames = {hand_frame(1, 0), hand_frame(2, 0), hand_frame(1, 1)};
  ASSERT_EQ(kind(hand_batch(frames)), MessageKind::kFrameBatch);
  frames[1].good_checksum = false;
  frames[2].version = 2;
  ASSERT_EQ(kind(hand_batch(frames)), MessageKind::kFrameBatch);
  EXPECT_EQ(decoder.batch_frame(0), DecodeError::kNone);
  EXPECT_EQ(decoder.batch_frame(1), DecodeError::kChecksum);
  EXPECT_EQ(decoder.batch_frame(2), DecodeError::kVersion);
  EXPECT_EQ(decoder.batch_frame(0), DecodeError::kNone);  // order does not matter: each is read alone
  EXPECT_EQ(decoder.frame().stream_id, 1u);
  frames[1].good_checksum = true;
  frames[2].version = 1;
  // The whole batch refused, each by its cause.
  EXPECT_EQ(kind(hand_batch(frames, 2)), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kVersion);
  EXPECT_EQ(kind(hand_batch({})), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kMissingField);
  EXPECT_EQ(kind(hand_batch(frames, 1, "fffffffffffffffe", true)), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kMissingField);
  EXPECT_EQ(kind(hand_batch(frames, 1, "0000000000000001")), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kTopicMismatch) << "a batch's topic is 2^64-2";
  std::vector<uint8_t> truncated = hand_batch(frames);
  truncated.resize(truncated.size() - 20);
  EXPECT_EQ(kind(truncated), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kVerifier);
  // Too many frames (4097 one-joint frames fit the byte limit): oversized, not a broken buffer.
  std::vector<HandFrame> many;
  for (uint64_t i = 0; i <= kMaxBatchFrames; ++i) many.push_back(hand_frame(i, 0, 1));
  EXPECT_EQ(kind(hand_batch(many)), MessageKind::kNone);
  EXPECT_EQ(decoder.error(), DecodeError::kOversized);
  many.pop_back();
  ASSERT_EQ(kind(hand_batch(many)), MessageKind::kFrameBatch) << decode_error_name(decoder.error());
  EXPECT_EQ(decoder.batch_size(), kMaxBatchFrames);
  // More bytes than the decoder's limit.
  Decoder small(4096);
  const std::vector<uint8_t> big = hand_batch(many);
  EXPECT_EQ(small.decode(big.data(), big.size()), MessageKind::kNone);
  EXPECT_EQ(small.error(), DecodeError::kOversized);
}

// A batch's frames through the ingest's rules one by one, from the batch's sender: refused frames
// counted by cause (and on their stream), the others handed on in the batch's order, and the
// counters adding up with a batch counted as its frames.
// The stats message carries the batch counters (added with frame batches), so a monitor can
// balance received against the outcomes.
TEST(runtime_wire, StatsCarryTheBatchCounters) {
  Encoder encoder;
  Decoder decoder;
  StatsFields f;
  f.received = 12;
  f.batches = 3;
  f.batch_frames = 191;
  f.frames = 190;
  const Bytes m = encoder.stats(f);
  std::vector<uint8_t> copy(m.data, m.data + m.size);
  ASSERT_EQ(decoder.decode(copy.data(), copy.size()), MessageKind::kStats);
  const StatsFields back = decoder.stats();
  EXPECT_EQ(back.batches, 3u);
  EXPECT_EQ(back.batch_frames, 191u);
  EXPECT_EQ(back.received, 12u);
}

TEST(runtime_ingest, BatchFramesAreJudgedOneByOne) {
  Context context;
  IngestOptions options;
  options.endpoints = {"bind:inproc://batch-ingest-test"};
  options.limits.max_frame_age_ns = 0;
  options.log_refusals = false;
  Received received;
  int skeletons = 0;
  Ingest::Handlers handlers = recording(received, &skeletons);
  std::vector<std::pair<uint64_t, TableVerdict>> refused_on_stream;
  handlers.on_refused_frame = [&](uint64_t id, TableVerdict v) { refused_on_stream.emplace_back(id, v); };
  Ingest ingest(context, options, handlers);
  Encoder encoder;
  const SenderToken a = connection_sender(1, 0), b = connection_sender(2, 0);
  auto handle = [&](const std::vector<uint8_t>& m, SenderToken from) { ingest.handle(m.data(), m.size(), from); };
  auto bytes = [](Bytes m) { return std::vector<uint8_t>(m.data, m.data + m.size); };
  handle(bytes(encoder.skeleton(three_joint_definition(1))), a);
  handle(bytes(encoder.skeleton(three_joint_definition(2))), b);
  std::vector<HandFrame> from_a = {hand_frame(1, 0), hand_frame(1, 1),
                                   hand_frame(2, 0),      // b's stream: not a's
                                   hand_frame(1, 1),      // the same sequence again: out of order
                                   hand_frame(3, 0),      // never defined
                                   hand_frame(1, 2, 2),   // two joints, the definition has three
                                   hand_frame(1, 3),      // its checksum wrong (below)
                                   hand_frame(1, 4)};
  from_a[6].good_checksum = false;
  handle(hand_batch(from_a), a);
  handle(hand_batch({hand_frame(2, 0), hand_frame(2, 1)}), b);
  handle(hand_batch({hand_frame(1, 5)}, 1, "0000000000000001"), a);  // a batch on a stream's topic: refused whole
  const IngestCounters& c = ingest.counters();
  EXPECT_EQ(c.batches, 2u);
  EXPECT_EQ(c.batch_frames, 10u);
  EXPECT_EQ(c.frames, 5u);
  EXPECT_EQ(c.not_owner, 1u);
  EXPECT_EQ(c.out_of_order, 1u);
  EXPECT_EQ(c.unknown_stream, 1u);
  EXPECT_EQ(c.wrong_joint_count, 1u);
  EXPECT_EQ(c.malformed[static_cast<int>(DecodeError::kChecksum)], 1u);
  EXPECT_EQ(c.malformed[static_cast<int>(DecodeError::kTopicMismatch)], 1u);
  EXPECT_EQ(received.streams, (std::vector<uint64_t>{1, 1, 1, 2, 2}));
  EXPECT_EQ(received.sequences, (std::vector<uint64_t>{0, 1, 4, 0, 1}));
  EXPECT_EQ(refused_on_stream, (std::vector<std::pair<uint64_t, TableVerdict>>{
                                   {2, TableVerdict::kNotOwner}, {1, TableVerdict::kOutOfOrder}, {1, TableVerdict::kWrongJoints}}));
  // handle() is called directly here (received counts socket reads): 2 definitions + 3 batch messages.
  const uint64_t items = 5 - c.batches + c.batch_frames;
  EXPECT_EQ(c.frames + c.skeletons + c.repeated_skeletons + c.closes + c.other_shard + c.dropped_total(), items);
}

// A shard keeps its own streams' frames of a batch (the batch's topic is nobody's shard) and
// counts the others' as other_shard, one per frame.
TEST(runtime_shard, BatchFramesOfOtherShardsAreCountedApart) {
  Context context;
  IngestOptions options;
  options.endpoints = {"bind:inproc://shard-batch-test"};
  options.shard_count = 3;
  options.shard_index = 1;  // streams 0 and 7; stream 1 is shard 0's; the batch topic's would be 2
  options.limits.max_frame_age_ns = 0;
  Received received;
  int skeletons = 0;
  Ingest ingest(context, options, recording(received, &skeletons));
  Encoder encoder;
  for (uint64_t id : {0, 7}) {
    const Bytes m = encoder.skeleton(three_joint_definition(id));
    ingest.handle(m.data, m.size);
  }
  for (uint64_t seq = 0; seq < 4; ++seq) {
    const std::vector<uint8_t> m = hand_batch({hand_frame(0, seq), hand_frame(1, seq), hand_frame(7, seq)});
    ingest.handle(m.data(), m.size());
  }
  const IngestCounters& c = ingest.counters();
  EXPECT_EQ(c.frames, 8u);
  EXPECT_EQ(c.other_shard, 4u);
  EXPECT_EQ(c.dropped_total(), 0u);
  EXPECT_EQ(received.streams, (std::vector<uint64_t>{0, 7, 0, 7, 0, 7, 0, 7}));
}

TEST(runtime_publisher, SeesEachJoinWithItsTopicAndNeverBlocks) {
  Context context;
  PublisherOptions options;
  options.endpoints = {"tcp://127.0.0.1:*"};
  options.send_hwm = 10;
  Publisher publisher(context, options);

  void* sub = zmq_socket(context.get(), ZMQ_SUB);
  int linger = 0;
  zmq_setsockopt(sub, ZMQ_LINGER, &linger, sizeof linger);
  ASSERT_EQ(zmq_connect(sub, publisher.endpoint().c_str()), 0);
  char topic[16];
  write_topic(7, topic);
  zmq_setsockopt(sub, ZMQ_SUBSCRIBE, topic, 16);

  std::string joined;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (joined.empty() && std::chrono::steady_clock::now() < deadline) {
    zmq_pollitem_t item{publisher.socket(), 0, ZMQ_POLLIN, 0};
    zmq_poll(&item, 1, 50);
    publisher.poll_joins([&](const uint8_t* p, size_t n) { joined.assign(reinterpret_cast<const char*>(p), n); });
  }
  EXPECT_EQ(joined, std::string(topic, 16));

  // The subscriber never reads: sends still return at once (DONTWAIT; a PUB drops at its HWM).
  Encoder encoder;
  const auto xyz = pose(7, 0, 3);
  for (int i = 0; i < 5000; ++i) publisher.send(encoder.frame(7, static_cast<uint64_t>(i), i, xyz.data(), 3));
  EXPECT_EQ(publisher.sent() + publisher.failed(), 5000u);
  zmq_close(sub);
}

// A message read after its connection's close was seen (it waited in the socket's queue) is
// from kClosedConnection: the stream it defines is an orphan, so the source's next connection
// claims it with its next definition, and no dead sender keeps it locked.
// Practice settings through the ingest (handed in with their senders): only the owner's reach the
// receiver, in order; a re-send of the revision in force is not handed on; every other one is
// counted by its cause, and the messages still add up.
TEST(runtime_ingest, PracticeSettingsAreTheOwnersAndCountedByCause) {
  Context context;
  IngestOptions options;
  options.kind = IngestKind::kPull;
  options.endpoints = {"bind:tcp://127.0.0.1:*"};
  options.log_refusals = false;
  Received received;
  int skeletons = 0;
  Ingest::Handlers handlers = recording(received, &skeletons);
  handlers.on_revision = [](const SkeletonDefinition&) { return true; };
  std::vector<PracticeSetting> handed;
  handlers.on_practice = [&handed](const PracticeSetting& p, std::string* why) {
    if (p.teacher_start > 100.0) {  // this receiver's clip is 100 s long
      *why = "outside";
      return TableVerdict::kPracticeOutsideClip;
    }
    handed.push_back(p);
    return TableVerdict::kAccepted;
  };
  Ingest ingest(context, options, handlers);
  const SenderToken owner = connection_sender(3, 0), other = connection_sender(4, 0);
  Encoder encoder;
  auto send = [&](Bytes m, SenderToken from) { ingest.handle(m.data, m.size, from, 1'000); };
  auto practice = [](uint64_t id, uint32_t revision, double start) {
    PracticeSetting p;
    p.stream_id = id;
    p.revision = revision;
    p.teacher_start = start;
    return p;
  };
  send(encoder.practice(practice(5, 1, 2.0)), owner);  // before its definition
  send(encoder.skeleton(three_joint_definition(5)), owner);
  send(encoder.practice(practice(5, 1, 2.0)), owner);
  send(encoder.practice(practice(5, 1, 2.0)), owner);   // re-sent: not handed on
  send(encoder.practice(practice(5, 2, 9.0)), other);   // another sender's
  send(encoder.practice(practice(5, 2, -1.0)), owner);  // no clip holds it
  send(encoder.practice(practice(5, 2, 500.0)), owner); // outside this clip
  send(encoder.practice(practice(5, 2, 6.0)), owner);
  // A new definition forgets the setting: the same revision is taken again (a reopened stream).
  send(encoder.skeleton(three_joint_definition(5, 2)), owner);
  send(encoder.practice(practice(5, 2, 6.0)), owner);
  ASSERT_EQ(handed.size(), 3u);
  EXPECT_EQ(handed[0].teacher_start, 2.0);
  EXPECT_EQ(handed[1].teacher_start, 6.0);
  EXPECT_EQ(handed[2].revision, 2u);
  const IngestCounters& c = ingest.counters();
  EXPECT_EQ(c.practices, 3u);
  EXPECT_EQ(c.repeated_practices, 1u);
  EXPECT_EQ(c.unknown_stream, 1u);
  EXPECT_EQ(c.not_owner, 1u);
  EXPECT_EQ(c.practice_bad_values, 1u);
  EXPECT_EQ(c.practice_outside_clip, 1u);
  EXPECT_EQ(c.skeletons, 2u);
  EXPECT_EQ(c.frames + c.skeletons + c.repeated_skeletons + c.closes + c.practices + c.repeated_practices +
                c.other_shard + c.dropped_total(),
            10u);
}

TEST(runtime_ingest_table, LateMessagesOfAClosedConnectionOwnNothing) {
  IngestTable table;
  const SenderToken reconnected = connection_sender(7, 1), other = connection_sender(8, 0);
  bool is_new = false;
  ASSERT_EQ(table.judge_definition(kClosedConnection, 42, 1, &is_new), TableVerdict::kAccepted);
  EXPECT_TRUE(is_new);
  table.commit_definition(kClosedConnection, 42, 1, 3, 0);
  // Its own late frames still reach the orphan, in order.
  bool restarted = false;
  uint64_t gap = 0;
  int64_t age = 0;
  EXPECT_EQ(table.judge_frame(kClosedConnection, 42, 0, 0, 3, 1, &restarted, &gap, &age), TableVerdict::kAccepted);
  // Frames from another sender are refused until it defines the stream; then it owns it.
  EXPECT_EQ(table.judge_frame(reconnected, 42, 1, 0, 3, 2, &restarted, &gap, &age), TableVerdict::kNotOwner);
  ASSERT_EQ(table.judge_definition(reconnected, 42, 1, &is_new), TableVerdict::kAccepted);
  EXPECT_FALSE(is_new);
  table.commit_definition(reconnected, 42, 1, 3, 3);
  EXPECT_EQ(table.judge_frame(reconnected, 42, 1, 0, 3, 4, &restarted, &gap, &age), TableVerdict::kAccepted);
  // Now owned: neither a third sender nor a late message of a closed connection may take it.
  EXPECT_EQ(table.judge_definition(other, 42, 2, &is_new), TableVerdict::kNotOwner);
  EXPECT_EQ(table.judge_definition(kClosedConnection, 42, 2, &is_new), TableVerdict::kNotOwner);
  EXPECT_EQ(table.judge_frame(kClosedConnection, 42, 2, 0, 3, 5, &restarted, &gap, &age), TableVerdict::kNotOwner);
  // A closed connection's streams count against no sender's limit.
  IngestTable small(IngestLimits{4, 1});
  for (uint64_t id = 1; id <= 3; ++id) {
    ASSERT_EQ(small.judge_definition(kClosedConnection, id, 1, &is_new), TableVerdict::kAccepted);
    small.commit_definition(kClosedConnection, id, 1, 3, 0);
  }
  EXPECT_EQ(small.streams(), 3u);
}

// Stale frames said once, when a source is the cause: a capture clock at half the host's rate (a
// replay at half speed stamping clip times) keeps every frame stale with its age growing 0.5 s a
// second, and is explained once per run with that rate; a backlog after an outage (old frames
// arriving together, their ages falling, then fresh ones) is dropped without a word.
TEST(runtime_ingest_table, AStreamStaleWithAgesGrowingIsExplainedOnceABacklogIsNot) {
  IngestTable table;  // max_frame_age 250 ms
  const SenderToken sender = connection_sender(5, 0);
  bool is_new = false, restarted = false;
  uint64_t gap = 0;
  int64_t age = 0;
  ASSERT_EQ(table.judge_definition(sender, 1, 1, &is_new), TableVerdict::kAccepted);
  table.commit_definition(sender, 1, 1, 3, 0);
  const int64_t frame = 8'333'333;  // 120 Hz
  int explained = 0, stale = 0;
  double growth = 0.0;
  int64_t explained_age = 0;
  for (uint64_t k = 0; k < 360; ++k) {  // capture k frames, arrival 2k frames (+1 s)
    const int64_t capture = static_cast<int64_t>(k) * frame, arrival = 1'000'000'000 + 2 * capture;
    const TableVerdict v = table.judge_frame(sender, 1, k, capture, 3, arrival, &restarted, &gap, &age);
    EXPECT_EQ(age, capture);  // each frame one frame time later behind its capture than the last
    if (v == TableVerdict::kStale) {
      ++stale;
      double g = 0.0;
      int64_t a = 0;
      if (table.stale_run_to_explain(1, &g, &a)) ++explained, growth = g, explained_age = a;
    }
  }
  EXPECT_EQ(stale, 360 - 31);  // ages 0 .. 30 frames (250 ms) pass
  EXPECT_EQ(explained, 1);
  EXPECT_NEAR(growth, 0.5, 1e-9);
  EXPECT_EQ(explained_age, (31 + IngestTable::kStaleRunToExplain - 1) * frame);
  // A fresh frame ends the run; a new run is explained again.
  const int64_t fresh_capture = 400 * frame;
  EXPECT_EQ(table.judge_frame(sender, 1, 400, fresh_capture, 3, 1'000'000'000 + fresh_capture, &restarted, &gap, &age),
            TableVerdict::kAccepted);
  EXPECT_EQ(age, 0);
  explained = 0;
  for (uint64_t j = 1; j <= 120; ++j) {
    const int64_t capture = fresh_capture + static_cast<int64_t>(j) * frame;
    table.judge_frame(sender, 1, 400 + j, capture, 3, 1'000'000'000 + fresh_capture + 2 * static_cast<int64_t>(j) * frame,
                      &restarted, &gap, &age);
    double g = 0.0;
    int64_t a = 0;
    explained += table.stale_run_to_explain(1, &g, &a);
  }
  EXPECT_EQ(explained, 1);

  // Stream 2: live at 120 Hz, then a 2 s outage whose 240 queued frames arrive within 24 ms, then
  // live again: the backlog's ages fall from 2 s; nothing to explain.
  ASSERT_EQ(table.judge_definition(sender, 2, 1, &is_new), TableVerdict::kAccepted);
  table.commit_definition(sender, 2, 1, 3, 0);
  uint64_t sequence = 0;
  for (int k = 0; k < 120; ++k, ++sequence)
    EXPECT_EQ(table.judge_frame(sender, 2, sequence, k * frame, 3, 5 + k * frame, &restarted, &gap, &age),
              TableVerdict::kAccepted);
  stale = 0;
  const int64_t back = 120 * frame + 2'000'000'000;
  for (int k = 0; k < 240; ++k, ++sequence) {
    const TableVerdict v =
        table.judge_frame(sender, 2, sequence, (120 + k) * frame, 3, 5 + back + k * 100'000, &restarted, &gap, &age);
    stale += v == TableVerdict::kStale;
    double g = 0.0;
    int64_t a = 0;
    EXPECT_FALSE(table.stale_run_to_explain(2, &g, &a)) << k;
  }
  EXPECT_GT(stale, 200);
  EXPECT_EQ(table.judge_frame(sender, 2, sequence, 360 * frame, 3, 5 + 360 * frame + 1'000'000, &restarted, &gap, &age),
            TableVerdict::kAccepted);
}

// The premise of a keyless ingest's senders (zmq_io.cpp): with a ZAP domain set, libzmq asks the
// context's ZAP handler about every NULL-mechanism connection too, and the number the handler
// answers arrives on each message of that connection as its User-Id. Two connections, two numbers,
// the later one larger; a NULL request of another domain is refused (no message gets through).
TEST(runtime_ingest, KeylessConnectionsCarryTheNumberTheZapHandlerGaveThem) {
  Context context;
  context.number_connections();
  auto bound = [&](const char* domain) {
    void* pull = zmq_socket(context.get(), ZMQ_PULL);
    int linger = 0;
    zmq_setsockopt(pull, ZMQ_LINGER, &linger, sizeof linger);
    zmq_setsockopt(pull, ZMQ_ZAP_DOMAIN, domain, std::strlen(domain));
    zmq_bind(pull, "tcp://127.0.0.1:*");
    return pull;
  };
  auto endpoint_of = [](void* socket) {
    char text[256];
    size_t size = sizeof text;
    zmq_getsockopt(socket, ZMQ_LAST_ENDPOINT, text, &size);
    return std::string(text);
  };
  void* pull = bound(kConnectionDomain);
  void* senders = zmq_ctx_new();
  auto pusher = [&](const std::string& endpoint) {
    void* push = zmq_socket(senders, ZMQ_PUSH);
    int linger = 0;
    zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
    zmq_connect(push, endpoint.c_str());
    return push;
  };
  // Each message's User-Id (empty when none came within 2 s).
  auto user_of_next = [](void* socket, int timeout_ms) {
    zmq_pollitem_t item{socket, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&item, 1, timeout_ms) <= 0) return std::string();
    zmq_msg_t message;
    zmq_msg_init(&message);
    std::string user = "(no message)";
    if (zmq_msg_recv(&message, socket, 0) >= 0) {
      const char* u = zmq_msg_gets(&message, "User-Id");
      user = u ? u : "(none)";
    }
    zmq_msg_close(&message);
    return user;
  };
  void* first = pusher(endpoint_of(pull));
  zmq_send(first, "a", 1, 0);
  const std::string first_user = user_of_next(pull, 2000);
  void* second = pusher(endpoint_of(pull));
  zmq_send(second, "b", 1, 0);
  const std::string second_user = user_of_next(pull, 2000);
  zmq_send(first, "c", 1, 0);
  const std::string first_again = user_of_next(pull, 2000);
  ASSERT_FALSE(first_user.empty());
  ASSERT_FALSE(second_user.empty());
  EXPECT_EQ(first_user.find_first_not_of("0123456789"), std::string::npos) << first_user;
  EXPECT_EQ(second_user.find_first_not_of("0123456789"), std::string::npos) << second_user;
  EXPECT_LT(std::stoull(first_user), std::stoull(second_user));
  EXPECT_EQ(first_again, first_user) << "every message of a connection carries its number";
  EXPECT_EQ(context.zap()->numbered(), 2u);
  // Another domain's NULL request is refused: its connection never delivers.
  void* other = bound("some-other-domain");
  void* refused = pusher(endpoint_of(other));
  zmq_send(refused, "d", 1, ZMQ_DONTWAIT);
  EXPECT_EQ(user_of_next(other, 500), "");
  EXPECT_EQ(context.zap()->numbered(), 2u);
  EXPECT_GE(context.zap()->denied(), 1u);
  for (void* s : {first, second, refused}) zmq_close(s);
  zmq_ctx_term(senders);
  zmq_close(pull);
  zmq_close(other);
}

}  // namespace
}  // namespace kata::transport
