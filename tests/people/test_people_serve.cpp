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

// What one runtime gave: every result's capture time per stream (in order), each stream's
// counters and the runtime's, after the stop.
struct Served {
  std::map<uint64_t, std::vector<double>> times;
  std::map<uint64_t, kata_stream_counters> streams;
  kata_runtime_counters counters{};
};

constexpr uint64_t kGoodGroup = 510;
constexpr uint64_t kSingle = 511;  // the good sender's one-person stream (frame messages)
constexpr uint64_t kBadGroup = 512;

void offer_skeleton(kata_runtime runtime, kata_skeleton mp, uint64_t id, int32_t closed, std::vector<unsigned char>& buffer) {
  kata_skeleton_message sm;
  kata_skeleton_message_init(&sm);
  sm.stream_id = id;
  sm.skeleton = mp;
  sm.layout = "mediapipe";
  sm.closed = closed;
  size_t size = 0;
  ASSERT_EQ(kata_message_write_skeleton(&sm, buffer.data(), buffer.size(), &size), KATA_OK);
  ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
}

void offer_people(kata_runtime runtime, uint64_t group, uint64_t sequence, double time, const float* xyz,
                  const float* confidence, uint32_t poses, std::vector<unsigned char>& buffer) {
  kata_people_frame_message m;
  kata_people_frame_message_init(&m);
  m.stream_id = group;
  m.sequence = sequence;
  m.capture_time = time;
  m.joint_count = kata::test::people::kLandmarks;
  m.pose_count = poses;
  m.positions = xyz;
  m.confidences = confidence;
  size_t size = 0;
  ASSERT_EQ(kata_message_write_people_frame(&m, buffer.data(), buffer.size(), &size), KATA_OK);
  ASSERT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
}

// One bad group's people frame: its poses (back to back) and its capture time.
struct BadFrame {
  double time;
  std::vector<float> xyz;
};

// A good sender (the class as people frames of kGoodGroup, its first pose of each image as frame
// messages of kSingle) and, interleaved, the bad frames of kBadGroup (closed after its last frame).
Served serve(kata_context ctx, kata_skeleton mp, const std::vector<DetectedFrame>& frames,
             const std::vector<BadFrame>& bad) {
  constexpr uint32_t J = kata::test::people::kLandmarks;
  Served out;
  Collected got;
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.direct_ingest = 1;
  rd.max_frame_age_seconds = 0.0;  // the scene's capture times are not this host's clock
  rd.on_result = collect;
  rd.on_result_user = &got;
  kata_runtime runtime = nullptr;
  EXPECT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
  if (!runtime) return out;
  std::vector<unsigned char> buffer(1 << 18);
  offer_skeleton(runtime, mp, kGoodGroup, 0, buffer);
  offer_skeleton(runtime, mp, kSingle, 0, buffer);
  if (!bad.empty()) offer_skeleton(runtime, mp, kBadGroup, 0, buffer);
  uint64_t single_sequence = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const DetectedFrame& f = frames[k];
    const uint32_t n = static_cast<uint32_t>(f.actor.size());
    offer_people(runtime, kGoodGroup, k, f.time, f.xyz.data(), f.confidence.data(), n, buffer);
    if (n > 0) {
      kata_frame_message fm;
      kata_frame_message_init(&fm);
      fm.stream_id = kSingle;
      fm.sequence = single_sequence++;
      fm.capture_time = f.time;
      fm.joint_count = J;
      fm.positions = f.xyz.data();
      fm.confidences = f.confidence.data();
      size_t size = 0;
      EXPECT_EQ(kata_message_write_frame(&fm, buffer.data(), buffer.size(), &size), KATA_OK);
      EXPECT_EQ(kata_runtime_offer(runtime, buffer.data(), size), KATA_OK);
    }
    if (k < bad.size()) {
      const BadFrame& b = bad[k];
      offer_people(runtime, kBadGroup, k, b.time, b.xyz.empty() ? nullptr : b.xyz.data(), nullptr,
                   static_cast<uint32_t>(b.xyz.size() / (3 * J)), buffer);
      if (k + 1 == bad.size()) offer_skeleton(runtime, mp, kBadGroup, 1, buffer);  // the group ends: its persons too
    }
  }
  EXPECT_EQ(kata_runtime_stop(runtime), KATA_OK);  // every offered message handled, every result sent
  out.counters.struct_size = sizeof out.counters;
  EXPECT_EQ(kata_runtime_get_counters(runtime, &out.counters), KATA_OK);
  uint32_t count = 0;
  kata_runtime_get_stream_counters(runtime, nullptr, 0, &count);
  std::vector<kata_stream_counters> streams(count);
  if (count > 0) {
    streams[0].struct_size = sizeof streams[0];
    EXPECT_EQ(kata_runtime_get_stream_counters(runtime, streams.data(), count, &count), KATA_OK);
  }
  for (const kata_stream_counters& c : streams) out.streams[c.stream_id] = c;
  kata_runtime_destroy(runtime);
  std::lock_guard<std::mutex> lock(got.mutex);
  out.times = got.times;
  return out;
}

// A people frame with more poses than the tracker's table, one with a NaN pose, one with a pose
// out of range and one with every joint on one point, an empty one and one not after the previous:
// each counted by its cause in kata_runtime_counters, while a good sender's group and stream, in
// the same runtime, give exactly the results they give alone.
TEST(PeopleServe, RefusedPeopleAreCountedByCauseAndDisturbNothing) {
  constexpr uint32_t J = kata::test::people::kLandmarks;
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_skeleton mp = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "mediapipe", &mp), KATA_OK);
  const std::vector<DetectedFrame> frames = class_frames(4.0);
  ASSERT_FALSE(frames[0].actor.empty());

  // The bad group: person i is the first pose of the class's first image, 3 m apart along x.
  const std::vector<float> pose(frames[0].xyz.begin(), frames[0].xyz.begin() + 3 * J);
  auto person = [&](int i, int k, std::vector<float>* to) {
    for (uint32_t j = 0; j < J; ++j)
      for (int a = 0; a < 3; ++a) to->push_back(pose[3 * j + a] + (a == 0 ? 3.0f * static_cast<float>(i) + 0.01f * static_cast<float>(k) : 0.0f));
  };
  const int kMaxPeople = 8;  // kata_people_desc_init's max_people: a runtime's group tracker's
  std::vector<BadFrame> bad;
  for (int k = 0; k < 10; ++k) {
    BadFrame b{10.0 + k / 30.0, {}};
    if (k != 3)
      for (int i = 0; i < kMaxPeople; ++i) person(i, k, &b.xyz);
    if (k == 1) {  // two more people than the table holds
      person(kMaxPeople, k, &b.xyz);
      person(kMaxPeople + 1, k, &b.xyz);
    }
    if (k == 2) {  // a pose with a NaN joint
      person(0, k, &b.xyz);
      b.xyz[b.xyz.size() - 3 * J + 7] = std::nanf("");
    }
    if (k == 4) {  // a pose with a joint beyond KATA_MAX_COORDINATE, one with every joint on one point
      person(0, k, &b.xyz);
      b.xyz[b.xyz.size() - 3 * J + 3] = 2e9f;
      b.xyz.insert(b.xyz.end(), 3 * J, 0.5f);
    }
    if (k == 5) b.time = bad[4].time;  // not after the previous frame: the tracker refuses the frame
    bad.push_back(std::move(b));
  }
  // What was sent wrong, by cause; the rest of its poses are tracked.
  // Poses in tracked frames: 8, 10, 9, 0 (empty), 10, then 8 in each of the last four (the 8 of the
  // refused frame are not looked at); 8 of each tracked frame but the empty one are tracked.
  const uint64_t bad_frames = 10, bad_poses = 8 + 10 + 9 + 0 + 10 + 4 * 8, bad_tracked = 8 * 8;

  // The good group's frames through a local tracker of the runtime's defaults: its share of the counts.
  kata_people_desc pd;
  kata_people_desc_init(&pd);
  pd.joint_count = J;
  pd.max_poses = KATA_MAX_PEOPLE_POSES;
  kata_people local = nullptr;
  ASSERT_EQ(kata_people_create(ctx, &pd, &local), KATA_OK);
  std::vector<uint32_t> ids(KATA_MAX_PEOPLE_POSES);
  std::set<uint64_t> good_streams = {kSingle};
  for (const DetectedFrame& f : frames) {
    const uint32_t n = static_cast<uint32_t>(f.actor.size());
    ASSERT_EQ(kata_people_track(local, f.time, f.xyz.data(), f.confidence.data(), n, ids.data(), ids.size()), KATA_OK);
    for (uint32_t i = 0; i < n; ++i)
      if (ids[i]) good_streams.insert(kata_people_stream_id(kGoodGroup, ids[i]));
  }
  kata_people_counters g;
  g.struct_size = sizeof g;
  ASSERT_EQ(kata_people_get_counters(local, &g), KATA_OK);
  kata_people_destroy(local);
  ASSERT_EQ(good_streams.size(), 1u + 3u);
  ASSERT_EQ(g.poses, g.assigned) << "the class alone has no pose to refuse";

  const Served alone = serve(ctx, mp, frames, {});
  const Served mixed = serve(ctx, mp, frames, bad);

  const kata_runtime_counters& c = mixed.counters;
  EXPECT_EQ(c.people_frames, frames.size() + bad_frames - 1);
  EXPECT_EQ(c.people_refused_frames, 1u);
  EXPECT_EQ(c.people_empty_frames, g.empty_frames + 1);
  EXPECT_EQ(c.people_poses, g.poses + bad_poses);
  EXPECT_EQ(c.people_poses_tracked, g.assigned + bad_tracked);
  EXPECT_EQ(c.people_refused_table_full, 2u);
  EXPECT_EQ(c.people_refused_non_finite, 1u);
  EXPECT_EQ(c.people_refused_out_of_range, 1u);
  EXPECT_EQ(c.people_refused_few_joints, 1u);
  EXPECT_EQ(c.people_refused_too_many_poses, 0u);
  EXPECT_EQ(c.people_poses, c.people_poses_tracked + c.people_refused_non_finite + c.people_refused_out_of_range +
                                c.people_refused_few_joints + c.people_refused_too_many_poses +
                                c.people_refused_table_full);
  EXPECT_EQ(c.people_streams_opened, g.opened + kMaxPeople);
  EXPECT_EQ(c.people_streams_closed, g.closed + kMaxPeople);  // the bad group's persons closed with it
  EXPECT_EQ(c.people_streams_refused, 0u);
  EXPECT_EQ(c.people_poses_unopened, 0u);
  // Every tracked pose became a frame of its person's stream; nothing was malformed.
  EXPECT_EQ(c.frames_in, alone.counters.frames_in + bad_tracked);
  EXPECT_EQ(c.ingest_dropped, 0u);
  EXPECT_EQ(alone.counters.ingest_dropped, 0u);
  EXPECT_EQ(c.ingest_frames, alone.counters.ingest_frames + bad_frames);
  // Alone: the good group's share only.
  EXPECT_EQ(alone.counters.people_frames, frames.size());
  EXPECT_EQ(alone.counters.people_poses_tracked, g.assigned);
  EXPECT_EQ(alone.counters.people_streams_opened, g.opened);
  EXPECT_EQ(alone.counters.people_refused_frames + alone.counters.people_refused_table_full +
                alone.counters.people_refused_non_finite,
            0u);

  // The good sender's streams: the same results, in the same order, and the same counts.
  for (uint64_t id : good_streams) {
    ASSERT_EQ(alone.times.count(id), 1u) << "no result on good stream " << id;
    EXPECT_GT(alone.times.at(id).size(), 30u) << id;
    EXPECT_EQ(mixed.times.count(id) ? mixed.times.at(id) : std::vector<double>(), alone.times.at(id)) << id;
    // A person the tracker forgot: their stream's state may have gone to a later stream.
    if (alone.streams.count(id) == 0 || mixed.streams.count(id) == 0) continue;
    const kata_stream_counters &a = alone.streams.at(id), &m = mixed.streams.at(id);
    EXPECT_EQ(m.frames_in, a.frames_in) << id;
    EXPECT_EQ(m.results, a.results) << id;
    EXPECT_EQ(m.published, a.published) << id;
  }
  // Nothing but the good streams and the bad group's persons has results.
  for (const auto& [id, times] : mixed.times) {
    bool known = good_streams.count(id) > 0;
    for (uint32_t k = 1; k <= static_cast<uint32_t>(kMaxPeople); ++k) known = known || id == kata_people_stream_id(kBadGroup, k);
    EXPECT_TRUE(known) << "results on stream " << id;
  }
  kata_skeleton_destroy(mp);
  kata_context_destroy(ctx);
}

}  // namespace
