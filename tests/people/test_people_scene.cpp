// The people tracker (kata/people.h) through the public C ABI on a class made from real CMU clips
// (scene.hpp): two people walking past each other, one hidden behind the other for 0.5-1 s, a
// third who leaves and comes back within the forget time, a stranger entering meanwhile, the
// poses shuffled every frame and 5 % of them dropped. Each person's "own stream" is the id the
// tracker gave their first pose; every later pose of theirs must carry it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <vector>

#include "kata/kata.h"
#include "people/scene.hpp"
#include "support/alloc_counter.hpp"

namespace {

using kata::test::people::Actor;
using kata::test::people::DetectedFrame;
using kata::test::people::Motion;
using kata::test::people::SceneOptions;

// A to-and-fro walk along x between from and to at `speed` m/s, starting at t0, turning at the ends.
bool shuttle(double t, double from, double to, double speed, double* x, int* facing) {
  const double length = std::fabs(to - from), leg = length / speed;
  const double phase = std::fmod(t, 2.0 * leg);
  const double dir = to > from ? 1.0 : -1.0;
  if (phase < leg) {
    *x = from + dir * speed * phase, *facing = static_cast<int>(dir);
  } else {
    *x = to - dir * speed * (phase - leg), *facing = -static_cast<int>(dir);
  }
  return true;
}

constexpr double kView = 4.0;  // the camera sees |x| < 4 m

struct Class {
  Motion a{"02_01", 30.0}, b{"07_01", 30.0}, c{"02_02", 30.0}, d{"05_02", 30.0};
  std::vector<Actor> actors() const {
    std::vector<Actor> out;
    // A, in front, and B, 0.8 m behind, walk past each other at x = 0 (t = 3.75 s, 11.25 s).
    out.push_back({"A 02_01", &a, [](double t, double* x, double* z, int* f) {
                     *z = 0.0;
                     return shuttle(t, -3.0, 3.0, 0.8, x, f);
                   }});
    out.push_back({"B 07_01", &b, [](double t, double* x, double* z, int* f) {
                     *z = 0.8;
                     return shuttle(t, 3.0, -3.0, 0.8, x, f);
                   }});
    // C walks in from the right (t = 3.25 s), back out (gone 6.75-8.25 s), in again, then stays.
    out.push_back({"C 02_02", &c, [](double t, double* x, double* z, int* f) {
                     *z = 2.5;
                     if (t < 2.0) return false;
                     if (t < 5.0) *x = 5.0 - 0.8 * (t - 2.0), *f = -1;
                     else if (t < 7.5) *x = 2.6 + 0.8 * (t - 5.0), *f = 1;
                     else *x = std::max(2.6, 4.6 - 0.8 * (t - 7.5)), *f = -1;
                     return std::fabs(*x) < kView;
                   }});
    // D, a stranger, enters from the left while C is away (t = 8.25 s) and stays.
    out.push_back({"D 05_02", &d, [](double t, double* x, double* z, int* f) {
                     *z = 2.5, *f = 1;
                     if (t < 7.0) return false;
                     *x = std::min(-2.6, -5.0 + 0.8 * (t - 7.0));
                     return std::fabs(*x) < kView;
                   }});
    return out;
  }
};

const Class& the_class() {
  static const Class c;
  return c;
}

struct Outcome {
  int poses = 0, kept = 0;                 // poses given, poses on their person's own stream
  int after_crossing = 0, swapped = 0;     // poses of A and B after a crossing, on another's stream
  int longest_hidden = 0, shortest_hidden = 1 << 30;  // frames B stayed hidden at a crossing
  std::map<int, uint32_t> own;             // actor -> own stream
  std::map<int, std::set<uint32_t>> ids;   // actor -> every id it got
};

Outcome run(const SceneOptions& options, kata_people_desc* desc_out = nullptr) {
  const std::vector<Actor> actors = the_class().actors();
  const std::vector<DetectedFrame> frames = kata::test::people::detect(actors, options);
  kata_context ctx = nullptr;
  EXPECT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_people_desc d;
  kata_people_desc_init(&d);
  d.joint_count = kata::test::people::kLandmarks;
  if (desc_out) *desc_out = d;
  kata_people p = nullptr;
  EXPECT_EQ(kata_people_create(ctx, &d, &p), KATA_OK) << kata_context_last_error(ctx);
  Outcome o;
  std::vector<uint32_t> ids(16);
  int hidden_run = 0;
  bool crossed = false;
  for (const DetectedFrame& f : frames) {
    const uint32_t n = static_cast<uint32_t>(f.actor.size());
    EXPECT_EQ(kata_people_track(p, f.time, f.xyz.data(), f.confidence.data(), n, ids.data(), ids.size()), KATA_OK)
        << kata_people_last_error(p);
    const bool b_hidden = std::find(f.hidden.begin(), f.hidden.end(), 1) != f.hidden.end();
    if (b_hidden) {
      ++hidden_run;
    } else if (hidden_run > 0) {
      o.longest_hidden = std::max(o.longest_hidden, hidden_run);
      o.shortest_hidden = std::min(o.shortest_hidden, hidden_run);
      hidden_run = 0;
      crossed = true;
    }
    for (uint32_t i = 0; i < n; ++i) {
      const int a = f.actor[i];
      EXPECT_NE(ids[i], 0u) << "a valid pose refused at t=" << f.time;
      if (!o.own.count(a)) o.own[a] = ids[i];
      o.ids[a].insert(ids[i]);
      ++o.poses;
      const bool on_own = ids[i] == o.own[a];
      o.kept += on_own ? 1 : 0;
      if (crossed && a <= 1) {
        ++o.after_crossing;
        o.swapped += on_own ? 0 : 1;
      }
    }
  }
  kata_people_destroy(p);
  kata_context_destroy(ctx);
  return o;
}

void expect_identity(const SceneOptions& options, const char* what) {
  const Outcome o = run(options);
  const double kept = 100.0 * o.kept / o.poses;
  std::printf("[ figures  ] %s seed %u: identity kept on %d of %d poses (%.2f %%), %d poses of A and B after a "
              "crossing, %d on another's stream; B hidden %d-%d frames at a crossing\n",
              what, options.seed, o.kept, o.poses, kept, o.after_crossing, o.swapped, o.shortest_hidden,
              o.longest_hidden);
  // The scene is what the issue asks for: B hidden 0.5-1 s at each crossing (30 Hz).
  EXPECT_GE(o.shortest_hidden, 15);
  EXPECT_LE(o.longest_hidden, 30);
  EXPECT_GE(kept, 99.0) << what;
  EXPECT_EQ(o.swapped, 0) << what << ": a swap after a crossing";
  ASSERT_EQ(o.own.size(), 4u);
  // Four people, four streams: C back on their own stream after leaving, D's stream new.
  std::set<uint32_t> owns;
  for (const auto& [a, id] : o.own) owns.insert(id);
  EXPECT_EQ(owns.size(), 4u) << what << ": two people share a stream";
  EXPECT_EQ(o.ids.at(2), std::set<uint32_t>{o.own.at(2)}) << what << ": C did not come back to their stream";
  EXPECT_EQ(o.ids.at(3), std::set<uint32_t>{o.own.at(3)}) << what << ": the stranger took another stream";
}

TEST(PeopleScene, IdentityKeptInThreeDimensions) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    SceneOptions o;
    o.seed = seed;
    expect_identity(o, "3D world landmarks");
  }
}

TEST(PeopleScene, IdentityKeptOnFlatKeypoints) {
  // z = 0 everywhere (an image's 2D keypoints): B passes right over A's place.
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    SceneOptions o;
    o.seed = seed;
    o.flat = true;
    expect_identity(o, "2D keypoints");
  }
}

TEST(PeopleScene, IdentityKeptWithASecondHiddenAFifthDroppedAndMoreJitter) {
  // Harder than the issue asks: B hidden ~1 s (29 frames) at each crossing, 20 % of poses
  // dropped, 3 cm of jitter per landmark, in 3D and in 2D.
  for (bool flat : {false, true}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SceneOptions o;
      o.seed = seed;
      o.flat = flat;
      o.drop = 0.2;
      o.noise = 0.03;
      o.occlusion_width = 0.78;
      expect_identity(o, flat ? "2D keypoints, harder" : "3D world landmarks, harder");
    }
  }
}

// Someone away for longer than forget_seconds comes back as a new person; their old stream is
// reported closed exactly once, when the forget time has passed.
TEST(PeopleScene, AwayLongerThanTheForgetTimeIsANewStream) {
  const Motion& m = the_class().a;
  std::vector<Actor> actors = {{"A", &m, [](double t, double* x, double* z, int* f) {
                                  *z = 0.0, *f = 1, *x = -1.0 + 0.3 * t;
                                  return t < 2.0 || t > 6.0;  // away 4 s
                                }}};
  SceneOptions options;
  options.seconds = 8.0;
  options.drop = 0.0;
  const std::vector<DetectedFrame> frames = kata::test::people::detect(actors, options);
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_people_desc d;
  kata_people_desc_init(&d);
  d.joint_count = kata::test::people::kLandmarks;
  EXPECT_EQ(d.forget_seconds, 3.0);
  kata_people p = nullptr;
  ASSERT_EQ(kata_people_create(ctx, &d, &p), KATA_OK);
  std::set<uint32_t> seen;
  std::vector<double> closed_at;
  uint32_t id = 0, closed[8], count = 0;
  for (const DetectedFrame& f : frames) {
    const uint32_t n = static_cast<uint32_t>(f.actor.size());
    ASSERT_EQ(kata_people_track(p, f.time, f.xyz.data(), f.confidence.data(), n, &id, 1), KATA_OK);
    if (n) seen.insert(id);
    ASSERT_EQ(kata_people_closed(p, closed, 8, &count), KATA_OK);
    if (count) closed_at.push_back(f.time - 100.0);
  }
  EXPECT_EQ(seen.size(), 2u);
  ASSERT_EQ(closed_at.size(), 1u);
  EXPECT_GT(closed_at[0], 2.0 + 3.0 - 0.05);
  EXPECT_LT(closed_at[0], 2.0 + 3.0 + 0.1);
  kata_people_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_people_get_counters(p, &c), KATA_OK);
  EXPECT_EQ(c.opened, 2u);
  EXPECT_EQ(c.closed, 1u);
  EXPECT_EQ(c.open_streams, 1u);
  kata_people_destroy(p);
  kata_context_destroy(ctx);
}

// Bad input: more poses than max_poses, a pose with a NaN, an empty frame, a time going back:
// refused and counted, the good poses of the same frame tracked as before.
TEST(PeopleCapi, BadInputIsCountedAndDisturbsNothing) {
  const Class& cls = the_class();
  const Motion* motions[4] = {&cls.a, &cls.b, &cls.c, &cls.d};
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_people_desc d;
  kata_people_desc_init(&d);
  d.joint_count = kata::test::people::kLandmarks;
  d.max_poses = 4;
  kata_people p = nullptr;
  ASSERT_EQ(kata_people_create(ctx, &d, &p), KATA_OK);
  constexpr int J = kata::test::people::kLandmarks;
  std::vector<float> xyz, conf;
  uint32_t ids[8], first[4] = {0, 0, 0, 0};
  const auto frame = [&](double t, int extra_nan, int extra_faint) {
    xyz.clear(), conf.clear();
    for (int a = 0; a < 4; ++a) {
      const auto l = motions[a]->at(t, -3.0 + 2.0 * a, 0.0, 1);
      xyz.insert(xyz.end(), l.begin(), l.end());
      conf.insert(conf.end(), J, 0.9f);
    }
    for (int e = 0; e < extra_nan; ++e) {  // a copy of person 0 with a NaN joint
      auto l = motions[0]->at(t, -3.0, 0.0, 1);
      l[10] = std::nanf("");
      xyz.insert(xyz.end(), l.begin(), l.end());
      conf.insert(conf.end(), J, 0.9f);
    }
    for (int e = 0; e < extra_faint; ++e) {  // a faint fifth pose far away: valid but least confident
      const auto l = motions[1]->at(t, 9.0, 5.0, 1);
      xyz.insert(xyz.end(), l.begin(), l.end());
      conf.insert(conf.end(), J, 0.5f);
    }
  };
  double t = 0.0;
  for (int k = 0; k < 10; ++k, t += 1.0 / 30) {
    frame(t, 0, 0);
    ASSERT_EQ(kata_people_track(p, t, xyz.data(), conf.data(), 4, ids, 8), KATA_OK);
    for (int a = 0; a < 4; ++a) {
      if (k == 0) first[a] = ids[a];
      EXPECT_EQ(ids[a], first[a]);
    }
  }
  // A NaN pose and a fifth pose beyond max_poses (4): both refused, the four tracked as before.
  frame(t, 1, 1);
  ASSERT_EQ(kata_people_track(p, t, xyz.data(), conf.data(), 6, ids, 8), KATA_OK);
  for (int a = 0; a < 4; ++a) EXPECT_EQ(ids[a], first[a]);
  EXPECT_EQ(ids[4], 0u);
  EXPECT_EQ(ids[5], 0u);
  // A joint below min_confidence may be anything, even NaN.
  frame(t += 1.0 / 30, 0, 0);
  conf[5] = 0.0f;
  xyz[15] = std::nanf("");
  ASSERT_EQ(kata_people_track(p, t, xyz.data(), conf.data(), 4, ids, 8), KATA_OK);
  EXPECT_EQ(ids[0], first[0]);
  // An empty frame; then times that are not after the last: refused, nothing changed.
  ASSERT_EQ(kata_people_track(p, t += 1.0 / 30, nullptr, nullptr, 0, nullptr, 0), KATA_OK);
  EXPECT_EQ(kata_people_track(p, t, xyz.data(), conf.data(), 4, ids, 8), KATA_E_TIMESTAMP_NOT_INCREASING);
  EXPECT_EQ(kata_people_track(p, std::nan(""), xyz.data(), conf.data(), 4, ids, 8), KATA_E_NON_FINITE);
  EXPECT_EQ(kata_people_track(p, t + 1, xyz.data(), conf.data(), 4, ids, 3), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(kata_people_track(p, t + 1, nullptr, conf.data(), 4, ids, 8), KATA_E_NULL_POINTER);
  frame(t += 1.0 / 30, 0, 0);
  ASSERT_EQ(kata_people_track(p, t, xyz.data(), conf.data(), 4, ids, 8), KATA_OK);
  for (int a = 0; a < 4; ++a) EXPECT_EQ(ids[a], first[a]);

  kata_people_counters c;
  c.struct_size = sizeof c;
  ASSERT_EQ(kata_people_get_counters(p, &c), KATA_OK);
  EXPECT_EQ(c.frames, 14u);
  EXPECT_EQ(c.empty_frames, 1u);
  EXPECT_EQ(c.refused_frames, 2u);  // the buffer and NULL refusals never reach the tracker
  EXPECT_EQ(c.poses, 4u * 13 + 2);
  EXPECT_EQ(c.assigned, 4u * 13);
  EXPECT_EQ(c.refused_non_finite, 1u);
  EXPECT_EQ(c.refused_too_many_poses, 1u);
  EXPECT_EQ(c.opened, 4u);
  EXPECT_EQ(c.open_streams, 4u);
  uint32_t open[8], count = 0;
  ASSERT_EQ(kata_people_streams(p, open, 8, &count), KATA_OK);
  EXPECT_EQ(count, 4u);
  EXPECT_EQ(kata_people_streams(p, open, 2, &count), KATA_E_BUFFER_TOO_SMALL);
  double centroid[3];
  EXPECT_EQ(kata_people_predicted(p, first[2], t, centroid), KATA_OK);
  EXPECT_NEAR(centroid[0], 1.0, 0.2);  // person 2 stands at x = 1
  EXPECT_EQ(kata_people_predicted(p, 999, t, centroid), KATA_E_NOT_FOUND);
  kata_people_destroy(p);

  // The table is bounded: a fifth person while max_people streams are open is refused.
  d.max_people = 3;
  ASSERT_EQ(kata_people_create(ctx, &d, &p), KATA_OK);
  frame(0.0, 0, 0);
  ASSERT_EQ(kata_people_track(p, 0.0, xyz.data(), conf.data(), 4, ids, 8), KATA_OK);
  EXPECT_EQ(std::count(ids, ids + 4, 0u), 1);
  ASSERT_EQ(kata_people_get_counters(p, &c), KATA_OK);
  EXPECT_EQ(c.refused_table_full, 1u);
  kata_people_destroy(p);

  // A desc without joint_count, or out of range: refused with a message.
  kata_people_desc_init(&d);
  EXPECT_EQ(kata_people_create(ctx, &d, &p), KATA_E_INVALID_ARGUMENT);
  d.joint_count = 33;
  d.max_people = 65;
  EXPECT_EQ(kata_people_create(ctx, &d, &p), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("max_people"), std::string::npos);
  d.max_people = 8;
  d.gate = std::nan("");
  EXPECT_EQ(kata_people_create(ctx, &d, &p), KATA_E_INVALID_ARGUMENT);
  kata_context_destroy(ctx);
}

TEST(PeopleCapi, TrackingAllocatesNothing) {
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "a sanitizer owns malloc";
  SceneOptions options;
  options.seconds = 5.0;
  const std::vector<DetectedFrame> frames = kata::test::people::detect(the_class().actors(), options);
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_people_desc d;
  kata_people_desc_init(&d);
  d.joint_count = kata::test::people::kLandmarks;
  kata_people p = nullptr;
  ASSERT_EQ(kata_people_create(ctx, &d, &p), KATA_OK);
  uint32_t ids[16], list[16], count = 0;
  kata_people_counters c;
  c.struct_size = sizeof c;
  kata::test::arm_alloc_counter();
  for (const DetectedFrame& f : frames) {
    kata_people_track(p, f.time, f.xyz.data(), f.confidence.data(), static_cast<uint32_t>(f.actor.size()), ids, 16);
    kata_people_opened(p, list, 16, &count);
    kata_people_closed(p, list, 16, &count);
    kata_people_streams(p, list, 16, &count);
    kata_people_get_counters(p, &c);
  }
  kata_people_track(p, 1e6, nullptr, nullptr, 0, nullptr, 0);
  EXPECT_EQ(kata::test::disarm_alloc_counter(), 0);
  kata_people_destroy(p);
  kata_context_destroy(ctx);
}

}  // namespace
