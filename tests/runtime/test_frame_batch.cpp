// Frame batches (schemas/frame_batch.fbs) through a whole runtime over loopback TCP: a source's
// frames of many streams in one message per tick give the results the same frames give sent one
// message each, bit for bit; and hostile batches (a frame of another sender's stream, a NaN frame,
// a stream twice in one batch, truncated and oversized batches) are refused and counted by cause,
// frame by frame, while every other frame of the batch and every other stream keeps its result.
// Senders are PUSH sockets of their own (their own connections); results come to an in-process
// sink. Frames carry the clip's capture times and are sent as fast as ZeroMQ takes them, with no
// age limit, so a loaded machine changes no result. Every wait is bounded.
#include <gtest/gtest.h>
#include <zmq.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "support/accounting.hpp"
#include "support/alloc_counter.hpp"
#include "transport/wire.hpp"
#include "transport/zmq_io.hpp"

namespace kata::runtime {
namespace {

using Clock = std::chrono::steady_clock;
using transport::Encoder;
using transport::ResultFields;
using transport::SkeletonDefinition;

// The teacher and the students: 05_18 from clip frame 1; stream k follows it from row 7k.
struct Lesson : test::LiveClip {
  std::shared_ptr<const metric::Metric> metric = test::default_metric();
  std::shared_ptr<const pipeline::Teacher> teacher = test::clip_teacher(metric, "05_18");
  Lesson() : test::LiveClip("05_18") {}
  // Stream id's frame of sequence `seq`: its row and its capture time (the clip's time).
  const float* frame(uint64_t id, uint64_t seq) const { return LiveClip::frame(static_cast<int64_t>(7 * id + seq)); }
  int64_t capture_ns(uint64_t seq) const { return static_cast<int64_t>(std::llround((1.0 + seq) * frame_time() * 1e9)); }
};

const Lesson& lesson() {
  static Lesson l;
  return l;
}

// What a result says, but its times (when it was computed and sent): compared bit for bit.
struct Record {
  uint64_t result_sequence = 0, frame_sequence = 0;
  int64_t frame_index = 0;
  double capture_time = 0.0;
  int32_t scored = 0;
  float distance = 0.0f, score = 0.0f, parts[KATA_PART_COUNT] = {}, part_scores[KATA_PART_COUNT] = {};
  int32_t matched_teacher_frame = 0, part_to_fix = 0, state = 0, cue_joint = 0, cue_action = 0;
  double matched_teacher_time = 0.0;
  float cue_degrees = 0.0f;
  std::vector<float> ghost;
  bool operator==(const Record& o) const {
    return result_sequence == o.result_sequence && frame_sequence == o.frame_sequence &&
           frame_index == o.frame_index && std::memcmp(&capture_time, &o.capture_time, sizeof capture_time) == 0 &&
           scored == o.scored && std::memcmp(&distance, &o.distance, sizeof distance) == 0 &&
           std::memcmp(&score, &o.score, sizeof score) == 0 && std::memcmp(parts, o.parts, sizeof parts) == 0 &&
           std::memcmp(part_scores, o.part_scores, sizeof part_scores) == 0 &&
           matched_teacher_frame == o.matched_teacher_frame && part_to_fix == o.part_to_fix && state == o.state &&
           cue_joint == o.cue_joint && cue_action == o.cue_action &&
           std::memcmp(&matched_teacher_time, &o.matched_teacher_time, sizeof matched_teacher_time) == 0 &&
           std::memcmp(&cue_degrees, &o.cue_degrees, sizeof cue_degrees) == 0 && ghost.size() == o.ghost.size() &&
           (ghost.empty() || std::memcmp(ghost.data(), o.ghost.data(), ghost.size() * sizeof(float)) == 0);
  }
};

Record record_of(const ResultFields& f) {
  Record r;
  r.result_sequence = f.result_sequence;
  r.frame_sequence = f.frame_sequence;
  r.frame_index = f.frame_index;
  r.capture_time = f.capture_time;
  r.scored = f.scored;
  r.distance = f.distance;
  r.score = f.score;
  std::memcpy(r.parts, f.parts, sizeof r.parts);
  std::memcpy(r.part_scores, f.part_scores, sizeof r.part_scores);
  r.matched_teacher_frame = f.matched_teacher_frame;
  r.matched_teacher_time = f.matched_teacher_time;
  r.part_to_fix = f.part_to_fix;
  r.state = f.state;
  r.cue_joint = f.cue_joint;
  r.cue_degrees = f.cue_degrees;
  r.cue_action = f.cue_action;
  if (f.ghost) r.ghost.assign(f.ghost, f.ghost + 3 * static_cast<size_t>(f.ghost_joint_count));
  return r;
}

// A runtime with a PULL ingest and no publisher: every result goes to a sink that keeps it.
struct LiveRun {
  std::mutex mutex;
  std::map<uint64_t, std::vector<Record>> results;
  std::unique_ptr<Runtime> runtime;
  explicit LiveRun(size_t max_message_bytes = 1 << 20) {
    RuntimeConfig config;
    config.workers = 2;
    config.ingest.kind = transport::IngestKind::kPull;
    config.ingest.endpoints = {"bind:tcp://127.0.0.1:*"};
    config.ingest.limits.max_frame_age_ns = 0;  // sent unpaced: never judged stale
    config.ingest.max_message_bytes = max_message_bytes;
    config.ingest.log_refusals = false;
    config.configure_stream = [](const SkeletonDefinition& d) {
      StreamSetup s = setup_from_definition(d);
      s.pipeline.stream.stencil = lesson().metric->stencil();
      s.teacher = lesson().teacher;
      s.teacher_options.ghost = true;
      return s;
    };
    Sink sink;
    sink.on_result = [this](const ResultFields& f) {
      std::lock_guard<std::mutex> lock(mutex);
      results[f.stream_id].push_back(record_of(f));
    };
    config.sinks.push_back(sink);
    runtime = std::make_unique<Runtime>(config);
  }
  size_t result_count() {
    std::lock_guard<std::mutex> lock(mutex);
    size_t n = 0;
    for (const auto& [id, r] : results) n += r.size();
    return n;
  }
  // Waits until the ingest judged `items` frames and definitions (a batch counts as its frames).
  bool judged(uint64_t items, int seconds = 30) {
    const auto end = Clock::now() + std::chrono::seconds(seconds);
    while (Clock::now() < end) {
      const transport::IngestCounters in = runtime->counters().ingest;
      if (in.frames + in.skeletons + in.repeated_skeletons + in.closes + in.other_shard + in.dropped_total() >= items)
        return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  bool streams_open(uint64_t n, int seconds = 30) {
    const auto end = Clock::now() + std::chrono::seconds(seconds);
    while (runtime->counters().streams < n && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return runtime->counters().streams >= n;
  }
};

// One sender: its own PUSH socket, so its own connection.
struct Sender {
  void* socket;
  Encoder encoder;
  uint64_t messages = 0;
  Sender(void* context, const std::string& endpoint) : socket(zmq_socket(context, ZMQ_PUSH)) {
    int linger = 5000;
    zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof linger);
    zmq_connect(socket, endpoint.c_str());
  }
  ~Sender() { zmq_close(socket); }
  void send(const void* data, size_t size) {
    ASSERT_EQ(zmq_send(socket, data, size, 0), static_cast<int>(size));
    ++messages;
  }
  void send(transport::Bytes m) { send(m.data, m.size); }
};

Encoder::BatchFrame batch_frame(uint64_t id, uint64_t seq) {
  return {id, seq, lesson().capture_ns(seq), lesson().frame(id, seq), lesson().joints(), nullptr, nullptr};
}

constexpr uint64_t kFirstStream = 20;
constexpr int kStreams = 6, kTicks = 90;

// The same frames, one message each in one runtime and one batch per tick in another: every
// stream's results are equal field for field and bit for bit (ghost included), times aside.
TEST(runtime_frame_batch, GivesTheResultsOfTheSameFramesSentOneByOne) {
  std::map<uint64_t, std::vector<Record>> by_mode[2];
  for (int batched = 0; batched < 2; ++batched) {
    LiveRun run;
    void* context = zmq_ctx_new();
    {
      Sender sender(context, run.runtime->ingest_endpoint());
      for (uint64_t s = 0; s < kStreams; ++s) sender.send(sender.encoder.skeleton(lesson().definition(kFirstStream + s)));
      ASSERT_TRUE(run.streams_open(kStreams));
      std::vector<Encoder::BatchFrame> tick(kStreams);
      for (uint64_t t = 0; t < kTicks; ++t) {
        for (uint64_t s = 0; s < kStreams; ++s) tick[s] = batch_frame(kFirstStream + s, t);
        if (batched) {
          sender.send(sender.encoder.frame_batch(tick.data(), tick.size()));
        } else {
          for (const Encoder::BatchFrame& f : tick)
            sender.send(sender.encoder.frame(f.stream_id, f.sequence, f.capture_ns, f.xyz, f.joints));
        }
      }
      ASSERT_TRUE(run.judged(kStreams + kStreams * kTicks));
      const transport::IngestCounters in = run.runtime->counters().ingest;
      EXPECT_EQ(in.frames, static_cast<uint64_t>(kStreams * kTicks));
      EXPECT_EQ(in.batches, batched ? static_cast<uint64_t>(kTicks) : 0u);
      EXPECT_EQ(in.dropped_total(), 0u);
    }
    zmq_ctx_term(context);
    run.runtime->stop();
    std::map<uint64_t, test::StreamTally> tallies;
    for (uint64_t s = 0; s < kStreams; ++s) {
      tallies[kFirstStream + s] = {static_cast<uint64_t>(kTicks), run.results[kFirstStream + s].size(), 0};
    }
    EXPECT_TRUE(test::every_frame_accounted(*run.runtime, tallies, test::Delivery::kSinks));
    by_mode[batched] = run.results;
  }
  ASSERT_EQ(by_mode[0].size(), static_cast<size_t>(kStreams));
  for (const auto& [id, alone] : by_mode[0]) {
    const std::vector<Record>& batched = by_mode[1][id];
    ASSERT_GT(alone.size(), static_cast<size_t>(kTicks) / 2) << "stream " << id << " was scored";
    ASSERT_EQ(batched.size(), alone.size()) << "stream " << id;
    int scored = 0, ghosts = 0;
    for (size_t i = 0; i < alone.size(); ++i) {
      EXPECT_TRUE(batched[i] == alone[i]) << "stream " << id << " result " << i;
      scored += alone[i].scored;
      ghosts += !alone[i].ghost.empty();
    }
    EXPECT_GT(scored, kTicks / 2) << "stream " << id << ": compared scores, not only empty results";
    EXPECT_GT(ghosts, kTicks / 2) << "stream " << id << ": compared ghosts";
  }
}

// Hostile batches beside real streams: each bad frame is refused and counted by cause (on its
// stream when it has one), the batch's other frames are scored, and every frame of every stream is
// accounted for at the end.
TEST(runtime_frame_batch, HostileBatchesAreCountedByCauseAndOtherFramesKeepTheirResults) {
  constexpr uint64_t kA = 1, kB = 2, kTheirs = 3;  // the source's two streams, another sender's one
  constexpr size_t kLimit = 64 * 1024;
  LiveRun run(kLimit);
  void* context = zmq_ctx_new();
  std::map<uint64_t, test::StreamTally> sent;
  uint64_t batches = 0, batch_frames = 0;
  {
    Sender source(context, run.runtime->ingest_endpoint()), other(context, run.runtime->ingest_endpoint());
    source.send(source.encoder.skeleton(lesson().definition(kA)));
    source.send(source.encoder.skeleton(lesson().definition(kB)));
    other.send(other.encoder.skeleton(lesson().definition(kTheirs)));
    ASSERT_TRUE(run.streams_open(3));
    std::vector<float> nan_frame(lesson().frame(kB, 0), lesson().frame(kB, 0) + 3 * lesson().joints());
    nan_frame[4] = NAN;
    uint64_t seq = 0;
    auto send_batch = [&](Sender& from, const std::vector<Encoder::BatchFrame>& frames) {
      from.send(from.encoder.frame_batch(frames.data(), frames.size()));
      ++batches;
      batch_frames += frames.size();
      for (const Encoder::BatchFrame& f : frames) ++sent[f.stream_id].sent;
    };
    for (; seq < 30; ++seq) {
      send_batch(source, {batch_frame(kA, seq), batch_frame(kB, seq)});
      send_batch(other, {batch_frame(kTheirs, seq)});
    }
    // The other sender's frame of the source's stream A, between its own: A's counts it, its own go on.
    send_batch(other, {batch_frame(kTheirs, seq), batch_frame(kA, seq), batch_frame(kTheirs, seq + 1)});
    // B's frame with a NaN coordinate: the pipeline refuses it (counted on B), A's frame beside it is scored.
    Encoder::BatchFrame bad = batch_frame(kB, seq);
    bad.xyz = nan_frame.data();
    send_batch(source, {batch_frame(kA, seq), bad});
    ++seq;
    // A twice in one batch: the same sequence again is out of order, the next one is a frame.
    send_batch(source, {batch_frame(kA, seq), batch_frame(kB, seq), batch_frame(kA, seq), batch_frame(kA, seq + 1)});
    seq += 2;
    // A truncated batch and an oversized one (more bytes than the ingest's limit): refused whole.
    {
      std::vector<Encoder::BatchFrame> frames = {batch_frame(kA, seq), batch_frame(kB, seq)};
      const transport::Bytes m = source.encoder.frame_batch(frames.data(), frames.size());
      source.send(m.data, m.size - 40);
    }
    {
      std::vector<Encoder::BatchFrame> frames;
      for (uint64_t k = 0; k < 200; ++k) frames.push_back(batch_frame(kA, seq + k));
      const transport::Bytes m = source.encoder.frame_batch(frames.data(), frames.size());
      ASSERT_GT(m.size, kLimit);
      source.send(m);
    }
    for (int k = 0; k < 30; ++k, ++seq) {
      send_batch(source, {batch_frame(kA, seq), batch_frame(kB, seq)});
      send_batch(other, {batch_frame(kTheirs, seq + 1)});
    }
    const uint64_t messages = source.messages + other.messages;
    ASSERT_TRUE(run.judged(messages - batches + batch_frames));
    const transport::IngestCounters in = run.runtime->counters().ingest;
    EXPECT_EQ(in.received, messages);
    EXPECT_EQ(in.batches, batches);
    EXPECT_EQ(in.batch_frames, batch_frames);
    EXPECT_EQ(in.not_owner, 1u);
    EXPECT_EQ(in.out_of_order, 1u);
    EXPECT_EQ(in.malformed[static_cast<int>(transport::DecodeError::kVerifier)], 1u);
    EXPECT_EQ(in.malformed[static_cast<int>(transport::DecodeError::kOversized)], 1u);
    EXPECT_EQ(in.malformed_total(), 2u);
    EXPECT_EQ(in.frames + in.skeletons + in.repeated_skeletons + in.closes + in.other_shard + in.dropped_total(),
              in.items());
  }
  zmq_ctx_term(context);
  run.runtime->stop();
  for (auto& [id, tally] : sent) tally.received = run.results[id].size();
  EXPECT_TRUE(test::every_frame_accounted(*run.runtime, sent, test::Delivery::kSinks));
  const StreamCounters a = *run.runtime->stream_counters(kA), b = *run.runtime->stream_counters(kB),
                       theirs = *run.runtime->stream_counters(kTheirs);
  EXPECT_EQ(a.unauthorised, 1u);
  EXPECT_EQ(a.out_of_sequence, 1u);
  EXPECT_EQ(b.refused, 1u) << "the NaN frame";
  EXPECT_EQ(a.refused + a.stale + a.wrong_joints + a.queue_full, 0u);
  EXPECT_EQ(theirs.unauthorised + theirs.refused + theirs.out_of_sequence, 0u) << "the other sender's stream is untouched";
  EXPECT_EQ(run.results[kTheirs].size(), sent[kTheirs].sent);
  // A's frames beside the refused ones were scored: every one sent by its owner, once.
  std::vector<uint64_t> a_sequences;
  for (const Record& r : run.results[kA]) a_sequences.push_back(r.frame_sequence);
  std::vector<uint64_t> expected;
  for (uint64_t k = 0; k < 30; ++k) expected.push_back(k);
  for (uint64_t k = 30; k < 33; ++k) expected.push_back(k);  // beside the NaN, then the pair sent twice
  for (uint64_t k = 33; k < 63; ++k) expected.push_back(k);
  EXPECT_EQ(a_sequences, expected);
}

// The ingest's batch path (decode each frame, judge it, push it) and the workers allocate nothing
// per frame: batches handed to a direct ingest (no socket: libzmq mallocs every message it reads),
// results to a sink.
TEST(runtime_alloc, IngestedBatchesAllocateNothingPerFrame) {
  if (!test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under AddressSanitizer";
  RuntimeConfig config;
  config.workers = 2;
  config.ingest.kind = transport::IngestKind::kDirect;
  config.ingest.limits.max_frame_age_ns = 0;
  config.configure_stream = [](const SkeletonDefinition& d) {
    StreamSetup s = setup_from_definition(d);
    s.pipeline.stream.stencil = lesson().metric->stencil();
    s.teacher = lesson().teacher;
    s.teacher_options.ghost = true;
    return s;
  };
  std::map<uint64_t, test::StreamTally> tally;  // every node made before the runtime runs
  for (uint64_t s = 0; s < kStreams; ++s) tally[kFirstStream + s];
  Sink sink;  // on a runtime thread: read after stop (joined)
  sink.on_result = [&tally](const ResultFields& r) { ++tally.at(r.stream_id).received; };
  config.sinks.push_back(sink);
  Runtime runtime(config);
  Encoder encoder;
  for (uint64_t s = 0; s < kStreams; ++s) {
    const transport::Bytes m = encoder.skeleton(lesson().definition(kFirstStream + s));
    ASSERT_TRUE(runtime.offer(m.data, m.size));
  }
  const auto end = Clock::now() + std::chrono::seconds(30);
  while (runtime.counters().streams < kStreams && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(runtime.counters().streams, static_cast<uint64_t>(kStreams));
  std::vector<Encoder::BatchFrame> tick(kStreams);
  auto send_and_wait = [&](uint64_t first, uint64_t count) {
    for (uint64_t t = first; t < first + count; ++t) {
      for (uint64_t s = 0; s < kStreams; ++s) {
        tick[s] = batch_frame(kFirstStream + s, t);
        ++tally[kFirstStream + s].sent;
      }
      const transport::Bytes m = encoder.frame_batch(tick.data(), tick.size());
      if (!runtime.offer(m.data, m.size)) return false;
    }
    const uint64_t want = kStreams * (first + count);
    for (int tries = 0; tries < 4000 && runtime.counters().total.results < want; ++tries)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return runtime.counters().total.results == want;
  };
  ASSERT_TRUE(send_and_wait(0, 20));  // warm-up: first-frame paths, the encoder's buffers
  const long before = test::allocations();
  const bool done = send_and_wait(20, 100);
  const long allocated = test::allocations() - before;
  ASSERT_TRUE(done);
  EXPECT_EQ(allocated, 0) << "the batch path allocated";
  runtime.stop();
  EXPECT_EQ(runtime.counters().ingest.batches, 120u);
  EXPECT_TRUE(test::every_frame_accounted(runtime, tally, test::Delivery::kSinks));
}

}  // namespace
}  // namespace kata::runtime
