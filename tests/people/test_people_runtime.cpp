// The runtime's people path inside (runtime/people_streams.cpp): once a group's tracker and its
// persons' streams are open, a people frame allocates nothing, from the ingest through the
// tracker to each person's push.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

#include "runtime/runtime.hpp"
#include "support/alloc_counter.hpp"
#include "support/live_clip.hpp"
#include "transport/people_frame.hpp"

namespace kata::runtime {
namespace {

using Clock = std::chrono::steady_clock;

TEST(people_runtime_alloc, PeopleFramesAllocateNothingOnceThePeopleAreOpen) {
  if (!test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under a sanitizer";
  static const test::LiveClip clip("07_01");
  constexpr uint64_t kGroup = 900;
  constexpr int kPeople = 3;
  RuntimeConfig config;
  config.workers = 1;
  config.ingest.kind = transport::IngestKind::kDirect;
  config.ingest.limits.max_frame_age_ns = 0;
  Runtime runtime(config);
  transport::Encoder encoder;
  const transport::Bytes d = encoder.skeleton(clip.definition(kGroup));
  ASSERT_TRUE(runtime.offer(d.data, d.size));
  const int joints = clip.joints();
  std::vector<float> poses(static_cast<size_t>(kPeople) * joints * 3);
  std::vector<uint8_t> message;
  message.reserve(1 << 16);  // the test's own buffer, grown before the count
  uint64_t sequence = 0;
  // Three copies of the clip 2 m apart (units: the clip's, ~5.6 cm), in a rotating order.
  const auto send = [&](int frames) {
    for (int k = 0; k < frames; ++k, ++sequence) {
      for (int p = 0; p < kPeople; ++p) {
        const float* row = clip.frame(static_cast<int64_t>(sequence));
        float* out = poses.data() + static_cast<size_t>((p + sequence) % kPeople) * joints * 3;
        for (int j = 0; j < joints; ++j)
          for (int c = 0; c < 3; ++c) out[3 * j + c] = row[3 * j + c] + (c == 0 ? 36.0f * p : 0.0f);
      }
      transport::encode_people_frame(kGroup, sequence, static_cast<int64_t>((1.0 + sequence) * clip.frame_time() * 1e9),
                                     joints, kPeople, poses.data(), nullptr, &message);
      if (!runtime.offer(message.data(), message.size())) return false;
    }
    const uint64_t want = static_cast<uint64_t>(kPeople) * sequence;
    for (int tries = 0; tries < 4000 && runtime.counters().total.frames_in < want; ++tries)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return runtime.counters().total.frames_in == want;
  };
  ASSERT_TRUE(send(150));  // warm-up: the tracker, the persons' streams, their calibration (body height)
  ASSERT_EQ(runtime.counters().streams, 1u + kPeople);
  const long before = test::allocations();
  const bool done = send(100);
  const long allocated = test::allocations() - before;
  ASSERT_TRUE(done);
  EXPECT_EQ(allocated, 0) << "the people path allocated";
  runtime.stop();
  EXPECT_EQ(runtime.counters().ingest.people_frames, 250u);
  EXPECT_EQ(runtime.counters().ingest.people_poses, 250u * kPeople);
  for (int k = 1; k <= kPeople; ++k)
    EXPECT_TRUE(runtime.stream_counters(transport::person_stream_id(kGroup, static_cast<uint32_t>(k))).has_value());
}

}  // namespace
}  // namespace kata::runtime
