// The runtime end to end: frames pushed (or ingested over ZeroMQ), results received by a SUB
// socket in the same process over loopback, compared with an in-process pipeline. Every wait
// is bounded; ipc paths are unique per process.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zmq.h>

#include <time.h>

#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "transport/wire.hpp"
#include "support/accounting.hpp"
#include "support/alloc_counter.hpp"
#include "support/zmq_subscriber.hpp"

namespace kata::runtime {
namespace {

using transport::SkeletonDefinition;

// ipc endpoints unique per process (short: a socket path holds at most 107 bytes); ZeroMQ
// removes the file when the bound socket closes.
std::string unique_ipc(const char* tag) {
  static int counter = 0;
  return "ipc:///tmp/kata_rt_" + std::to_string(getpid()) + "_" + tag + "_" + std::to_string(counter++);
}

struct Fixture {
  BvhClip student = load_bvh(std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh");
  std::shared_ptr<const metric::Metric> metric = test::default_metric();
  std::vector<float> positions = clip_positions(student);
  std::shared_ptr<const pipeline::Teacher> teacher = test::clip_teacher(metric, "02_01");

  int joints() const { return student.skeleton.joint_count(); }
  const float* frame(int i) const { return positions.data() + static_cast<size_t>(i) * 3 * static_cast<size_t>(joints()); }

  SkeletonDefinition definition(uint64_t id) const {
    SkeletonDefinition d;
    d.stream_id = id;
    d.revision = 1;
    d.skeleton = student.skeleton;
    d.layout = "cmu";
    d.frame_rate = static_cast<float>(1.0 / student.frame_time);
    return d;
  }
  StreamSetup setup(bool with_teacher) const {
    StreamSetup s;
    const GpdMap map = make_gpd_map(student.skeleton, preset_joint_names("cmu"));
    s.pipeline.stream = stream_config_for(student.skeleton, map, metric->stencil());
    s.pipeline.student = student.skeleton;
    s.pipeline.result_capacity = 64;
    if (with_teacher) s.teacher = teacher;
    return s;
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

struct Expected {
  pipeline::Result result;
  std::vector<float> ghost;
};

std::vector<Expected> in_process(const StreamSetup& setup, int first, int frames, double frame_time) {
  pipeline::Pipeline p(setup.pipeline);
  if (setup.teacher) p.set_teacher(setup.teacher, setup.teacher_options);
  std::vector<Expected> out;
  std::vector<pipeline::Result> r(8);
  std::vector<float> g(8 * 3 * static_cast<size_t>(std::max(1, p.ghost_joint_count())));
  auto drain = [&] {
    for (size_t n; (n = p.read(r.data(), g.data(), nullptr, r.size())) > 0;)
      for (size_t i = 0; i < n; ++i) {
        const size_t per = 3 * static_cast<size_t>(p.ghost_joint_count());
        out.push_back({r[i], std::vector<float>(g.begin() + static_cast<long>(i * per),
                                                g.begin() + static_cast<long>((i + 1) * per))});
      }
  };
  for (int i = 0; i < frames; ++i) {
    EXPECT_EQ(p.push(i * frame_time, fixture().frame(first + i), fixture().joints()), Status::kOk);
    drain();
  }
  p.flush();
  drain();
  return out;
}

class runtime_end_to_end : public ::testing::TestWithParam<const char*> {};

TEST_P(runtime_end_to_end, EveryFrameOutInOrderEqualToTheInProcessPipeline) {
  Fixture& fx = fixture();
  const std::string param = GetParam();  // "tcp", "ipc", or "tcp-backoff" (the backoff idle strategy)
  const std::string transport = param.substr(0, 3);
  RuntimeConfig config;
  config.workers = 2;
  if (param == "tcp-backoff") config.idle.kind = runtime::IdleStrategy::Kind::kBackoff;
  config.publish.endpoints = {transport == "tcp" ? "tcp://127.0.0.1:*" : unique_ipc("e2e")};
  Runtime runtime(config);
  const uint64_t ids[2] = {11, 12};
  const int first[2] = {1, 40};
  const int frames = 150;
  for (uint64_t id : ids) runtime.open_stream(fx.definition(id), fx.setup(true));

  std::map<uint64_t, kata::test::StreamTally> tally;  // frames pushed, results received
  void* context = zmq_ctx_new();
  {
    // Joins after the streams were opened: the definitions come again on its join.
    test::ZmqSubscriber sub(context, runtime.publish_endpoint());
    transport::Decoder decoder;
    std::map<uint64_t, int> definitions;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (definitions.size() < 2 && std::chrono::steady_clock::now() < deadline)
      if (sub.next(decoder, 100) == transport::MessageKind::kSkeleton) {
        const SkeletonDefinition d = decoder.skeleton();
        EXPECT_EQ(d.skeleton.names, fx.student.skeleton.names);
        EXPECT_EQ(d.layout, "cmu");
        ++definitions[d.stream_id];
      }
    ASSERT_EQ(definitions.size(), 2u) << "a late subscriber must get every skeleton definition";

    for (int i = 0; i < frames; ++i)
      for (int s = 0; s < 2; ++s) {
        ASSERT_EQ(runtime.push(ids[s], static_cast<uint64_t>(i), i * fx.student.frame_time, fx.frame(first[s] + i),
                               fx.joints()),
                  Status::kOk);
        ++tally[ids[s]].sent;
      }

    std::map<uint64_t, std::vector<transport::ResultFields>> got;
    std::map<uint64_t, std::vector<std::vector<float>>> ghosts;
    size_t total = 0;
    const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (total < 2 * static_cast<size_t>(frames) && std::chrono::steady_clock::now() < limit) {
      if (sub.next(decoder, 100) != transport::MessageKind::kResult) continue;
      const transport::ResultFields& r = decoder.result();
      got[r.stream_id].push_back(r);
      ghosts[r.stream_id].emplace_back(r.ghost, r.ghost + 3 * r.ghost_joint_count);
      ++tally[r.stream_id].received;
      ++total;
    }
    runtime.stop();
    for (int s = 0; s < 2; ++s) {
      const auto expected = in_process(fx.setup(true), first[s], frames, fx.student.frame_time);
      // The backward stencil and a rest-pose body height: one result per frame, none held.
      ASSERT_EQ(expected.size(), static_cast<size_t>(frames));
      const auto& r = got[ids[s]];
      ASSERT_EQ(r.size(), expected.size()) << "stream " << ids[s];
      for (size_t i = 0; i < r.size(); ++i) {
        SCOPED_TRACE("stream " + std::to_string(ids[s]) + " result " + std::to_string(i));
        EXPECT_EQ(r[i].result_sequence, i);
        EXPECT_EQ(r[i].frame_sequence, static_cast<uint64_t>(expected[i].result.frame_index));
        EXPECT_EQ(r[i].frame_index, expected[i].result.frame_index);
        EXPECT_NEAR(r[i].capture_time, expected[i].result.capture_time, 1e-9);
        EXPECT_TRUE(r[i].scored);
        EXPECT_EQ(r[i].score, expected[i].result.score.score);
        EXPECT_EQ(r[i].distance, expected[i].result.score.distance);
        for (int k = 0; k < 5; ++k) EXPECT_EQ(r[i].parts[k], expected[i].result.score.parts[k]);
        EXPECT_EQ(r[i].matched_teacher_frame, expected[i].result.matched_frame);
        EXPECT_EQ(r[i].matched_teacher_time, expected[i].result.score.matched_time);
        EXPECT_EQ(ghosts[ids[s]][i], expected[i].ghost);
        EXPECT_GT(r[i].arrival_ns, 0);
        EXPECT_LE(r[i].arrival_ns, r[i].computed_ns);
        EXPECT_LE(r[i].computed_ns, r[i].published_ns);
      }
    }
  }
  zmq_ctx_term(context);
  const RuntimeCounters c = runtime.counters();
  EXPECT_EQ(c.total.frames_in, 2u * frames);
  EXPECT_EQ(c.total.results, 2u * frames);
  EXPECT_EQ(c.total.published, 2u * frames);
  EXPECT_EQ(c.total.queue_full + c.total.result_queue_full + c.total.pipeline_dropped + c.total.refused, 0u);
  EXPECT_TRUE(kata::test::every_frame_accounted(runtime, tally));
}

INSTANTIATE_TEST_SUITE_P(transports, runtime_end_to_end, ::testing::Values("tcp", "ipc", "tcp-backoff"));

// The backoff idle strategy spins only while a worker holds a frame: a runtime with open streams
// and no frames costs (almost) no CPU. A thread left spinning would burn about a core-second here.
TEST(runtime_idle, BackoffBurnsNoCpuWithoutFrames) {
  Fixture& fx = fixture();
  RuntimeConfig config;
  config.workers = 2;
  config.idle.kind = runtime::IdleStrategy::Kind::kBackoff;
  config.publish.endpoints = {"tcp://127.0.0.1:*"};
  Runtime runtime(config);
  runtime.open_stream(fx.definition(5), fx.setup(true));
  for (int i = 0; i < 4; ++i)  // a few frames first: every thread has run its backoff once
    ASSERT_EQ(runtime.push(5, static_cast<uint64_t>(i), i * fx.student.frame_time, fx.frame(1 + i), fx.joints()),
              Status::kOk);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  auto cpu = [] {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  };
  const double before = cpu();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double used = cpu() - before;
  EXPECT_LT(used, 0.1) << "CPU seconds in one idle second";
  runtime.stop();
  EXPECT_EQ(runtime.counters().total.results, 4u);
}

TEST(runtime_stall, StalledSubscriberLosesMessagesNotThePipelinesRate) {
  Fixture& fx = fixture();
  RuntimeConfig config;
  config.workers = 2;
  config.publish.endpoints = {unique_ipc("stall")};
  config.publish.send_hwm = 50;
  Runtime runtime(config);
  StreamSetup setup = fx.setup(false);
  setup.pipeline.keep_features = true;
  setup.publish_features = true;  // ~7 KB results: far more than the socket buffers hold
  runtime.open_stream(fx.definition(1), setup);

  void* context = zmq_ctx_new();
  {
    test::ZmqSubscriber sub(context, runtime.publish_endpoint(), 50);
    transport::Decoder decoder;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (sub.next(decoder, 100) != transport::MessageKind::kSkeleton && std::chrono::steady_clock::now() < deadline) {}

    // The subscriber reads nothing for 2 s while frames come at 1 kHz (paced by sleeping).
    const int frames = 2000;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < frames; ++i) {
      std::this_thread::sleep_until(start + std::chrono::microseconds(1000 * i));
      ASSERT_EQ(runtime.push(1, static_cast<uint64_t>(i), i * 0.001, fx.frame(1 + i % (fx.student.frame_count() - 1)), fx.joints()),
                Status::kOk);
    }
    // Every frame was computed and handed to ZeroMQ while nobody read.
    const auto wait_until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (runtime.counters().total.published + runtime.counters().total.send_failed < frames &&
           std::chrono::steady_clock::now() < wait_until)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const RuntimeCounters c = runtime.counters();
    EXPECT_EQ(c.total.results, static_cast<uint64_t>(frames));
    EXPECT_EQ(c.total.published, static_cast<uint64_t>(frames));
    EXPECT_EQ(c.total.queue_full + c.total.result_queue_full + c.total.pipeline_dropped, 0u);

    // Now read what is left: ZeroMQ dropped at its high-water marks; the gaps in result_sequence
    // account for every message not received.
    uint64_t received = 0, gaps = 0, last = 0;
    bool any = false;
    for (transport::MessageKind k; (k = sub.next(decoder, 500)) != transport::MessageKind::kNone;) {
      if (k != transport::MessageKind::kResult) continue;
      const uint64_t seq = decoder.result().result_sequence;
      if (any) {
        EXPECT_GT(seq, last);
        gaps += seq - last - 1;
      } else {
        gaps += seq;
      }
      last = seq;
      any = true;
      ++received;
    }
    gaps += static_cast<uint64_t>(frames) - 1 - last;
    EXPECT_EQ(received + gaps, static_cast<uint64_t>(frames));
    EXPECT_GT(gaps, 0u) << "the high-water marks should have dropped messages";
    EXPECT_LT(received, 1000u) << "memory bounded: far fewer than all queued";
    runtime.stop();
    // ZeroMQ's drops are not the runtime's to count: the subscriber counts them (its gaps).
    EXPECT_TRUE(kata::test::every_frame_accounted(runtime, {{1, {static_cast<uint64_t>(frames), received, gaps}}}));
  }
  zmq_ctx_term(context);
}

// Nothing lost at the end: every result stop() published reaches a connected subscriber that
// reads only after stop() returned (1000 results of 7 KB, megabytes more than the socket buffers
// hold, so most are still in the publisher's queue when it closes; with ZMQ_LINGER 0 they were
// dropped: 429 and 443 of 1000 received in two runs).
TEST(runtime_stop, ResultsPublishedBeforeStopReachASubscriberAfterIt) {
  Fixture& fx = fixture();
  const int frames = 1000;
  void* context = zmq_ctx_new();
  {
    std::unique_ptr<Runtime> runtime;
    {
      RuntimeConfig config;
      config.workers = 1;
      config.publish.endpoints = {"tcp://127.0.0.1:*"};
      runtime = std::make_unique<Runtime>(config);
    }
    StreamSetup setup = fx.setup(false);
    setup.pipeline.keep_features = true;
    setup.publish_features = true;
    runtime->open_stream(fx.definition(5), setup);
    // A receive high-water mark of 10 keeps the results that the socket buffers cannot hold in the
    // publisher's queue (below its own mark of 10000: none is dropped there).
    test::ZmqSubscriber sub(context, runtime->publish_endpoint(), 10);
    transport::Decoder decoder;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (sub.next(decoder, 100) != transport::MessageKind::kSkeleton && std::chrono::steady_clock::now() < deadline) {}

    // Paced (at most 16 frames ahead of the results) so that the worker's queue never drops one.
    for (int i = 0; i < frames; ++i) {
      ASSERT_EQ(runtime->push(5, static_cast<uint64_t>(i), i * fx.student.frame_time,
                              fx.frame(1 + i % (fx.student.frame_count() - 1)), fx.joints()),
                Status::kOk);
      const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(10);
      while (runtime->counters().total.results + 16 < static_cast<uint64_t>(i) && std::chrono::steady_clock::now() < limit)
        std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    runtime->stop();
    const RuntimeCounters c = runtime->counters();
    ASSERT_EQ(c.total.published, static_cast<uint64_t>(frames));
    ASSERT_EQ(c.total.queue_full + c.total.result_queue_full + c.total.send_failed, 0u);
    std::thread destroy([&] { runtime.reset(); });  // waits (bounded) for the queued results to go out
    uint64_t received = 0, in_order = 0;
    for (transport::MessageKind k;
         received < static_cast<uint64_t>(frames) && (k = sub.next(decoder, 3000)) != transport::MessageKind::kNone;) {
      if (k != transport::MessageKind::kResult) continue;
      in_order += decoder.result().result_sequence == received;
      ++received;
    }
    destroy.join();
    EXPECT_EQ(received, static_cast<uint64_t>(frames)) << "results published before stop() were dropped at close";
    EXPECT_EQ(in_order, received);
  }
  zmq_ctx_term(context);
}

TEST(runtime_ingest, StreamsFromTheirDefinitionRestartCounted) {
  Fixture& fx = fixture();
  RuntimeConfig config;
  config.workers = 2;
  config.publish.endpoints = {"tcp://127.0.0.1:*"};
  config.ingest.kind = transport::IngestKind::kPull;
  config.ingest.endpoints = {"bind:" + unique_ipc("ingest")};
  Runtime runtime(config);

  int results = 0;  // received by the subscriber
  void* context = zmq_ctx_new();
  {
    test::ZmqSubscriber sub(context, runtime.publish_endpoint());
    transport::Decoder decoder;
    void* push = zmq_socket(context, ZMQ_PUSH);
    int linger = 2000;
    zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
    ASSERT_EQ(zmq_connect(push, runtime.ingest_endpoint().c_str()), 0);
    transport::Encoder encoder;
    auto send = [&](transport::Bytes m) { zmq_send(push, m.data, m.size, 0); };
    send(encoder.frame(3, 0, 0, fx.frame(1), fx.joints()));  // before its definition: unknown stream
    send(encoder.skeleton(fx.definition(3)));
    // The stream exists once its definition comes back to the subscriber (sent on open, on the
    // subscriber's join, and every second), so no result is published before anyone listens.
    const auto joined = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (sub.next(decoder, 100) != transport::MessageKind::kSkeleton && std::chrono::steady_clock::now() < joined) {}
    const int64_t dt = static_cast<int64_t>(fx.student.frame_time * 1e9);
    for (int i = 0; i < 30; ++i) send(encoder.frame(3, static_cast<uint64_t>(i), i * dt, fx.frame(1 + i), fx.joints()));
    // The source restarts: sequence and its clock back to 0.
    for (int i = 0; i < 20; ++i) send(encoder.frame(3, static_cast<uint64_t>(i), i * dt, fx.frame(100 + i), fx.joints()));

    results = 0;
    int64_t restarts_seen = 0, last_index = -1;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (results < 50 && std::chrono::steady_clock::now() < deadline) {
      if (sub.next(decoder, 100) != transport::MessageKind::kResult) continue;
      const transport::ResultFields& r = decoder.result();
      EXPECT_EQ(r.stream_id, 3u);
      EXPECT_FALSE(r.scored);
      if (r.frame_sequence == 0 && results > 0) ++restarts_seen;
      EXPECT_GT(r.frame_index, last_index);
      last_index = r.frame_index;
      ++results;
    }
    zmq_close(push);
    EXPECT_EQ(results, 50);
    EXPECT_EQ(restarts_seen, 1);
  }
  zmq_ctx_term(context);
  runtime.stop();
  const RuntimeCounters c = runtime.counters();
  EXPECT_EQ(c.streams, 1u);
  EXPECT_EQ(c.ingest.unknown_stream, 1u);
  EXPECT_EQ(c.ingest.restarts, 1u);
  EXPECT_EQ(c.ingest.frames, 50u);
  EXPECT_EQ(c.total.refused, 0u);
  // The 50 frames after the definition (the one before it is the ingest's unknown_stream above).
  EXPECT_TRUE(kata::test::every_frame_accounted(runtime, {{3, {50, static_cast<uint64_t>(results)}}}));
}

TEST(runtime_alloc, PushWorkerAndResultQueuesAllocateNothingPerFrame) {
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under AddressSanitizer";
  Fixture& fx = fixture();
  RuntimeConfig config;
  // No publisher: libzmq itself mallocs every message it sends (200 allocations for 200 results
  // when one is bound), which this test cannot tell from ours.
  config.workers = 2;
  std::map<uint64_t, kata::test::StreamTally> tally;  // sent by the test, received by the sink
  Sink sink;  // on the I/O thread: read after stop (joined)
  sink.on_result = [&tally](const transport::ResultFields& r) { ++tally.at(r.stream_id).received; };
  config.sinks.push_back(sink);
  tally[1];
  tally[2];  // every node made before the runtime runs: the sink's at() never allocates
  Runtime runtime(config);
  runtime.open_stream(fx.definition(1), fx.setup(true));
  runtime.open_stream(fx.definition(2), fx.setup(true));
  auto push_and_wait = [&](int first, int count) {
    for (int i = first; i < first + count; ++i)
      for (uint64_t id : {1u, 2u}) {
        ++tally[id].sent;
        if (runtime.push(id, static_cast<uint64_t>(i), i * fx.student.frame_time, fx.frame(1 + i), fx.joints()) !=
            Status::kOk)
          return false;
      }
    const uint64_t want = 2u * static_cast<uint64_t>(first + count);
    for (int tries = 0; tries < 2000 && runtime.counters().total.results < want; ++tries)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return runtime.counters().total.results == want;
  };
  ASSERT_TRUE(push_and_wait(0, 20));  // warm-up: first-frame paths, thread-local state
  const long before = kata::test::allocations();
  const bool done = push_and_wait(20, 100);
  const long allocated = kata::test::allocations() - before;
  ASSERT_TRUE(done);
  EXPECT_EQ(allocated, 0) << "per-frame path allocated";
  runtime.stop();
  EXPECT_TRUE(kata::test::every_frame_accounted(runtime, tally, kata::test::Delivery::kSinks));
}

}  // namespace
}  // namespace kata::runtime
