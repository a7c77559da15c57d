// The direct ingest: a NATS shard's delivery thread hands messages to
// Runtime::offer, a ring the I/O thread reads, instead of a private ipc socket. Here a thread of
// the test is that producer (no NATS needed: the bridge only forwards the bytes). The ring itself
// (wrap-around, full, order); a real stream beside hostile messages (each counted by cause, the
// stream keeping every result); and stop() racing the producer (every message offer() took is
// counted by the ingest, every other one was refused to the producer: none lost uncounted).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "transport/message_ring.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

using transport::SkeletonDefinition;
using Clock = std::chrono::steady_clock;

int64_t now_ns() { return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count(); }


// 07_01 from its first frame (T-pose included), wrapping round the clip.
const test::LiveClip& clip() {
  static const test::LiveClip c("07_01", 0);
  return c;
}

RuntimeConfig direct_config() {
  RuntimeConfig config;
  config.workers = 2;
  config.ingest.kind = transport::IngestKind::kDirect;
  return config;
}

TEST(transport_message_ring, KeepsOrderAcrossWrapsAndRefusesWhenFull) {
  transport::MessageRing ring(256);
  EXPECT_EQ(ring.capacity(), 256u);
  EXPECT_FALSE(ring.push("x", ring.max_message() + 1));  // larger than half: never
  std::vector<uint8_t> in(40);
  const uint8_t* data = nullptr;
  size_t size = 0;
  // Messages of varying sizes through many wraps, the consumer one behind.
  uint32_t next_in = 0, next_out = 0;
  for (int round = 0; round < 1000; ++round) {
    while (true) {
      const size_t n = 1 + (next_in * 7) % 37;
      std::memset(in.data(), static_cast<int>(next_in & 0xFF), n);
      if (!ring.push(in.data(), n)) break;  // full: nothing stored
      ++next_in;
    }
    ASSERT_TRUE(ring.front(&data, &size));
    ASSERT_EQ(size, 1 + (next_out * 7) % 37);
    for (size_t i = 0; i < size; ++i) ASSERT_EQ(data[i], next_out & 0xFF);
    ring.pop();
    ++next_out;
  }
  while (ring.front(&data, &size)) {
    ASSERT_EQ(size, 1 + (next_out * 7) % 37);
    ring.pop();
    ++next_out;
  }
  EXPECT_EQ(next_in, next_out);
  EXPECT_TRUE(ring.empty());
}

TEST(runtime_direct_ingest, HostileMessagesAreCountedByCauseAndTheRealStreamKeepsEveryResult) {
  constexpr uint64_t kReal = 7;
  constexpr int kFrames = 120;
  std::mutex mutex;
  std::multiset<uint64_t> results;  // frame sequences of kReal's results
  RuntimeConfig config = direct_config();
  Sink sink;
  sink.on_result = [&](const transport::ResultFields& f) {
    std::lock_guard<std::mutex> lock(mutex);
    if (f.stream_id == kReal) results.insert(f.frame_sequence);
  };
  config.sinks.push_back(sink);
  Runtime runtime(config);
  EXPECT_EQ(runtime.ingest_endpoint(), "direct");  // no socket: nothing bound, no socket directory

  uint64_t offered = 0;
  transport::Encoder encoder;
  auto offer = [&](transport::Bytes b) {
    ASSERT_TRUE(runtime.offer(b.data, b.size));
    ++offered;
  };
  // The producer is one thread (as libnats' delivery thread), not the test's.
  std::thread producer([&] {
    offer(encoder.skeleton(clip().definition(kReal)));
    const int64_t base = now_ns();
    const char garbage[] = "0000000000000007 not a flatbuffer at all, but long enough to look at";
    for (int i = 0; i < kFrames; ++i) {
      const int64_t capture = base + static_cast<int64_t>(i) * 8'333'333;
      offer(encoder.frame(kReal, static_cast<uint64_t>(i), capture, clip().frame(1 + i), clip().joints()));
      if (i % 30 == 10) {  // hostile, between the real frames
        ASSERT_TRUE(runtime.offer(garbage, sizeof garbage));  // malformed
        ++offered;
        const transport::Bytes f = encoder.frame(kReal, 100000, capture, clip().frame(1), clip().joints());
        ASSERT_TRUE(runtime.offer(f.data, f.size / 2));  // a truncated frame claiming the stream
        ++offered;
        ASSERT_TRUE(runtime.offer(garbage, 3));  // shorter than a topic
        ++offered;
      }
    }
    // A frame of a stream never defined, and one of the real stream with too few joints.
    offer(encoder.frame(99, 0, now_ns(), clip().frame(1), clip().joints()));
    offer(encoder.frame(kReal, kFrames, base + kFrames * 8'333'333LL, clip().frame(1), clip().joints() - 1));
  });
  producer.join();

  const auto end = Clock::now() + std::chrono::seconds(20);
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (results.size() >= static_cast<size_t>(kFrames) || Clock::now() > end) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  runtime.stop();
  std::multiset<uint64_t> want;
  for (uint64_t i = 0; i < kFrames; ++i) want.insert(i);
  {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(results, want);  // every frame once, nothing forged
  }
  const RuntimeCounters c = runtime.counters();
  const transport::IngestCounters& in = c.ingest;
  EXPECT_EQ(in.received, offered);
  EXPECT_EQ(in.frames, static_cast<uint64_t>(kFrames));
  EXPECT_EQ(in.skeletons, 1u);
  EXPECT_EQ(in.malformed_total(), 12u);  // 4 x (garbage, truncated, too short)
  EXPECT_EQ(in.malformed[static_cast<int>(transport::DecodeError::kTooShort)], 4u);
  EXPECT_EQ(in.unknown_stream, 1u);
  EXPECT_EQ(in.wrong_joint_count, 1u);
  EXPECT_EQ(in.frames + in.skeletons + in.repeated_skeletons + in.closes + in.other_shard + in.dropped_total(),
            in.received);
  const auto s = runtime.stream_counters(kReal);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->frames_in, static_cast<uint64_t>(kFrames));
  EXPECT_EQ(s->wrong_joints, 1u);  // counted on the stream too
}

TEST(runtime_direct_ingest, StopRacingTheProducerLosesNoMessageUncounted) {
  Runtime runtime(direct_config());
  transport::Encoder encoder;
  const transport::Bytes definition = encoder.skeleton(clip().definition(3));
  ASSERT_TRUE(runtime.offer(definition.data, definition.size));
  std::atomic<bool> go{false};
  std::atomic<uint64_t> taken{1}, refused{0};
  std::thread producer([&] {
    transport::Encoder own;
    const int64_t base = now_ns();
    go.store(true);
    for (uint64_t i = 0; refused.load(std::memory_order_relaxed) < 100; ++i) {
      const transport::Bytes f =
          own.frame(3, i, base + static_cast<int64_t>(i) * 1'000'000, clip().frame(1 + static_cast<int>(i)), clip().joints());
      (runtime.offer(f.data, f.size) ? taken : refused).fetch_add(1, std::memory_order_relaxed);
      if (i % 64 == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  });
  while (!go.load()) std::this_thread::yield();
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  runtime.stop();
  producer.join();  // it ends after 100 refusals: stop() refuses from its start
  const RuntimeCounters c = runtime.counters();
  EXPECT_EQ(c.ingest.received, taken.load());  // every message taken was judged before stop returned
  EXPECT_GT(c.ingest.frames, 0u);
  EXPECT_EQ(c.ingest.frames + c.ingest.skeletons + c.ingest.dropped_total(), c.ingest.received);
}

}  // namespace
}  // namespace kata::runtime
