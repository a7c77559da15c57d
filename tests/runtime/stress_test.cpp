// Stress tests of the runtime's threads, written for ThreadSanitizer (./build.sh tsan runs them;
// the ordinary suite runs them too): many streams pushed from several threads while streams are
// opened and subscribers come and go, a runtime destroyed while frames arrive over ZeroMQ, and
// plugins loaded and unloaded around running runtimes. Besides "no data race", each asserts what
// a user relies on: nothing queued is lost, results arrive in order per stream. Counts and waits
// are bounded; endpoints are tcp://127.0.0.1:* (free ports) or ipc paths unique per process.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zmq.h>

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
#include "support/temp_paths.hpp"
#include "support/zmq_subscriber.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

using Clock = std::chrono::steady_clock;
using transport::SkeletonDefinition;

struct Clip {
  BvhClip clip = load_bvh(std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh");
  std::vector<float> positions = clip_positions(clip);
  int joints() const { return clip.skeleton.joint_count(); }
  int frames() const { return clip.frame_count(); }
  const float* frame(int i) const {
    return positions.data() + static_cast<size_t>(i % frames()) * 3 * static_cast<size_t>(joints());
  }
  SkeletonDefinition definition(uint64_t id) const {
    SkeletonDefinition d;
    d.stream_id = id;
    d.revision = 1;
    d.skeleton = clip.skeleton;
    d.preset = "cmu";
    return d;
  }
};

const Clip& clip() {
  static const Clip c;
  return c;
}

// 24 streams over 3 workers, pushed by 4 threads (6 streams each, in order per stream), while
// 8 more streams are opened from another thread, two threads connect and close subscribers
// (each join makes the I/O thread re-send definitions, walking the stream table that open_stream
// grows) and one thread reads counters. A persistent subscriber must see every result of every
// stream, in order.
TEST(runtime_stress, ManyStreamsSeveralPushersSubscribersComeAndGo) {
  const Clip& c = clip();
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
            if (runtime.push(id, static_cast<uint64_t>(f), f * c.clip.frame_time, c.frame(f + k), c.joints()) == Status::kOk)
              pushed.fetch_add(1);
          }
      });
    threads.emplace_back([&] {  // streams opened while others run
      for (int s = 0; s < kLate; ++s) {
        const uint64_t id = 1000 + static_cast<uint64_t>(s);
        runtime.open_stream(c.definition(id), setup_from_definition(c.definition(id)));
        for (int f = 0; f < 10; ++f)
          if (runtime.push(id, static_cast<uint64_t>(f), f * c.clip.frame_time, c.frame(f), c.joints()) == Status::kOk)
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
  const RuntimeCounters counters = runtime.counters();
  EXPECT_EQ(counters.streams, static_cast<uint64_t>(kStreams + kLate));
  EXPECT_EQ(counters.total.queue_full + counters.total.result_queue_full + counters.total.pipeline_dropped +
                counters.total.refused + counters.total.send_failed,
            0u);
}

// A source keeps sending definitions and frames over ZeroMQ while runtimes reading them are
// created and destroyed, three times; frames queued when stop begins are finished.
TEST(runtime_stress, RuntimeDestroyedWhileFramesArrive) {
  const Clip& c = clip();
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
    const int64_t dt = static_cast<int64_t>(c.clip.frame_time * 1e9);
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
    Sink sink;
    sink.on_result = [&](const transport::ResultFields&) { ++published_by_sink; };
    config.sinks.push_back(sink);
    auto runtime = std::make_unique<Runtime>(config);
    const auto limit = Clock::now() + std::chrono::seconds(30);
    while (runtime->counters().total.results < 40 && Clock::now() < limit)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    runtime->stop();
    const RuntimeCounters counters = runtime->counters();
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
      EXPECT_GE(results, 60u);
    }  // instances deactivated, plugins unloaded
    std::ifstream in(csv);
    std::string line;
    uint64_t rows = 0;
    std::getline(in, line);
    while (std::getline(in, line)) ++rows;
    EXPECT_EQ(rows, results) << "round " << round;
  }
}

}  // namespace
}  // namespace kata::runtime
