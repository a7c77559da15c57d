// A runtime (what `kata serve` runs) fed people frames (schemas/people_frame.fbs) through the
// public C ABI: a group stream defined as MediaPipe landmarks, then the class of scene.hpp as one
// message per image (poses shuffled, 5 % dropped, one person hidden at each crossing). Each
// person's poses must come out as results of their own stream, kata_people_stream_id(group, k),
// with k what a kata_people tracker with the same defaults gives the same frames; malformed
// messages and bad poses are counted and disturb nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <vector>

#include "kata/kata.h"
#include "people/scene.hpp"

namespace {

using kata::test::people::DetectedFrame;

struct Collected {
  std::mutex mutex;
  std::map<uint64_t, std::vector<double>> times;  // stream -> capture times of its results
};

void collect(void* user, const kata_result_record* r) {
  auto* c = static_cast<Collected*>(user);
  std::lock_guard<std::mutex> lock(c->mutex);
  c->times[r->stream_id].push_back(r->capture_time);
}

// The scene's frames in MediaPipe's camera axes ((x, y, z) -> (x, -y, -z): y down).
std::vector<DetectedFrame> class_frames(double seconds) {
  static const kata::test::people::Motion a{"02_01", 30.0}, b{"07_01", 30.0}, c{"02_02", 30.0};
  std::vector<kata::test::people::Actor> actors = {
      {"A", &a, [](double t, double* x, double* z, int* f) { *z = 0.0, *f = 1, *x = -2.0 + 0.8 * t; return true; }},
      {"B", &b, [](double t, double* x, double* z, int* f) { *z = 0.8, *f = -1, *x = 2.0 - 0.8 * t; return true; }},
      {"C", &c, [](double t, double* x, double* z, int* f) { *z = 2.5, *f = -1, *x = 3.0; return t > 1.0; }}};
  kata::test::people::SceneOptions o;
  o.seconds = seconds;
  std::vector<DetectedFrame> frames = kata::test::people::detect(actors, o);
  for (DetectedFrame& f : frames)
    for (size_t i = 0; i < f.xyz.size(); ++i)
      if (i % 3 != 0) f.xyz[i] = -f.xyz[i];
  return frames;
}

TEST(PeopleServe, EachPersonIsScoredOnTheirOwnStream) {
  constexpr uint64_t kGroup = 500;
  constexpr uint32_t J = kata::test::people::kLandmarks;
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_skeleton mp = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "mediapipe", &mp), KATA_OK);
  Collected got;
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.direct_ingest = 1;
  rd.max_frame_age_seconds = 0.0;  // the scene's capture times are not this host's clock
  rd.on_result = collect;
  rd.on_result_user = &got;
  kata_runtime runtime = nullptr;
  ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);

  std::vector<unsigned char> buffer(1 << 18);
  size_t size = 0;
  kata_skeleton_message sm;
  kata_skeleton_message_init(&sm);
  sm.stream_id = kGroup;
  sm.skeleton = mp;
  sm.layout = "mediapipe";
  ASSERT_EQ(kata_message_write_skeleton(&sm, buffer.data(), buffer.size(), &size), KATA_OK);
  ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);

  // The same frames through a tracker of the same defaults: the persons the runtime must find.
  kata_people_desc pd;
  kata_people_desc_init(&pd);
  pd.joint_count = J;
  pd.max_poses = KATA_MAX_PEOPLE_POSES;
  kata_people local = nullptr;
  ASSERT_EQ(kata_people_create(ctx, &pd, &local), KATA_OK);
  std::map<uint64_t, std::set<int64_t>> expected;  // person stream -> capture times (ns) of its poses
  std::vector<DetectedFrame> frames = class_frames(6.0);
  uint64_t sequence = 0;
  size_t nan_frame = frames.size() / 2;
  std::vector<uint32_t> ids(KATA_MAX_PEOPLE_POSES);
  for (size_t k = 0; k < frames.size(); ++k) {
    DetectedFrame& f = frames[k];
    uint32_t n = static_cast<uint32_t>(f.actor.size());
    if (k == nan_frame) {  // one more pose, with a NaN joint: refused by the tracker alone
      std::vector<float> bad(f.xyz.begin(), f.xyz.begin() + 3 * J);
      bad[7] = std::nanf("");
      f.xyz.insert(f.xyz.end(), bad.begin(), bad.end());
      f.confidence.insert(f.confidence.end(), J, 0.9f);
      ++n;
    }
    ASSERT_EQ(kata_people_track(local, f.time, f.xyz.data(), f.confidence.data(), n, ids.data(), ids.size()), KATA_OK);
    for (uint32_t i = 0; i < n; ++i)
      if (ids[i]) expected[kata_people_stream_id(kGroup, ids[i])].insert(std::llround(f.time * 1e9));
    if (k == nan_frame) {
      EXPECT_EQ(ids[n - 1], 0u);
    }
    kata_people_frame_message m;
    kata_people_frame_message_init(&m);
    m.stream_id = kGroup;
    m.sequence = sequence++;
    m.capture_time = f.time;
    m.joint_count = J;
    m.pose_count = n;
    m.positions = f.xyz.data();
    m.confidences = f.confidence.data();
    ASSERT_EQ(kata_message_write_people_frame(&m, buffer.data(), buffer.size(), &size), KATA_OK)
        << kata_context_last_error(ctx);
    ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
    if (k == 10) {
      // Malformed: a flipped byte (the checksum), a wrong joint count; both counted, nothing else changes.
      std::vector<unsigned char> flipped(buffer.begin(), buffer.begin() + static_cast<long>(size));
      flipped[size - 40] ^= 0x10;
      ASSERT_EQ(kata_runtime_offer(runtime, flipped.data(), flipped.size()), KATA_OK);
      kata_people_frame_message w = m;
      w.joint_count = J - 1;
      w.pose_count = 1;
      w.sequence = sequence++;
      w.capture_time = f.time + 1e-4;
      ASSERT_EQ(kata_message_write_people_frame(&w, buffer.data(), buffer.size(), &size), KATA_OK);
      ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
    }
  }
  // What the writer refuses.
  kata_people_frame_message m;
  kata_people_frame_message_init(&m);
  m.stream_id = kGroup;
  m.joint_count = J;
  m.pose_count = KATA_MAX_PEOPLE_POSES + 1;
  m.positions = frames[0].xyz.data();
  EXPECT_EQ(kata_message_write_people_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_INVALID_ARGUMENT);
  m.pose_count = 1;
  m.capture_time = std::nan("");
  EXPECT_EQ(kata_message_write_people_frame(&m, buffer.data(), buffer.size(), &size), KATA_E_NON_FINITE);

  ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);  // every offered message handled, every result sent
  ASSERT_EQ(expected.size(), 3u);
  std::lock_guard<std::mutex> lock(got.mutex);
  EXPECT_EQ(got.times.count(kGroup), 0u) << "the group stream scores nothing of a people frame";
  for (const auto& [stream, times] : got.times) {
    ASSERT_EQ(expected.count(stream), 1u) << "results on a stream no person has: " << stream;
    for (double t : times)
      EXPECT_EQ(expected[stream].count(std::llround(t * 1e9)), 1u) << "stream " << stream << " at " << t;
  }
  for (const auto& [stream, times] : expected) {
    ASSERT_EQ(got.times.count(stream), 1u) << "no result for person stream " << stream;
    // Every pose gives a result once the stream's body height is known (its first frames).
    EXPECT_GT(got.times[stream].size(), times.size() / 2) << stream;
  }
  kata_runtime_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_runtime_get_counters(runtime, &c), KATA_OK);
  EXPECT_EQ(c.ingest_frames, frames.size());  // the people frames, each a frame of the group
  EXPECT_EQ(c.ingest_wrong_joint_count, 1u);
  EXPECT_EQ(c.ingest_dropped, 2u);  // the checksum and the wrong joint count
  EXPECT_EQ(c.streams, 1u + 3u);
  kata_people_destroy(local);
  kata_runtime_destroy(runtime);
  kata_skeleton_destroy(mp);
  kata_context_destroy(ctx);
}

}  // namespace
