// Stress tests of the runtime's threads, written for ThreadSanitizer (./build.sh tsan runs them;
// the ordinary suite runs them too): many streams pushed from several threads while streams are
// opened and subscribers come and go, a runtime destroyed while frames arrive over ZeroMQ, and
// plugins loaded and unloaded around running runtimes. Besides "no data race", each asserts what
// a user relies on: nothing queued is lost, results arrive in order per stream. Counts and waits
// are bounded; endpoints are tcp://127.0.0.1:* (free ports) or ipc paths unique per process.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zmq.h>

#include <array>
#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "runtime/plugin.hpp"
#include "runtime/plugin_host.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "support/accounting.hpp"
#include "support/temp_paths.hpp"
#include "support/zmq_subscriber.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

using Clock = std::chrono::steady_clock;
using transport::SkeletonDefinition;


// 07_01 from its first frame (T-pose included), wrapping round the clip.
const test::LiveClip& clip() {
  static const test::LiveClip c("07_01", 0);
  return c;
}

// 24 streams over 3 workers, pushed by 4 threads (6 streams each, in order per stream), while
// 8 more streams are opened from another thread, two threads connect and close subscribers
// (each join makes the I/O thread re-send definitions, walking the stream table that open_stream
// grows) and one thread reads counters. A persistent subscriber must see every result of every
// stream, in order.
TEST(runtime_stress, ManyStreamsSeveralPushersSubscribersComeAndGo) {
  const test::LiveClip& c = clip();
  RuntimeConfig config;
  config.workers = 3;
  config.frame_queue_capacity = 8192;
  config.result_queue_capacity = 8192;
  config.publish.endpoints = {"tcp://127.0.0.1:*"};
  config.publish.send_hwm = 1000000;
  config.skeleton_resend_seconds = 0.05;  // the periodic re-send runs often, beside everything else
  Runtime runtime(config);
  constexpr int kPushers = 4, kPerPusher = 6, kLate = 8, kFrames = 60;
  constexpr int kStreams = kPushers * kPerPusher;
  for (int s = 0; s < kStreams; ++s) runtime.open_stream(c.definition(static_cast<uint64_t>(s)), setup_from_definition(c.definition(static_cast<uint64_t>(s))));

  void* context = zmq_ctx_new();
  std::map<uint64_t, std::vector<uint64_t>> sequences;  // frame_sequence of each result, per stream
  {
    test::ZmqSubscriber keeper(context, runtime.publish_endpoint(), 1000000);
    // Joined once a definition arrives (results sent before the join would not reach it).
    transport::Decoder decoder;
    const auto join_limit = Clock::now() + std::chrono::seconds(20);
    for (bool joined = false; !joined && Clock::now() < join_limit;)
      joined = keeper.next(decoder, 100) == transport::MessageKind::kSkeleton;

    std::atomic<bool> done{false};
    std::atomic<uint64_t> pushed{0};
    std::vector<std::thread> threads;
    for (int p = 0; p < kPushers; ++p)
      threads.emplace_back([&, p] {
        for (int f = 0; f < kFrames; ++f)
          for (int k = 0; k < kPerPusher; ++k) {
            const uint64_t id = static_cast<uint64_t>(p * kPerPusher + k);
            if (runtime.push(id, static_cast<uint64_t>(f), f * c.frame_time(), c.frame(f + k), c.joints()) == Status::kOk)
              pushed.fetch_add(1);
          }
      });
    threads.emplace_back([&] {  // streams opened while others run
      for (int s = 0; s < kLate; ++s) {
        const uint64_t id = 1000 + static_cast<uint64_t>(s);
        runtime.open_stream(c.definition(id), setup_from_definition(c.definition(id)));
        for (int f = 0; f < 10; ++f)
          if (runtime.push(id, static_cast<uint64_t>(f), f * c.frame_time(), c.frame(f), c.joints()) == Status::kOk)
            pushed.fetch_add(1);
      }
    });
    for (int t = 0; t < 2; ++t)
      threads.emplace_back([&] {  // subscribers joining and leaving
        while (!done.load()) {
          test::ZmqSubscriber passer(context, runtime.publish_endpoint(), 1000, "", 1);
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
          passer.receive(20);
        }
      });
    threads.emplace_back([&] {  // counters read beside everything
      while (!done.load()) {
        const RuntimeCounters counters = runtime.counters();
        EXPECT_LE(counters.total.results, counters.total.frames_in);
        (void)runtime.stream_counters(3);
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    });

    const uint64_t expected = static_cast<uint64_t>(kStreams * kFrames + kLate * 10);
    uint64_t received = 0;
    const auto limit = Clock::now() + std::chrono::seconds(120);
    while (received < expected && Clock::now() < limit) {
      if (keeper.next(decoder, 100) != transport::MessageKind::kResult) continue;
      sequences[decoder.result().stream_id].push_back(decoder.result().frame_sequence);
      ++received;
    }
    done.store(true);
    for (auto& t : threads) t.join();
    EXPECT_EQ(pushed.load(), expected);
    EXPECT_EQ(received, expected);
  }
  zmq_ctx_term(context);
  runtime.stop();
  ASSERT_EQ(sequences.size(), static_cast<size_t>(kStreams + kLate));
  for (const auto& [id, seq] : sequences) {
    const size_t frames = id >= 1000 ? 10u : static_cast<size_t>(kFrames);
    ASSERT_EQ(seq.size(), frames) << "stream " << id;
    for (size_t i = 0; i < seq.size(); ++i) EXPECT_EQ(seq[i], i) << "stream " << id;
  }
  std::map<uint64_t, kata::test::StreamTally> tally;
  for (const auto& [id, seq] : sequences) tally[id] = {id >= 1000 ? 10u : static_cast<uint64_t>(kFrames), seq.size()};
  EXPECT_TRUE(kata::test::every_frame_accounted(runtime, tally));
  const RuntimeCounters counters = runtime.counters();
  EXPECT_EQ(counters.streams, static_cast<uint64_t>(kStreams + kLate));
  EXPECT_EQ(counters.total.queue_full + counters.total.result_queue_full + counters.total.pipeline_dropped +
                counters.total.refused + counters.total.send_failed,
            0u);
}

// A source keeps sending definitions and frames over ZeroMQ while runtimes reading them are
// created and destroyed, three times; frames queued when stop begins are finished.
TEST(runtime_stress, RuntimeDestroyedWhileFramesArrive) {
  const test::LiveClip& c = clip();
  void* context = zmq_ctx_new();
  void* pub = zmq_socket(context, ZMQ_PUB);
  int linger = 0;
  zmq_setsockopt(pub, ZMQ_LINGER, &linger, sizeof linger);
  const std::string endpoint = "ipc:///tmp/kata_stress_" + std::to_string(getpid()) + "_src";
  ASSERT_EQ(zmq_bind(pub, endpoint.c_str()), 0);
  std::atomic<bool> done{false};
  std::thread source([&] {  // the PUB socket is used by this thread only from here on
    transport::Encoder encoder;
    uint64_t sequence = 0;
    const int64_t dt = static_cast<int64_t>(c.frame_time() * 1e9);
    while (!done.load()) {
      for (uint64_t id = 0; id < 4; ++id) {
        if (sequence % 50 == 0) {
          const transport::Bytes d = encoder.skeleton(c.definition(id));
          zmq_send(pub, d.data, d.size, ZMQ_DONTWAIT);
        }
        const transport::Bytes f = encoder.frame(id, sequence, static_cast<int64_t>(sequence) * dt,
                                                 c.frame(static_cast<int>(sequence)), c.joints());
        zmq_send(pub, f.data, f.size, ZMQ_DONTWAIT);
      }
      ++sequence;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    zmq_close(pub);
  });
  for (int round = 0; round < 3; ++round) {
    RuntimeConfig config;
    config.workers = 2;
    config.ingest.endpoints = {endpoint};
    uint64_t published_by_sink = 0;  // the sink runs on the I/O thread; read after stop (joined)
    std::array<uint64_t, 4> sunk{};  // per stream
    Sink sink;
    sink.on_result = [&](const transport::ResultFields& r) {
      ++published_by_sink;
      ++sunk[r.stream_id];
    };
    config.sinks.push_back(sink);
    auto runtime = std::make_unique<Runtime>(config);
    const auto limit = Clock::now() + std::chrono::seconds(30);
    while (runtime->counters().total.results < 40 && Clock::now() < limit)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    runtime->stop();
    const RuntimeCounters counters = runtime->counters();
    // A PUB source joined late sends more than ingest sees: "sent" is what ingest handed on.
    std::map<uint64_t, kata::test::StreamTally> tally;
    for (const auto& [id, sc] : runtime->all_stream_counters())
      tally[id] = {sc.frames_in + sc.queue_full + sc.stopped, sunk[id]};
    EXPECT_TRUE(kata::test::every_frame_accounted(*runtime, tally, kata::test::Delivery::kSinks)) << "round " << round;
    runtime.reset();  // destroyed while the source keeps sending
    EXPECT_GE(counters.total.results, 40u) << "round " << round;
    EXPECT_GT(counters.ingest.frames, 0u);
    // Every frame queued before stop was finished and handed to the sink.
    EXPECT_EQ(counters.total.frames_in, counters.total.results + counters.total.refused);
    EXPECT_EQ(published_by_sink, counters.total.results);
  }
  done.store(true);
  source.join();
  zmq_ctx_term(context);
}

// The shipped plugins loaded, run and unloaded (dlclose) around three runtimes in a row, each
// round with its own csv-sink file: a source thread inside the plugin pushes while the sink
// writes on the I/O thread. The file holds every result the runtime counted.
TEST(runtime_stress, PluginsLoadedAndUnloadedAroundRunningRuntimes) {
  kata::test::TempDir tmp;
  const std::string bvh = std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh";
  for (int round = 0; round < 3; ++round) {
    const std::string csv = (tmp.path() / ("round" + std::to_string(round) + ".csv")).string();
    uint64_t results = 0;
    StreamCounters counted;
    {
      auto target = std::make_shared<PluginHostTarget>();
      std::shared_ptr<LoadedPlugin> sink_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/csv-sink.so");
      std::shared_ptr<LoadedPlugin> source_plugin = LoadedPlugin::load(std::string(KATA_PLUGIN_DIR) + "/bvh-replay.so");
      PluginInstance sink(sink_plugin, "path=" + csv, target);
      RuntimeConfig config;
      config.sinks.push_back(sink.sink());
      Runtime runtime(config);
      target->runtime = &runtime;
      PluginInstance source(source_plugin, "path=" + bvh + ";stream=9;speed=40;loops=100", target);
      source.start();
      const auto limit = Clock::now() + std::chrono::seconds(30);
      while (runtime.counters().total.results < 60 && Clock::now() < limit)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      source.stop();  // joins the plugin's thread
      runtime.stop();
      target->runtime = nullptr;
      results = runtime.counters().total.results;
      counted = runtime.stream_counters(9).value();
      EXPECT_GE(results, 60u);
    }  // instances deactivated, plugins unloaded
    std::ifstream in(csv);
    std::string line;
    uint64_t rows = 0;
    std::getline(in, line);
    while (std::getline(in, line)) ++rows;
    EXPECT_EQ(rows, results) << "round " << round;
    // What the source plugin pushed ("sent": what the queue took or refused) is in the file.
    EXPECT_EQ(kata::test::unaccounted(9, {counted.frames_in + counted.queue_full + counted.stopped, rows}, counted,
                                      kata::test::Delivery::kSinks),
              "")
        << "round " << round;
  }
}

// stop() while several threads push, 1,000 times: each push is either taken (kOk, and
// its result reaches the sink before stop() returns) or refused (kStopped, counted per stream);
// once a thread saw kStopped it never sees kOk again; every frame is accounted for. Eight lanes of
// 125 runtimes each run side by side (a stop waits for the workers' 50 ms idle wake-up).
TEST(runtime_stress, PushesRacingStopAreTakenOrRefusedNeverLost) {
  const test::LiveClip& c = clip();
  constexpr int kLanes = 8, kRounds = 125, kPushers = 3, kMaxFrames = 400;
  std::atomic<int> failures{0};
  std::atomic<uint64_t> taken_total{0}, refused_total{0};
  auto lane = [&](int lane_index) {
    for (int round = 0; round < kRounds && failures.load() == 0; ++round) {
      RuntimeConfig config;
      config.workers = 2;
      config.frame_queue_capacity = 512;
      // Room for every result a worker's streams can make (2 x kMaxFrames): none is dropped for
      // a slow I/O thread, so every frame taken is a result the sink receives.
      config.result_queue_capacity = 1024;
      config.max_joints = c.joints();
      config.max_streams = kPushers;
      std::array<uint64_t, kPushers> sunk{};  // on the I/O thread; read after stop (joined)
      Sink sink;
      sink.on_result = [&sunk](const transport::ResultFields& r) { ++sunk[r.stream_id]; };
      config.sinks.push_back(sink);
      Runtime runtime(config);
      for (uint64_t id = 0; id < kPushers; ++id) runtime.open_stream(c.definition(id), setup_from_definition(c.definition(id)));
      struct Tally {
        uint64_t ok = 0, full = 0, stopped = 0, ok_after_stopped = 0, other = 0;
      };
      std::array<Tally, kPushers> tallies{};
      std::atomic<bool> go{false};
      std::vector<std::thread> pushers;
      for (int p = 0; p < kPushers; ++p)
        pushers.emplace_back([&, p] {
          while (!go.load(std::memory_order_acquire)) std::this_thread::yield();
          Tally& t = tallies[static_cast<size_t>(p)];
          for (int f = 0; f < kMaxFrames; ++f) {
            const Status st = runtime.push(static_cast<uint64_t>(p), static_cast<uint64_t>(f), f * c.frame_time(),
                                           c.frame(f + p), c.joints());
            if (st == Status::kOk) {
              ++t.ok;
              if (t.stopped) ++t.ok_after_stopped;
            } else if (st == Status::kQueueFull) {
              ++t.full;
            } else if (st == Status::kStopped) {
              if (++t.stopped >= 3) break;  // a few more after the first: refused every time
            } else {
              ++t.other;
            }
          }
        });
      go.store(true, std::memory_order_release);
      // Stop at a different moment each round: from before the first push to well into the flow.
      const int wait_us = (round * 37 + lane_index * 11) % 3000;
      std::this_thread::sleep_for(std::chrono::microseconds(wait_us));
      runtime.stop();
      for (auto& t : pushers) t.join();

      std::map<uint64_t, kata::test::StreamTally> accounts;
      for (int p = 0; p < kPushers; ++p) {
        const Tally& t = tallies[static_cast<size_t>(p)];
        const uint64_t id = static_cast<uint64_t>(p);
        const StreamCounters sc = runtime.stream_counters(id).value();
        accounts[id] = {t.ok + t.full + t.stopped, sunk[static_cast<size_t>(p)]};
        const bool ok = t.ok_after_stopped == 0 && t.other == 0 && sc.stopped == t.stopped &&
                        sc.queue_full == t.full && sc.frames_in == t.ok && sc.results + sc.refused == t.ok &&
                        sunk[static_cast<size_t>(p)] == t.ok;
        if (!ok) {
          failures.fetch_add(1);
          ADD_FAILURE() << "lane " << lane_index << " round " << round << " stream " << id << ": pushes kOk " << t.ok
                        << " (after kStopped " << t.ok_after_stopped << "), kState " << t.full << ", kStopped "
                        << t.stopped << ", other " << t.other << "; counted frames_in " << sc.frames_in
                        << ", results " << sc.results << ", refused " << sc.refused << ", stopped " << sc.stopped
                        << ", queue_full " << sc.queue_full << ", pipeline_dropped " << sc.pipeline_dropped
                        << ", result_queue_full " << sc.result_queue_full << "; the sink received " << sunk[static_cast<size_t>(p)];
        }
        taken_total.fetch_add(t.ok);
        refused_total.fetch_add(t.stopped);
      }
      if (!kata::test::every_frame_accounted(runtime, accounts, kata::test::Delivery::kSinks)) {
        failures.fetch_add(1);
        ADD_FAILURE() << "lane " << lane_index << " round " << round << ": "
                      << kata::test::every_frame_accounted(runtime, accounts, kata::test::Delivery::kSinks).message();
      }
    }
  };
  std::vector<std::thread> lanes;
  for (int l = 0; l < kLanes; ++l) lanes.emplace_back(lane, l);
  for (auto& l : lanes) l.join();
  EXPECT_EQ(failures.load(), 0);
  // Both outcomes happened (the test raced): frames taken and pushes refused.
  EXPECT_GT(taken_total.load(), 0u);
  EXPECT_GT(refused_total.load(), 0u);
}

}  // namespace
}  // namespace kata::runtime
