// The runtime through the public C ABI only (libkata + libzmq for the subscriber): a stream with a
// teacher handed to a runtime, frames pushed, results received over loopback tcp.
#include <gtest/gtest.h>
#include <zmq.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "kata/kata.h"
#include "support/capi_fixture.hpp"
#include "support/zmq_subscriber.hpp"

namespace {

// Waits (at most 10 s) for the first skeleton definition (file identifier KSKL at bytes 20..23) on
// `sub`: from then on the subscription is joined. Its bytes go to *definition when not null.
bool wait_for_definition(kata::test::ZmqSubscriber& sub, std::vector<char>* definition = nullptr) {
  const char* buffer = reinterpret_cast<const char*>(sub.data());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline) {
    const int n = sub.receive(100);
    if (n > 24 && std::memcmp(buffer + 20, "KSKL", 4) == 0) {
      if (definition) definition->assign(buffer, buffer + n);
      return true;
    }
  }
  return false;
}

TEST(runtime_capi, StreamHandedToARuntimePublishesEveryResult) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip student = nullptr, teacher = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student), KATA_OK);
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &teacher), KATA_OK);
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK) << kata_context_last_error(ctx);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  sd.stencil = kata_model_stencil(model);
  kata_stream stream = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &stream), KATA_OK) << kata_context_last_error(ctx);
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher;
  td.first_frame = 1;
  ASSERT_EQ(kata_stream_attach_teacher(stream, &td), KATA_OK) << kata_stream_last_error(stream);

  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.publish_endpoints = "tcp://127.0.0.1:*";
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_runtime_add_stream(runtime, 42, &stream, "cmu", 0), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(stream, nullptr);  // the runtime owns it now
  EXPECT_EQ(kata_runtime_push(runtime, 43, 0, 0.0, nullptr, 0), KATA_E_NULL_POINTER);

  // A bad endpoint is refused with its name.
  kata_runtime_desc bad = rd;
  bad.publish_endpoints = "nonsense://x";
  kata_runtime other = nullptr;
  EXPECT_EQ(kata_runtime_create(ctx, &bad, &other), KATA_E_IO);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("nonsense://x"), std::string::npos);

  void* zctx = zmq_ctx_new();
  auto sub = std::make_unique<kata::test::ZmqSubscriber>(zctx, kata_runtime_publish_endpoint(runtime), 100000,
                                                         "000000000000002a", 1 << 16);
  ASSERT_TRUE(sub->connected());
  const char* buffer = reinterpret_cast<const char*>(sub->data());
  std::vector<char> definition, result;
  ASSERT_TRUE(wait_for_definition(*sub, &definition));

  // Practice: the section 0.1..0.4 s of the teacher, looped, for every frame pushed from here on;
  // refusals name why and change nothing.
  EXPECT_EQ(kata_runtime_set_practice(runtime, 42, 4, 0.0, 1, 0.4, 0.1), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("loop_end 0.1 s is not after loop_start 0.4 s"),
            std::string::npos) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_runtime_set_practice(runtime, 42, 4, 5000.0, 0, 0.0, 0.0), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("outside the teacher clip"), std::string::npos);
  EXPECT_EQ(kata_runtime_set_practice(runtime, 7, 4, 0.0, 1, 0.1, 0.4), KATA_E_NOT_FOUND);
  ASSERT_EQ(kata_runtime_set_practice(runtime, 42, 3, 0.0, 1, 0.1, 0.4), KATA_OK) << kata_context_last_error(ctx);

  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<float> p(3 * joints);
  const int frames = 60;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(student, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    ASSERT_EQ(kata_runtime_push(runtime, 42, static_cast<uint64_t>(i), i / 120.0, p.data(), joints), KATA_OK);
  }
  EXPECT_EQ(kata_runtime_push(runtime, 7, 0, 0.0, p.data(), joints), KATA_E_NOT_FOUND);
  int results = 0;
  const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (results < frames && std::chrono::steady_clock::now() < limit) {
    const int n = sub->receive(100);
    if (n > 24 && std::memcmp(buffer + 20, "KRES", 4) == 0) {
      kata_result_record r;
      r.struct_size = sizeof r;
      ASSERT_EQ(kata_message_read_result(buffer, static_cast<size_t>(n), &r), KATA_OK);
      EXPECT_EQ(r.stream_id, 42u);
      EXPECT_EQ(r.result_sequence, static_cast<uint64_t>(results));
      EXPECT_EQ(r.frame_sequence, static_cast<uint64_t>(results));
      EXPECT_EQ(r.scored, 1);
      EXPECT_TRUE(r.score >= 0.0f && r.score <= 100.0f);
      EXPECT_GT(r.ghost_joint_count, 0u);
      EXPECT_LE(r.arrival_ns, r.computed_ns);
      EXPECT_LE(r.computed_ns, r.published_ns);
      // The calibrated fields: calibrating for the first 0.25 s of the stream, then scored.
      if (results <= 28) {
        EXPECT_EQ(r.state, KATA_SCORE_CALIBRATING) << "frame " << results;
      } else if (results >= 32) {
        EXPECT_NE(r.state, KATA_SCORE_CALIBRATING) << "frame " << results;
      }
      for (float part : r.part_scores) EXPECT_TRUE(part >= 0.0f && part <= 100.0f);
      EXPECT_TRUE(r.part_to_fix >= -1 && r.part_to_fix < KATA_PART_COUNT);
      // The correction cue rides the published message: present exactly when a part is named.
      EXPECT_EQ(r.cue_joint >= 0, r.part_to_fix >= 0) << "frame " << results;
      EXPECT_TRUE(r.cue_joint >= -1 && r.cue_joint < 16 && r.cue_action >= KATA_CUE_NONE && r.cue_action <= KATA_CUE_TURN);
      // The practice it was computed under, and the matched time inside it (within 1/120 s: the
      // section's ends are rounded to teacher frames).
      EXPECT_EQ(r.has_practice, 1);
      EXPECT_EQ(r.practice_revision, 3u);
      EXPECT_EQ(r.practice_loop, 1);
      EXPECT_NEAR(r.practice_start_time, 0.1, 1.0 / 120);
      EXPECT_NEAR(r.practice_end_time, 0.4, 1.0 / 120);
      if (r.scored && r.state != KATA_SCORE_CALIBRATING) {
        EXPECT_GE(r.matched_teacher_time, r.practice_start_time - 1e-9);
        EXPECT_LE(r.matched_teacher_time, r.practice_end_time + 1e-9);
      }
      if (results == 40) {  // a caller built before the calibrated fields receives only its prefix
        kata_result_record old_layout;
        old_layout.struct_size = static_cast<uint32_t>(offsetof(kata_result_record, part_scores));
        old_layout.part_to_fix = 77;
        ASSERT_EQ(kata_message_read_result(buffer, static_cast<size_t>(n), &old_layout), KATA_OK);
        EXPECT_EQ(old_layout.score, r.score);
        EXPECT_EQ(old_layout.part_to_fix, 77);
      }
      if (result.empty()) result.assign(buffer, buffer + n);
      ++results;
    }
  }
  EXPECT_EQ(results, frames);
  // The C reader: a definition is no result, a truncated or flipped result is refused.
  kata_result_record r;
  r.struct_size = sizeof r;
  EXPECT_EQ(kata_message_read_result(definition.data(), definition.size(), &r), KATA_NO_DATA);
  ASSERT_FALSE(result.empty());
  EXPECT_EQ(kata_message_read_result(result.data(), result.size() - 40, &r), KATA_E_PARSE);
  std::vector<char> flipped = result;
  flipped[20] ^= 0x01;  // the file identifier
  EXPECT_EQ(kata_message_read_result(flipped.data(), flipped.size(), &r), KATA_E_PARSE);
  EXPECT_EQ(kata_runtime_stop(runtime), KATA_OK);
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.streams, 1u);
  EXPECT_EQ(c.frames_in, static_cast<uint64_t>(frames));
  EXPECT_EQ(c.results, static_cast<uint64_t>(frames));
  EXPECT_EQ(c.published, static_cast<uint64_t>(frames));
  EXPECT_EQ(c.results_dropped + c.queue_full + c.refused, 0u);
  sub.reset();
  zmq_ctx_term(zctx);
  kata_runtime_destroy(runtime);
  kata_model_destroy(model);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(student);
  kata_clip_destroy(teacher);
  kata_context_destroy(ctx);
}

// kata_runtime_desc.on_result (1.1): the callback receives every result of a stream handed to a
// runtime, in order, with its ghost, equal to what the same stream computes on its own from the
// same frames (a second stream with the same teacher, read with kata_stream_read_results).
struct Received {
  std::vector<kata_result_record> records;
  std::vector<float> ghosts;
  uint32_t size = 0;
};
void receive(void* user, const kata_result_record* r) {
  auto* got = static_cast<Received*>(user);
  got->size = r->struct_size;
  got->records.push_back(*r);
  got->records.back().ghost = nullptr;  // valid only during the call: its floats are copied
  if (r->ghost) got->ghosts.insert(got->ghosts.end(), r->ghost, r->ghost + 3 * r->ghost_joint_count);
}

TEST(runtime_capi, OnResultGetsEveryRecordAsTheStreamComputesIt) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip student = nullptr, teacher = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student), KATA_OK);
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &teacher), KATA_OK);
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK) << kata_context_last_error(ctx);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
  auto open = [&]() {
    kata_stream_desc sd;
    kata_stream_desc_init(&sd);
    sd.layout = "cmu";
    sd.stencil = kata_model_stencil(model);
    sd.result_capacity = 256;
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(ctx, skel, &sd, &s), KATA_OK) << kata_context_last_error(ctx);
    kata_teacher_desc td;
    kata_teacher_desc_init(&td);
    td.model = model;
    td.clip = teacher;
    td.first_frame = 1;
    EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK) << kata_stream_last_error(s);
    return s;
  };
  kata_stream alone = open(), handed = open();
  Received got;
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  EXPECT_EQ(rd.on_result, nullptr);
  EXPECT_EQ(rd.on_result_user, nullptr);
  rd = kata::test::callback_runtime_desc(receive, nullptr, &got);
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_runtime_add_stream(runtime, 9, &handed, "cmu", 0), KATA_OK) << kata_context_last_error(ctx);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<float> p(3 * joints);
  const int frames = 80;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(student, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    ASSERT_EQ(kata_runtime_push(runtime, 9, static_cast<uint64_t>(i), i / 120.0, p.data(), joints), KATA_OK);
    ASSERT_EQ(kata_stream_push(alone, i / 120.0, p.data(), joints), KATA_OK);
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);  // every queued frame's result delivered first
  const uint32_t g = kata_stream_ghost_joint_count(alone);
  ASSERT_GT(g, 0u);
  const uint32_t pending = kata_stream_results_pending(alone);
  std::vector<kata_result_record> expected(pending);
  expected[0].struct_size = sizeof expected[0];
  std::vector<float> ghosts(static_cast<size_t>(pending) * 3 * g);
  uint32_t n = 0;
  ASSERT_EQ(kata_stream_read_results(alone, expected.data(), ghosts.data(), ghosts.size(), nullptr, 0, pending, &n), KATA_OK);
  ASSERT_EQ(got.records.size(), static_cast<size_t>(n));
  EXPECT_EQ(got.size, sizeof(kata_result_record));
  ASSERT_EQ(got.ghosts.size(), ghosts.size());
  for (uint32_t i = 0; i < n; ++i) {
    const kata_result_record& r = got.records[i];
    EXPECT_EQ(r.stream_id, 9u);
    EXPECT_EQ(r.frame_sequence, static_cast<uint64_t>(expected[i].frame_index)) << i;
    EXPECT_EQ(r.scored, expected[i].scored) << i;
    EXPECT_EQ(r.state, expected[i].state) << i;
    EXPECT_EQ(r.score, expected[i].score) << i;
    EXPECT_EQ(r.matched_teacher_frame, expected[i].matched_teacher_frame) << i;
    EXPECT_EQ(r.part_to_fix, expected[i].part_to_fix) << i;
    EXPECT_EQ(r.ghost_joint_count, g) << i;
  }
  for (size_t k = 0; k < ghosts.size(); ++k) EXPECT_EQ(got.ghosts[k], ghosts[k]) << k;
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.results, static_cast<uint64_t>(n));
  kata_runtime_destroy(runtime);
  kata_stream_destroy(alone);
  kata_model_destroy(model);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(student);
  kata_clip_destroy(teacher);
  kata_context_destroy(ctx);
}

// kata_runtime_latency_percentile (1.1): the runtime's arrival -> published histogram, read back as
// the documented percentile of the records' own published_ns - arrival_ns (on_result sees every
// published record), computed here from those.
TEST(runtime_capi, LatencyPercentileIsTheDocumentedBucketEdgeOfThePublishedRecords) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &s), KATA_OK) << kata_context_last_error(ctx);
  Received got;
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.publish_endpoints = "tcp://127.0.0.1:*";
  rd.on_result = receive;
  rd.on_result_user = &got;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_runtime_latency_percentile(runtime, 0.5), 0.0);  // nothing published yet
  ASSERT_EQ(kata_runtime_add_stream(runtime, 3, &s, "cmu", 0), KATA_OK) << kata_context_last_error(ctx);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<float> p(3 * joints);
  for (int i = 0; i < 120; ++i) {
    ASSERT_EQ(kata_clip_positions(clip, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    ASSERT_EQ(kata_runtime_push(runtime, 3, static_cast<uint64_t>(i), i / 120.0, p.data(), joints), KATA_OK);
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);
  ASSERT_GT(got.records.size(), 100u);
  std::vector<uint64_t> histogram(288, 0);
  for (const kata_result_record& r : got.records) {
    ASSERT_GT(r.published_ns, 0) << "published";
    const int64_t ns = r.published_ns - r.arrival_ns;
    const int b = ns < 1 ? 0 : std::min(287, std::max(0, static_cast<int>(8.0 * std::log2(static_cast<double>(ns)))));
    ++histogram[static_cast<size_t>(b)];
  }
  for (double q : {0.0, 0.25, 0.5, 0.9, 0.99, 1.0}) {
    uint64_t seen = 0;
    double expected = 0.0;
    for (size_t i = 0; i < histogram.size(); ++i) {
      seen += histogram[i];
      if (static_cast<double>(seen) >= q * static_cast<double>(got.records.size())) {
        expected = std::exp2(static_cast<double>(i + 1) / 8.0);
        break;
      }
    }
    EXPECT_EQ(kata_runtime_latency_percentile(runtime, q), expected) << q;
  }
  EXPECT_LE(kata_runtime_latency_percentile(runtime, 0.5), kata_runtime_latency_percentile(runtime, 0.99));
  EXPECT_EQ(kata_runtime_latency_percentile(runtime, -0.1), 0.0);
  EXPECT_EQ(kata_runtime_latency_percentile(runtime, 1.5), 0.0);
  EXPECT_EQ(kata_runtime_latency_percentile(runtime, std::nan("")), 0.0);
  EXPECT_EQ(kata_runtime_latency_percentile(nullptr, 0.5), 0.0);
  kata_runtime_destroy(runtime);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
}

// kata_runtime_offer (1.1, kata_runtime_desc.direct_ingest): the messages kata_message_write_*
// write, handed in by the app's own transport, open the stream and score its frames as a socket
// would: one result per feature vector a stream fed the same frames directly computes, with the
// same frame sequences and capture times; a malformed message is taken and counted as dropped.
TEST(runtime_capi, OfferedMessagesOpenAndFeedAStreamAsASocketsWould) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  const uint32_t joints = kata_skeleton_joint_count(skel);

  // Refusals first: both a direct ingest and sockets; a runtime without one.
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  EXPECT_EQ(rd.direct_ingest, 0);
  rd.workers = 1;
  rd.direct_ingest = 1;
  rd.ingest_endpoints = "tcp://127.0.0.1:1";
  kata_runtime runtime = nullptr;
  EXPECT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::strstr(kata_context_last_error(ctx), "direct_ingest"), nullptr) << kata_context_last_error(ctx);
  rd.ingest_endpoints = nullptr;
  rd.direct_ingest = 0;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  const char junk[32] = {};
  EXPECT_EQ(kata_runtime_offer(runtime, junk, sizeof junk), KATA_E_STATE);
  kata_runtime_destroy(runtime);
  runtime = nullptr;

  Received got;
  rd.direct_ingest = 1;
  rd.max_frame_age_seconds = 0.0;  // the clip's capture times are not this host's clock
  rd.on_result = receive;
  rd.on_result_user = &got;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_runtime_offer(runtime, nullptr, 4), KATA_E_NULL_POINTER);
  std::vector<unsigned char> buffer(1 << 16);
  size_t size = 0;
  kata_skeleton_message sm;
  kata_skeleton_message_init(&sm);
  sm.stream_id = 21;
  sm.skeleton = skel;
  sm.layout = "cmu";
  ASSERT_EQ(kata_message_write_skeleton(&sm, buffer.data(), buffer.size(), &size), KATA_OK);
  ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
  EXPECT_EQ(kata_runtime_offer(runtime, junk, sizeof junk), KATA_OK);  // taken, judged malformed there

  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  sd.result_capacity = 256;
  kata_stream direct = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &direct), KATA_OK) << kata_context_last_error(ctx);
  std::vector<float> p(3 * joints);
  const int frames = 90;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(clip, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    kata_frame_message fm;
    kata_frame_message_init(&fm);
    fm.stream_id = 21;
    fm.sequence = static_cast<uint64_t>(i);
    fm.capture_time = 10.0 + i / 120.0;
    fm.positions = p.data();
    fm.joint_count = joints;
    ASSERT_EQ(kata_message_write_frame(&fm, buffer.data(), buffer.size(), &size), KATA_OK);
    ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK) << i;
    ASSERT_EQ(kata_stream_push(direct, fm.capture_time, p.data(), joints), KATA_OK);
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);  // every offered message handled first
  EXPECT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_E_QUEUE_FULL);  // stop has begun
  const uint32_t pending = kata_stream_results_pending(direct);
  std::vector<kata_result_record> expected(pending);
  ASSERT_GT(pending, 60u);
  expected[0].struct_size = sizeof expected[0];
  uint32_t n = 0;
  ASSERT_EQ(kata_stream_read_results(direct, expected.data(), nullptr, 0, nullptr, 0, pending, &n), KATA_OK);
  ASSERT_EQ(got.records.size(), static_cast<size_t>(n));
  for (uint32_t i = 0; i < n; ++i) {
    EXPECT_EQ(got.records[i].stream_id, 21u) << i;
    EXPECT_EQ(got.records[i].frame_sequence, static_cast<uint64_t>(expected[i].frame_index)) << i;
    EXPECT_NEAR(got.records[i].capture_time, expected[i].capture_time, 1e-9) << i;
  }
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.ingest_received, static_cast<uint64_t>(frames + 2));
  EXPECT_EQ(c.ingest_dropped, 1u);
  EXPECT_EQ(c.frames_in, static_cast<uint64_t>(frames));
  kata_runtime_destroy(runtime);
  kata_stream_destroy(direct);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
}

// kata_runtime_push_confidence: the confidences travel with the frame to the worker, which gates
// joints as kata_stream_push_confidence does. Ten frames with every joint at confidence 0 are
// accepted without features (no result, not counted as refused); the runtime publishes exactly as
// many results as a stream fed the same frames directly computes feature vectors.
TEST(runtime_capi, PushWithConfidencesGatesJointsAsAStreamDoes) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  kata_stream direct = nullptr, handed = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &direct), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &handed), KATA_OK) << kata_context_last_error(ctx);
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.publish_endpoints = "tcp://127.0.0.1:*";
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_runtime_add_stream(runtime, 9, &handed, nullptr, 0), KATA_OK) << kata_context_last_error(ctx);
  void* zctx = zmq_ctx_new();
  auto sub = std::make_unique<kata::test::ZmqSubscriber>(zctx, kata_runtime_publish_endpoint(runtime), 100000,
                                                         "0000000000000009", 1 << 16);
  ASSERT_TRUE(sub->connected());
  const char* buffer = reinterpret_cast<const char*>(sub->data());
  ASSERT_TRUE(wait_for_definition(*sub));
  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<float> p(3 * joints), confident(joints, 1.0f), unseen(joints, 0.0f);
  const int frames = 80;
  int lost = 0;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(clip, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    const float* c = (i >= 30 && i < 40) ? unseen.data() : (i % 2 ? confident.data() : nullptr);
    const kata_status st = kata_stream_push_confidence(direct, i / 120.0, p.data(), c, joints);
    ASSERT_TRUE(st == KATA_OK || st == KATA_TRACKING_LOST) << kata_stream_last_error(direct);
    lost += st == KATA_TRACKING_LOST;
    ASSERT_EQ(kata_runtime_push_confidence(runtime, 9, static_cast<uint64_t>(i), i / 120.0, p.data(), c, joints),
              KATA_OK);
  }
  EXPECT_EQ(lost, 10);
  EXPECT_EQ(kata_runtime_push_confidence(runtime, 9, 99, 1.0, nullptr, confident.data(), joints), KATA_E_NULL_POINTER);
  const int64_t want = kata_stream_feature_count(direct);
  ASSERT_GT(want, 0);
  ASSERT_LT(want, frames - 10 + 1);
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);
  int64_t results = 0;
  for (;;) {
    const int n = sub->receive(500);
    if (n <= 0) break;
    if (n > 24 && std::memcmp(buffer + 20, "KRES", 4) == 0) ++results;
  }
  EXPECT_EQ(results, want);
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.frames_in, static_cast<uint64_t>(frames));
  EXPECT_EQ(c.refused, 0u);
  EXPECT_EQ(c.results, static_cast<uint64_t>(want));
  sub.reset();
  zmq_ctx_term(zctx);
  kata_runtime_destroy(runtime);
  kata_stream_destroy(direct);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
}

// The runtime publishes its Stats on the result socket: a subscriber in C reads each as a valid
// message that is no result (KATA_NO_DATA), never as a corrupt one.
TEST(runtime_capi, StatsOnTheResultSocketAreValidNonResults) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.publish_endpoints = "tcp://127.0.0.1:*";
  rd.skeleton_resend_seconds = 0.05;  // stats go out with the periodic definitions
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  void* zctx = zmq_ctx_new();
  auto sub = std::make_unique<kata::test::ZmqSubscriber>(zctx, kata_runtime_publish_endpoint(runtime), 1000,
                                                         "ffffffffffffffff", 1 << 16);
  ASSERT_TRUE(sub->connected());
  const char* buffer = reinterpret_cast<const char*>(sub->data());
  int stats = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (stats < 2 && std::chrono::steady_clock::now() < deadline) {
    const int n = sub->receive(100);
    if (n > 24 && std::memcmp(buffer + 20, "KSTA", 4) == 0) {
      kata_result_record r;
      r.struct_size = sizeof r;
      r.stream_id = 99;
      EXPECT_EQ(kata_message_read_result(buffer, static_cast<size_t>(n), &r), KATA_NO_DATA);
      EXPECT_EQ(r.stream_id, 99u);  // untouched
      ++stats;
    }
  }
  EXPECT_EQ(stats, 2);
  sub.reset();
  zmq_ctx_term(zctx);
  EXPECT_EQ(kata_runtime_stop(runtime), KATA_OK);
  kata_runtime_destroy(runtime);
  kata_context_destroy(ctx);
}

// The skeleton definition a runtime publishes for a stream handed to it (the first message a
// subscriber gets on the stream's topic).
std::string definition_of(kata_context ctx, kata_stream stream, const char* preset, kata_status* added,
                          float frame_rate = -1.0f, float metres_per_unit = 0.0f) {
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.publish_endpoints = "tcp://127.0.0.1:*";
  kata_runtime runtime = nullptr;
  if (kata_runtime_create(ctx, &rd, &runtime) != KATA_OK) return "";
  // frame_rate -1: the call without rate and units.
  *added = frame_rate < 0.0f ? kata_runtime_add_stream(runtime, 5, &stream, preset, 0)
                             : kata_runtime_add_stream_ex(runtime, 5, &stream, preset, 0, frame_rate, metres_per_unit);
  std::string definition;
  if (*added == KATA_OK) {
    void* zctx = zmq_ctx_new();
    auto sub = std::make_unique<kata::test::ZmqSubscriber>(zctx, kata_runtime_publish_endpoint(runtime), 1000,
                                                           "0000000000000005", 1 << 16);
    const char* buffer = reinterpret_cast<const char*>(sub->data());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (definition.empty() && std::chrono::steady_clock::now() < deadline) {
      const int n = sub->receive(100);
      if (n > 24 && std::memcmp(buffer + 20, "KSKL", 4) == 0) definition.assign(buffer, buffer + n);
    }
    sub.reset();
    zmq_ctx_term(zctx);
  } else {
    kata_stream_destroy(stream);
  }
  kata_runtime_destroy(runtime);
  return definition;
}

// A FlatBuffers string as stored: 32-bit length, the bytes, a NUL.
std::string fb_string(const std::string& s) {
  std::string out(4, '\0');
  out[0] = static_cast<char>(s.size());
  return out + s + std::string(1, '\0');
}

// A runtime announces each stream's own layout, not "cmu": a MediaPipe stream as "mediapipe", a
// name-map stream by its map; a preset naming another layout is refused.
TEST(runtime_capi, AddStreamAnnouncesTheStreamsOwnLayout) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_skeleton mp = nullptr, gpd = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "mediapipe", &mp), KATA_OK);
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "gpd", &gpd), KATA_OK);
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "mediapipe";
  for (const char* preset : {static_cast<const char*>(nullptr), "mediapipe"}) {
    kata_stream s = nullptr;
    ASSERT_EQ(kata_stream_open(ctx, mp, &d, &s), KATA_OK) << kata_context_last_error(ctx);
    kata_status added = KATA_E_INTERNAL;
    const std::string def = definition_of(ctx, s, preset, &added);
    ASSERT_EQ(added, KATA_OK) << kata_context_last_error(ctx);
    ASSERT_FALSE(def.empty());
    EXPECT_NE(def.find(fb_string("mediapipe")), std::string::npos);
    EXPECT_EQ(def.find(fb_string("cmu")), std::string::npos);
  }
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, mp, &d, &s), KATA_OK);
  kata_status added = KATA_OK;
  definition_of(ctx, s, "cmu", &added);
  EXPECT_EQ(added, KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("not the layout the stream was opened with"),
            std::string::npos) << kata_context_last_error(ctx);

  // The same skeleton under its own names and with left and right swapped: only the announced
  // map tells a subscriber how to read each (a preset would announce both alike).
  const char* identity = "{\"Hip\":\"Hip\",\"Chest\":\"Chest\",\"Neck\":\"Neck\",\"Head\":\"Head\",\"LShoulder\":\"LShoulder\","
                         "\"LElbow\":\"LElbow\",\"LHand\":\"LHand\",\"RShoulder\":\"RShoulder\",\"RElbow\":\"RElbow\","
                         "\"RHand\":\"RHand\",\"LHip\":\"LHip\",\"LKnee\":\"LKnee\",\"LFoot\":\"LFoot\",\"RHip\":\"RHip\","
                         "\"RKnee\":\"RKnee\",\"RFoot\":\"RFoot\"}";
  const char* swapped = "{\"Hip\":\"Hip\",\"Chest\":\"Chest\",\"Neck\":\"Neck\",\"Head\":\"Head\",\"LShoulder\":\"RShoulder\","
                        "\"LElbow\":\"RElbow\",\"LHand\":\"RHand\",\"RShoulder\":\"LShoulder\",\"RElbow\":\"LElbow\","
                        "\"RHand\":\"LHand\",\"LHip\":\"RHip\",\"LKnee\":\"RKnee\",\"LFoot\":\"RFoot\",\"RHip\":\"LHip\","
                        "\"RKnee\":\"LKnee\",\"RFoot\":\"LFoot\"}";
  std::string defs[2];
  for (int i = 0; i < 2; ++i) {
    kata_stream_desc_init(&d);
    ASSERT_EQ(kata_stream_open_name_map(ctx, gpd, &d, i ? swapped : identity, &s), KATA_OK) << kata_context_last_error(ctx);
    defs[i] = definition_of(ctx, s, nullptr, &added);
    ASSERT_EQ(added, KATA_OK) << kata_context_last_error(ctx);
    ASSERT_FALSE(defs[i].empty());
    EXPECT_EQ(defs[i].find(fb_string("cmu")), std::string::npos);
    EXPECT_EQ(defs[i].find(fb_string("gpd")), std::string::npos);
  }
  EXPECT_EQ(defs[0].size(), defs[1].size());
  EXPECT_NE(defs[0], defs[1]);

  // kata_runtime_add_stream_ex: the definition announces the rate and the units, byte for byte
  // the message a source writes with kata_message_write_skeleton for the same stream (and
  // kata_runtime_add_stream's is that message with both 0).
  for (const float rate : {0.0f, 30.0f}) {
    SCOPED_TRACE(rate);
    kata_stream_desc_init(&d);
    d.layout = "mediapipe";
    ASSERT_EQ(kata_stream_open(ctx, mp, &d, &s), KATA_OK);
    const std::string def = rate == 0.0f ? definition_of(ctx, s, nullptr, &added)
                                         : definition_of(ctx, s, nullptr, &added, rate, 0.01f);
    ASSERT_EQ(added, KATA_OK) << kata_context_last_error(ctx);
    kata_skeleton_message sm;
    kata_skeleton_message_init(&sm);
    sm.stream_id = 5;
    sm.skeleton = mp;
    sm.layout = "mediapipe";
    sm.frame_rate = rate;
    sm.metres_per_unit = rate == 0.0f ? 0.0f : 0.01f;
    std::vector<char> expected(1 << 16);
    size_t size = 0;
    ASSERT_EQ(kata_message_write_skeleton(&sm, expected.data(), expected.size(), &size), KATA_OK);
    EXPECT_EQ(def, std::string(expected.data(), size));
  }
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK);
  kata_stream_desc_init(&d);
  d.layout = "mediapipe";
  ASSERT_EQ(kata_stream_open(ctx, mp, &d, &s), KATA_OK);
  EXPECT_EQ(kata_runtime_add_stream_ex(runtime, 6, &s, nullptr, 0, std::nanf(""), 1.0f), KATA_E_NON_FINITE);
  EXPECT_EQ(kata_runtime_add_stream_ex(runtime, 6, &s, nullptr, 0, 30.0f, -1.0f), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("metres_per_unit"), std::string::npos);
  ASSERT_NE(s, nullptr);  // refused: still the caller's
  EXPECT_EQ(kata_runtime_add_stream_ex(runtime, 6, &s, nullptr, 0, 30.0f, 1.0f), KATA_OK);
  EXPECT_EQ(s, nullptr);
  kata_runtime_destroy(runtime);
  kata_skeleton_destroy(mp);
  kata_skeleton_destroy(gpd);
  kata_context_destroy(ctx);
}

// "Queue full" and "no clip teacher" are distinct codes (KATA_E_STATE meant both): a stream with
// no teacher refuses a practice setting with KATA_E_NO_CLIP_TEACHER, and a worker queue of two
// cells overrun by a burst of pushes answers KATA_E_QUEUE_FULL, each counted as queue_full.
TEST(runtime_capi, QueueFullAndNoClipTeacherAreTheirOwnCodes) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &clip), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  kata_stream stream = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &stream), KATA_OK) << kata_context_last_error(ctx);
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.queue_capacity = 2;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_runtime_add_stream(runtime, 9, &stream, nullptr, 0), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_runtime_set_practice(runtime, 9, 1, 0.0, 1, 0.1, 0.4), KATA_E_NO_CLIP_TEACHER);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("no clip teacher"), std::string::npos)
      << kata_context_last_error(ctx);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<float> p(3 * joints);
  ASSERT_EQ(kata_clip_positions(clip, 1, p.data(), p.size()), KATA_OK);
  uint64_t full = 0, other = 0;
  for (int i = 0; i < 20000 && full < 10; ++i) {
    const kata_status st = kata_runtime_push(runtime, 9, static_cast<uint64_t>(i), i / 120.0, p.data(), joints);
    if (st == KATA_E_QUEUE_FULL) {
      ++full;
    } else if (st != KATA_OK) {
      ++other;
    }
  }
  EXPECT_GT(full, 0u);
  EXPECT_EQ(other, 0u);
  EXPECT_STREQ(kata_status_string(KATA_E_QUEUE_FULL), "KATA_E_QUEUE_FULL");
  EXPECT_STREQ(kata_status_string(KATA_E_NO_CLIP_TEACHER), "KATA_E_NO_CLIP_TEACHER");
  EXPECT_EQ(kata_runtime_stop(runtime), KATA_OK);
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.queue_full, full);
  kata_runtime_destroy(runtime);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
}

}  // namespace

// kata_runtime_desc.on_stream_open (1.1): the app attaches a teacher (here one built once with
// kata_teacher_create) to a stream a skeleton definition opens. The runtime's results for it must
// equal, bit for bit, those of a kata_stream given the same teacher with kata_stream_attach_teacher
// and fed the same frames; a definition the hook refuses opens nothing (its frames are dropped as
// an unknown stream's), is counted, and leaves the other stream's results as they are.
struct HookState {
  kata_teacher teacher = nullptr;
  uint64_t refuse_id = 0;
  std::vector<uint64_t> ids;
  std::vector<uint32_t> joint_counts;
  std::vector<std::string> layouts;
  std::vector<double> frame_rates;
};
kata_status on_open(void* user, const kata_stream_open_info* info, kata_stream stream) {
  auto* h = static_cast<HookState*>(user);
  h->ids.push_back(info->stream_id);
  h->joint_counts.push_back(info->joint_count);
  h->layouts.emplace_back(info->layout);
  h->frame_rates.push_back(info->frame_rate);
  if (info->stream_id == h->refuse_id) return KATA_E_STATE;
  if (kata_skeleton_joint_count(info->skeleton) != info->joint_count) return KATA_E_INTERNAL;
  return kata_stream_attach_shared_teacher(stream, h->teacher, nullptr);
}

// The two hook tests' set-up: the C ABI clips (teacher 02_01, student 07_01), a runtime fed by
// kata_runtime_offer whose on_stream_open is the test's hook and whose results reach `got`, and
// the skeleton and frame messages offered to it.
class RuntimeHook : public kata::test::CapiClips {
 protected:
  RuntimeHook() : CapiClips(KATA_DATA_DIR "/cmu/02_01.bvh", KATA_DATA_DIR "/cmu/07_01.bvh") {}
  kata_teacher_desc teacher_desc() const { return kata::test::clip_teacher_desc(model, teacher); }
  // One worker, the direct ingest, no age limit (the clip's capture times are not this host's clock).
  kata_runtime start(kata_stream_open_callback hook, void* hook_user) {
    const kata_runtime_desc rd = kata::test::hooked_direct_ingest_desc(model, hook, hook_user, receive, &got);
    kata_runtime runtime = nullptr;
    EXPECT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
    return runtime;
  }
  void offer_skeleton(kata_runtime runtime, uint64_t id, float frame_rate) {
    kata_skeleton_message sm;
    kata_skeleton_message_init(&sm);
    sm.stream_id = id;
    sm.skeleton = skel;
    sm.layout = "cmu";
    sm.frame_rate = frame_rate;
    size_t size = 0;
    ASSERT_EQ(kata_message_write_skeleton(&sm, buffer.data(), buffer.size(), &size), KATA_OK);
    ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
  }
  // Frame i of a stream: positions p, captured at 10 + i / 128 s (dyadic: the wire's nanoseconds
  // give it back exactly).
  void offer_frame(kata_runtime runtime, uint64_t id, int i, const std::vector<float>& p) {
    kata_frame_message fm;
    kata_frame_message_init(&fm);
    fm.stream_id = id;
    fm.sequence = static_cast<uint64_t>(i);
    fm.capture_time = 10.0 + i / 128.0;
    fm.positions = p.data();
    fm.joint_count = joints;
    size_t size = 0;
    ASSERT_EQ(kata_message_write_frame(&fm, buffer.data(), buffer.size(), &size), KATA_OK);
    ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK) << i;
  }

  Received got;
  std::vector<unsigned char> buffer = std::vector<unsigned char>(1 << 16);
};

TEST_F(RuntimeHook, OnStreamOpenAttachesASharedTeacherAndARefusalIsCounted) {
  kata_runtime_desc fresh;
  kata_runtime_desc_init(&fresh);
  EXPECT_EQ(fresh.on_stream_open, nullptr);
  EXPECT_EQ(fresh.stream_stencil, KATA_STENCIL_BACKWARD);
  const kata_teacher_desc td = teacher_desc();
  HookState hook;
  ASSERT_EQ(kata_teacher_create(ctx, &td, &hook.teacher), KATA_OK) << kata_context_last_error(ctx);
  hook.refuse_id = 22;
  kata_runtime runtime = start(on_open, &hook);
  ASSERT_NE(runtime, nullptr);
  // The hook attaches the handle to each stream it opens: kept until no definition can come.
  for (uint64_t id : {uint64_t{21}, uint64_t{22}}) ASSERT_NO_FATAL_FAILURE(offer_skeleton(runtime, id, 120.0f));

  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  sd.stencil = kata_model_stencil(model);
  sd.result_capacity = 256;
  // The wire carries rest offsets as floats (schemas/common.fbs Vec3): the stream set up the
  // existing way is opened on the skeleton as the runtime receives it.
  std::vector<const char*> names(joints);
  std::vector<int32_t> parents(joints);
  std::vector<double> offsets(3 * static_cast<size_t>(joints));
  for (uint32_t j = 0; j < joints; ++j) {
    names[j] = kata_skeleton_joint_name(skel, j);
    parents[j] = kata_skeleton_joint_parent(skel, j);
    ASSERT_EQ(kata_skeleton_joint_offset(skel, j, &offsets[3 * j]), KATA_OK);
    for (int k = 0; k < 3; ++k) offsets[3 * j + k] = static_cast<float>(offsets[3 * j + k]);
  }
  kata_skeleton received = nullptr;
  ASSERT_EQ(kata_skeleton_create(ctx, joints, names.data(), parents.data(), offsets.data(), &received), KATA_OK);
  kata_stream direct = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, received, &sd, &direct), KATA_OK) << kata_context_last_error(ctx);
  kata_skeleton_destroy(received);
  ASSERT_EQ(kata_stream_attach_teacher(direct, &td), KATA_OK) << kata_stream_last_error(direct);
  std::vector<float> p(3 * joints);
  const int frames = 120;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(student, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    for (uint64_t id : {uint64_t{21}, uint64_t{22}}) ASSERT_NO_FATAL_FAILURE(offer_frame(runtime, id, i, p));
    ASSERT_EQ(kata_stream_push(direct, 10.0 + i / 128.0, p.data(), joints), KATA_OK);
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);  // every offered message handled first
  kata_teacher_destroy(hook.teacher);  // the runtime's stream still holds it
  ASSERT_EQ(hook.ids.size(), 2u);
  EXPECT_EQ(hook.ids[0], 21u);
  EXPECT_EQ(hook.ids[1], 22u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(hook.joint_counts[i], joints);
    EXPECT_EQ(hook.layouts[i], "cmu");
    EXPECT_EQ(hook.frame_rates[i], 120.0);
  }

  const uint32_t pending = kata_stream_results_pending(direct);
  ASSERT_GT(pending, 90u);
  std::vector<kata_result_record> expected(pending);
  expected[0].struct_size = sizeof expected[0];
  std::vector<float> ghosts(pending * 3 * static_cast<size_t>(kata_stream_ghost_joint_count(direct)));
  ASSERT_GT(ghosts.size(), 0u);
  uint32_t n = 0;
  ASSERT_EQ(kata_stream_read_results(direct, expected.data(), ghosts.data(), ghosts.size(), nullptr, 0, pending, &n),
            KATA_OK);
  ASSERT_EQ(got.records.size(), static_cast<size_t>(n));  // stream 22 published nothing
  for (uint32_t i = 0; i < n; ++i) {
    SCOPED_TRACE(i);
    const kata_result_record& r = got.records[i];
    EXPECT_EQ(r.stream_id, 21u);
    EXPECT_EQ(r.scored, 1);
    EXPECT_EQ(r.scored, expected[i].scored);
    EXPECT_EQ(r.matched_teacher_frame, expected[i].matched_teacher_frame);
    EXPECT_EQ(std::memcmp(&r.distance, &expected[i].distance, sizeof(float)), 0);
    EXPECT_EQ(std::memcmp(&r.score, &expected[i].score, sizeof(float)), 0);
    EXPECT_EQ(std::memcmp(r.parts, expected[i].parts, sizeof r.parts), 0);
    EXPECT_EQ(std::memcmp(r.part_scores, expected[i].part_scores, sizeof r.part_scores), 0);
    EXPECT_EQ(r.part_to_fix, expected[i].part_to_fix);
    EXPECT_EQ(r.state, expected[i].state);
  }
  ASSERT_EQ(got.ghosts.size(), ghosts.size());
  EXPECT_EQ(std::memcmp(got.ghosts.data(), ghosts.data(), ghosts.size() * sizeof(float)), 0);
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.streams_refused_by_app, 1u);
  EXPECT_EQ(c.frames_in, static_cast<uint64_t>(frames));  // stream 21's only
  EXPECT_GE(c.ingest_dropped, static_cast<uint64_t>(frames) + 1);  // the refused definition, 22's frames
  kata_runtime_destroy(runtime);
  kata_stream_destroy(direct);
}

// A practice section the hook sets (kata_stream_set_practice_section inside on_stream_open, as
// kata serve's [scoring] loop does) is the one the runtime publishes: every result carries it
// (has_practice, the section's teacher times, the loop, revision 0: no Practice message set it),
// and the matched teacher time stays inside it.
struct PracticeHook {
  kata_teacher teacher = nullptr;
  int32_t first = 0, last = 0;
};
kata_status on_open_practice(void* user, const kata_stream_open_info*, kata_stream stream) {
  auto* h = static_cast<PracticeHook*>(user);
  const kata_status s = kata_stream_attach_shared_teacher(stream, h->teacher, nullptr);
  if (s != KATA_OK) return s;
  return kata_stream_set_practice_section(stream, h->first, h->last, 1);
}

TEST_F(RuntimeHook, APracticeSectionSetInOnStreamOpenIsPublishedWithEveryResult) {
  const kata_teacher_desc td = teacher_desc();
  PracticeHook hook;
  hook.first = 40;
  hook.last = 160;
  ASSERT_EQ(kata_teacher_create(ctx, &td, &hook.teacher), KATA_OK) << kata_context_last_error(ctx);
  kata_runtime runtime = start(on_open_practice, &hook);
  ASSERT_NE(runtime, nullptr);
  ASSERT_NO_FATAL_FAILURE(offer_skeleton(runtime, 5, 0.0f));
  std::vector<float> p(3 * joints);
  for (int i = 0; i < 100; ++i) {
    ASSERT_EQ(kata_clip_positions(student, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    ASSERT_NO_FATAL_FAILURE(offer_frame(runtime, 5, i, p));
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);
  kata_teacher_destroy(hook.teacher);
  // The section's ends in teacher seconds: its rows times the teacher clip's frame time.
  const double ft = kata_clip_frame_time(teacher);
  ASSERT_GT(ft, 0.0);
  ASSERT_GT(got.records.size(), 60u);
  for (size_t i = 0; i < got.records.size(); ++i) {
    SCOPED_TRACE(i);
    const kata_result_record& r = got.records[i];
    EXPECT_EQ(r.has_practice, 1);
    EXPECT_EQ(r.practice_revision, 0u);
    EXPECT_EQ(r.practice_loop, 1);
    EXPECT_NEAR(r.practice_start_time, hook.first * ft, 1e-9);
    EXPECT_NEAR(r.practice_end_time, hook.last * ft, 1e-9);
    if (r.scored) {
      EXPECT_GE(r.matched_teacher_time, r.practice_start_time - 1e-9);
      EXPECT_LE(r.matched_teacher_time, r.practice_end_time + 1e-9);
    }
  }
  kata_runtime_destroy(runtime);
}

// The 1.1 fields of kata_runtime_desc that a `kata serve` config sets: their defaults are the
// runtime's behaviour before them, and values outside their ranges are refused by name.
TEST(runtime_capi, ServeSettingsDefaultToTheEarlierBehaviourAndOutOfRangeValuesAreRefused) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  EXPECT_EQ(rd.shard_count, 1u);
  EXPECT_EQ(rd.shard_index, 0u);
  EXPECT_EQ(rd.require_checksum, 1);
  EXPECT_EQ(rd.idle_backoff, 0);
  EXPECT_EQ(rd.result_queue_capacity, 0u);
  EXPECT_EQ(rd.publish_server_key_file, nullptr);
  EXPECT_EQ(rd.sequence_window, 65536u);
  struct Bad {
    const char* word;
    void (*set)(kata_runtime_desc*);
  };
  const Bad bad[] = {
      {"shard_count", [](kata_runtime_desc* d) { d->shard_count = 0; }},
      {"shard_count", [](kata_runtime_desc* d) { d->shard_count = 65537; }},
      {"shard_index", [](kata_runtime_desc* d) { d->shard_count = 3, d->shard_index = 3; }},
      {"require_checksum", [](kata_runtime_desc* d) { d->require_checksum = 2; }},
      {"idle_backoff", [](kata_runtime_desc* d) { d->idle_backoff = -1; }},
      {"result_queue_capacity", [](kata_runtime_desc* d) { d->result_queue_capacity = 1; }},
      {"sequence_window", [](kata_runtime_desc* d) { d->sequence_window = 0; }},
      {"key_file", [](kata_runtime_desc* d) { d->publish_server_key_file = "proxy.pub"; }},
  };
  for (const Bad& b : bad) {
    SCOPED_TRACE(b.word);
    kata_runtime_desc d;
    kata_runtime_desc_init(&d);
    b.set(&d);
    kata_runtime runtime = nullptr;
    EXPECT_EQ(kata_runtime_create(ctx, &d, &runtime), KATA_E_INVALID_ARGUMENT);
    EXPECT_EQ(runtime, nullptr);
    EXPECT_NE(std::strstr(kata_context_last_error(ctx), b.word), nullptr) << kata_context_last_error(ctx);
  }
  kata_context_destroy(ctx);
}

namespace {

// kata_shard_of as kata/runtime.h specifies it (FNV-1a 64 over the id's bytes, least significant
// first), computed here rather than asked of the library.
uint32_t fnv_shard(uint64_t id, uint32_t count) {
  uint64_t h = 14695981039346656037ull;
  for (int b = 0; b < 8; ++b) {
    h ^= (id >> (8 * b)) & 0xff;
    h *= 1099511628211ull;
  }
  return count <= 1 ? 0 : static_cast<uint32_t>(h % count);
}

}  // namespace

// A shard of two fed every kind of ingest outcome through kata_runtime_offer: each new counter
// equals the number of messages of its kind the test offered, the outcomes add up to the messages
// received, the shard scores only its own streams (and an out-of-window sequence is judged by the
// desc's window), per-stream counters add up to the totals, and the histograms hold one count
// per published result and per frame handed on, their percentiles as documented.
TEST(runtime_capi, EveryIngestOutcomeIsCountedByCauseAndTheHistogramsHoldEveryCount) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip student = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  // Two streams of shard 1 of 2, one of shard 0.
  std::vector<uint64_t> mine, theirs;
  for (uint64_t id = 1; mine.size() < 2 || theirs.empty(); ++id)
    (fnv_shard(id, 2) == 1 ? mine : theirs).push_back(id);
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.direct_ingest = 1;
  rd.max_frame_age_seconds = 0.0;
  rd.shard_count = 2;
  rd.shard_index = 1;
  rd.sequence_window = 10;
  rd.idle_backoff = 1;
  rd.result_queue_capacity = 64;
  rd.publish_endpoints = "tcp://127.0.0.1:*";  // published results: the latency histogram's
  Received got;
  rd.on_result = receive;
  rd.on_result_user = &got;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  std::vector<unsigned char> buffer(1 << 16);
  size_t size = 0;
  uint64_t offered = 0;
  auto offer = [&] {
    ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
    ++offered;
  };
  auto skeleton = [&](uint64_t id) {
    kata_skeleton_message sm;
    kata_skeleton_message_init(&sm);
    sm.stream_id = id;
    sm.skeleton = skel;
    sm.layout = "cmu";
    ASSERT_EQ(kata_message_write_skeleton(&sm, buffer.data(), buffer.size(), &size), KATA_OK);
    offer();
  };
  std::vector<float> p(3 * joints);
  ASSERT_EQ(kata_clip_positions(student, 1, p.data(), p.size()), KATA_OK);
  auto frame = [&](uint64_t id, uint64_t sequence, uint32_t count) {
    kata_frame_message fm;
    kata_frame_message_init(&fm);
    fm.stream_id = id;
    fm.sequence = sequence;
    fm.capture_time = 10.0 + static_cast<double>(sequence) / 128.0;
    fm.positions = p.data();
    fm.joint_count = count;
    ASSERT_EQ(kata_message_write_frame(&fm, buffer.data(), buffer.size(), &size), KATA_OK);
    offer();
  };
  skeleton(mine[0]);
  skeleton(mine[1]);
  skeleton(theirs[0]);                               // other shard: 1
  skeleton(mine[0]);                                 // a re-send: repeated 1
  const int frames0 = 30, frames1 = 12;
  for (int i = 0; i < frames0; ++i) frame(mine[0], static_cast<uint64_t>(i), joints);
  for (int i = 0; i < frames1; ++i) frame(mine[1], static_cast<uint64_t>(i), joints);
  frame(theirs[0], 0, joints);                       // other shard: 2
  frame(mine[0], 5, joints);                         // out of order
  frame(mine[0], frames0 + 20, joints);              // beyond the window of 10
  frame(mine[1], frames1, joints - 1);               // wrong joint count
  uint64_t unknown = mine[1] + 1;
  while (fnv_shard(unknown, 2) != 1) ++unknown;
  frame(unknown, 0, joints);                         // no definition: unknown stream
  // Malformed: a topic of this shard's stream (another shard's is dropped on its topic alone)
  // and no FlatBuffer after it.
  unsigned char garbage[40] = {};
  std::snprintf(reinterpret_cast<char*>(garbage), 17, "%016llx", static_cast<unsigned long long>(mine[0]));
  garbage[16] = 7;
  ASSERT_EQ(kata_runtime_offer(runtime, garbage, sizeof garbage), KATA_OK);
  ++offered;
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);

  kata_runtime_counters c;
  std::memset(&c, 0xff, sizeof c);
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.ingest_received, offered);
  EXPECT_EQ(c.ingest_skeletons, 2u);
  EXPECT_EQ(c.ingest_repeated_skeletons, 1u);
  EXPECT_EQ(c.ingest_other_shard, 2u);
  EXPECT_EQ(c.ingest_frames, static_cast<uint64_t>(frames0 + frames1));
  EXPECT_EQ(c.ingest_out_of_order, 1u);
  EXPECT_EQ(c.ingest_out_of_window, 1u);
  EXPECT_EQ(c.ingest_wrong_joint_count, 1u);
  EXPECT_EQ(c.ingest_unknown_stream, 1u);
  EXPECT_EQ(c.ingest_malformed, 1u);
  EXPECT_EQ(c.ingest_dropped, 5u);
  EXPECT_EQ(c.ingest_closes, 0u);
  EXPECT_EQ(c.ingest_refused_skeletons, 0u);
  EXPECT_EQ(c.ingest_other_kind, 0u);
  EXPECT_EQ(c.ingest_batches, 0u);
  EXPECT_EQ(c.ingest_batch_frames, 0u);
  EXPECT_EQ(c.ingest_connections, 0u);  // no socket
  EXPECT_EQ(c.ingest_handshake_failures, 0u);
  EXPECT_EQ(c.ingest_last_handshake_error, 0u);
  EXPECT_EQ(c.pipeline_dropped + c.result_queue_full, c.results_dropped);
  EXPECT_EQ(c.send_failed, 0u);
  EXPECT_EQ(c.ingest_received - c.ingest_batches + c.ingest_batch_frames,
            c.ingest_frames + c.ingest_skeletons + c.ingest_repeated_skeletons + c.ingest_closes + c.ingest_practices +
                c.ingest_repeated_practices + c.ingest_other_shard + c.ingest_dropped);
  EXPECT_EQ(c.frames_in, static_cast<uint64_t>(frames0 + frames1));

  // Per stream, in the order they opened; the two structs sum to the totals.
  uint32_t count = 0;
  EXPECT_EQ(kata_runtime_get_stream_counters(runtime, nullptr, 0, &count), KATA_E_BUFFER_TOO_SMALL);
  ASSERT_EQ(count, 2u);
  std::vector<kata_stream_counters> sc(3);
  sc[0].struct_size = sizeof sc[0];
  EXPECT_EQ(kata_runtime_get_stream_counters(runtime, sc.data(), 1, &count), KATA_E_BUFFER_TOO_SMALL);
  ASSERT_EQ(kata_runtime_get_stream_counters(runtime, sc.data(), 3, &count), KATA_OK);
  ASSERT_EQ(count, 2u);
  EXPECT_EQ(sc[0].stream_id, mine[0]);
  EXPECT_EQ(sc[1].stream_id, mine[1]);
  EXPECT_EQ(sc[0].frames_in, static_cast<uint64_t>(frames0));
  EXPECT_EQ(sc[1].frames_in, static_cast<uint64_t>(frames1));
  EXPECT_EQ(sc[0].out_of_sequence, 2u);  // its out-of-order and out-of-window frames
  EXPECT_EQ(sc[1].wrong_joints, 1u);
  uint64_t published = 0, results = 0;
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(sc[i].struct_size, sizeof sc[i]);
    published += sc[i].published;
    results += sc[i].results;
  }
  EXPECT_EQ(published, c.published);
  EXPECT_EQ(results, c.results);
  EXPECT_EQ(published, got.records.size());
  EXPECT_EQ(published, static_cast<uint64_t>(frames0 + frames1) - c.refused - c.results_dropped);
  EXPECT_GT(published, 30u);
  sc[0].struct_size = 8;
  EXPECT_EQ(kata_runtime_get_stream_counters(runtime, sc.data(), 3, &count), KATA_E_INVALID_ARGUMENT);

  // Histograms: one count per published result, per frame handed on.
  std::vector<uint64_t> latency(KATA_LATENCY_BUCKETS + 1, 7), age(KATA_LATENCY_BUCKETS);
  EXPECT_EQ(kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_LATENCY, latency.data(), KATA_LATENCY_BUCKETS - 1),
            KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(kata_runtime_get_histogram(runtime, static_cast<kata_histogram_kind>(2), latency.data(), KATA_LATENCY_BUCKETS),
            KATA_E_INVALID_ARGUMENT);
  ASSERT_EQ(kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_LATENCY, latency.data(), KATA_LATENCY_BUCKETS), KATA_OK);
  ASSERT_EQ(kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_SOURCE_AGE, age.data(), KATA_LATENCY_BUCKETS), KATA_OK);
  EXPECT_EQ(latency[KATA_LATENCY_BUCKETS], 7u);  // nothing written past the buckets
  uint64_t latency_sum = 0, age_sum = 0;
  for (int i = 0; i < KATA_LATENCY_BUCKETS; ++i) {
    latency_sum += latency[i];
    age_sum += age[i];
  }
  EXPECT_EQ(latency_sum, c.published);
  EXPECT_EQ(age_sum, c.ingest_frames);
  for (double q : {0.0, 0.5, 0.99, 1.0})
    EXPECT_EQ(kata_histogram_percentile(latency.data(), KATA_LATENCY_BUCKETS, q), kata_runtime_latency_percentile(runtime, q));
  kata_runtime_destroy(runtime);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(student);
  kata_context_destroy(ctx);
}

// kata_histogram_percentile on histograms built here: the answer is the upper edge 2^((i+1)/8) ns
// of the bucket where the running count first reaches q of the total.
TEST(runtime_capi, HistogramPercentileIsTheUpperEdgeOfTheBucketReachingQ) {
  std::vector<uint64_t> h(KATA_LATENCY_BUCKETS, 0);
  EXPECT_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, 0.5), 0.0);  // empty
  h[80] = 50;   // [2^10, 2^10.125) ns
  h[160] = 49;  // [2^20, ...)
  h[200] = 1;
  EXPECT_DOUBLE_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, 0.5), std::pow(2.0, 81 / 8.0));
  EXPECT_DOUBLE_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, 0.51), std::pow(2.0, 161 / 8.0));
  EXPECT_DOUBLE_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, 0.99), std::pow(2.0, 161 / 8.0));
  EXPECT_DOUBLE_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, 1.0), std::pow(2.0, 201 / 8.0));
  EXPECT_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS - 1, 0.5), 0.0);
  EXPECT_EQ(kata_histogram_percentile(nullptr, KATA_LATENCY_BUCKETS, 0.5), 0.0);
  EXPECT_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, -0.1), 0.0);
  EXPECT_EQ(kata_histogram_percentile(h.data(), KATA_LATENCY_BUCKETS, std::nan("")), 0.0);
}

namespace {

struct Kept {
  std::vector<kata_result_record> records;
  std::vector<std::vector<float>> ghosts;
};
void keep(void* user, const kata_result_record* r) {
  auto* k = static_cast<Kept*>(user);
  k->records.push_back(*r);
  k->ghosts.emplace_back(r->ghost ? std::vector<float>(r->ghost, r->ghost + 3 * r->ghost_joint_count)
                                  : std::vector<float>());
}

}  // namespace

// kata_message_write_result (1.1): the message written from each record on_result received is,
// byte for byte, the message the runtime's ZeroMQ publisher sent for that result (scored, with a
// ghost and a practice section); a 1.0-sized record writes the cue as "none", and bad records are
// refused.
TEST(runtime_capi, AResultWrittenFromItsRecordIsTheMessageTheRuntimePublished) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip student = nullptr, teacher = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student), KATA_OK);
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &teacher), KATA_OK);
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  sd.stencil = kata_model_stencil(model);
  kata_stream stream = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &sd, &stream), KATA_OK);
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher;
  td.first_frame = 1;
  ASSERT_EQ(kata_stream_attach_teacher(stream, &td), KATA_OK) << kata_stream_last_error(stream);
  ASSERT_EQ(kata_stream_set_practice_section(stream, 10, 200, 1), KATA_OK);
  Kept kept;
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.publish_endpoints = "tcp://127.0.0.1:*";
  rd.on_result = keep;
  rd.on_result_user = &kept;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_runtime_add_stream(runtime, 42, &stream, "cmu", 0), KATA_OK) << kata_context_last_error(ctx);
  void* zctx = zmq_ctx_new();
  auto sub = std::make_unique<kata::test::ZmqSubscriber>(zctx, kata_runtime_publish_endpoint(runtime), 100000,
                                                         "000000000000002a", 1 << 16);
  ASSERT_TRUE(sub->connected());
  std::vector<char> definition;
  ASSERT_TRUE(wait_for_definition(*sub, &definition));
  const uint32_t joints = kata_skeleton_joint_count(skel);
  std::vector<float> p(3 * joints);
  const int frames = 60;
  for (int i = 0; i < frames; ++i) {
    ASSERT_EQ(kata_clip_positions(student, static_cast<uint32_t>(1 + i), p.data(), p.size()), KATA_OK);
    ASSERT_EQ(kata_runtime_push(runtime, 42, static_cast<uint64_t>(i), i / 120.0, p.data(), joints), KATA_OK);
  }
  std::vector<std::vector<unsigned char>> published;
  const char* buffer = reinterpret_cast<const char*>(sub->data());
  const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (published.size() < static_cast<size_t>(frames) && std::chrono::steady_clock::now() < limit) {
    const int n = sub->receive(100);
    if (n > 24 && std::memcmp(buffer + 20, "KRES", 4) == 0)
      published.emplace_back(buffer, buffer + n);
  }
  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);
  ASSERT_EQ(published.size(), static_cast<size_t>(frames));
  ASSERT_EQ(kept.records.size(), static_cast<size_t>(frames));
  std::vector<unsigned char> written(1 << 16);
  int scored = 0;
  for (int i = 0; i < frames; ++i) {
    SCOPED_TRACE(i);
    kata_result_record r = kept.records[static_cast<size_t>(i)];
    r.ghost = kept.ghosts[static_cast<size_t>(i)].empty() ? nullptr : kept.ghosts[static_cast<size_t>(i)].data();
    ASSERT_GT(r.ghost_joint_count, 0u);
    ASSERT_EQ(r.has_practice, 1);
    scored += r.scored;
    size_t size = 0;
    ASSERT_EQ(kata_message_write_result(&r, nullptr, 0, &size), KATA_E_BUFFER_TOO_SMALL);
    ASSERT_EQ(size, published[static_cast<size_t>(i)].size());
    ASSERT_EQ(kata_message_write_result(&r, written.data(), written.size(), &size), KATA_OK) << kata_context_last_error(ctx);
    ASSERT_EQ(size, published[static_cast<size_t>(i)].size());
    EXPECT_EQ(std::memcmp(written.data(), published[static_cast<size_t>(i)].data(), size), 0);
  }
  EXPECT_GT(scored, 20);
  // A 1.0-sized record (no cue fields): the cue reads back as "none", the rest as written.
  kata_result_record r = kept.records.back();
  r.ghost = kept.ghosts.back().data();
  r.cue_joint = 3;
  r.struct_size = static_cast<uint32_t>(offsetof(kata_result_record, reserved0) + sizeof r.reserved0);
  size_t size = 0;
  ASSERT_EQ(kata_message_write_result(&r, written.data(), written.size(), &size), KATA_OK);
  kata_result_record back;
  back.struct_size = sizeof back;
  ASSERT_EQ(kata_message_read_result(written.data(), size, &back), KATA_OK);
  EXPECT_EQ(back.cue_joint, -1);
  EXPECT_EQ(back.cue_action, -1);
  EXPECT_EQ(back.result_sequence, r.result_sequence);
  EXPECT_EQ(std::memcmp(&back.score, &r.score, sizeof r.score), 0);
  EXPECT_EQ(back.ghost_joint_count, r.ghost_joint_count);
  // Refusals write nothing and say why.
  r.struct_size = 16;
  EXPECT_EQ(kata_message_write_result(&r, written.data(), written.size(), &size), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(size, 0u);
  r.struct_size = sizeof r;
  r.ghost = nullptr;
  EXPECT_EQ(kata_message_write_result(&r, written.data(), written.size(), &size), KATA_E_NULL_POINTER);
  std::vector<float> bad = kept.ghosts.back();
  bad[4] = std::nanf("");
  r.ghost = bad.data();
  EXPECT_EQ(kata_message_write_result(&r, written.data(), written.size(), &size), KATA_E_NON_FINITE);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("ghost joint 1"), std::string::npos) << kata_context_last_error(ctx);
  r.ghost = kept.ghosts.back().data();
  r.score = std::numeric_limits<float>::infinity();
  EXPECT_EQ(kata_message_write_result(&r, written.data(), written.size(), &size), KATA_E_NON_FINITE);
  EXPECT_EQ(kata_message_write_result(nullptr, written.data(), written.size(), &size), KATA_E_NULL_POINTER);
  sub.reset();
  zmq_ctx_term(zctx);
  kata_runtime_destroy(runtime);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(teacher);
  kata_clip_destroy(student);
  kata_model_destroy(model);
  kata_context_destroy(ctx);
}
