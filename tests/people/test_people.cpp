// kata::people inside: the Hungarian method against every permutation, and the tracker's gate
// and motion prediction on poses whose truth is known by construction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "common/error.hpp"
#include "people/hungarian.hpp"
#include "people/tracker.hpp"

namespace {

using kata::people::Frame;
using kata::people::Hungarian;
using kata::people::Tracker;
using kata::people::TrackerConfig;

TEST(Hungarian, FindsTheLeastTotalCostOfEveryPermutation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> cost(0.0, 10.0);
  Hungarian h(8);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 7;
    std::vector<double> m(static_cast<size_t>(n * n));
    for (double& v : m) v = trial % 3 == 0 ? std::floor(cost(rng)) : cost(rng);  // ties too
    std::vector<int> got(static_cast<size_t>(n));
    h.solve(m.data(), n, got.data());
    std::vector<int> seen(got);
    std::sort(seen.begin(), seen.end());
    for (int i = 0; i < n; ++i) ASSERT_EQ(seen[static_cast<size_t>(i)], i) << "not a permutation";
    double total = 0.0;
    for (int i = 0; i < n; ++i) total += m[static_cast<size_t>(i * n + got[static_cast<size_t>(i)])];
    std::vector<int> perm(static_cast<size_t>(n));
    std::iota(perm.begin(), perm.end(), 0);
    double best = 1e300;
    do {
      double s = 0.0;
      for (int i = 0; i < n; ++i) s += m[static_cast<size_t>(i * n + perm[static_cast<size_t>(i)])];
      best = std::min(best, s);
    } while (std::next_permutation(perm.begin(), perm.end()));
    EXPECT_NEAR(total, best, 1e-9) << "n = " << n;
  }
}

// A stick figure of `joints` points: a vertical line 1.7 units tall at (x, z), arms swinging by phase.
std::vector<float> figure(int joints, double x, double z, double phase) {
  std::vector<float> p(static_cast<size_t>(3 * joints));
  for (int j = 0; j < joints; ++j) {
    const double h = 1.7 * j / (joints - 1);
    p[static_cast<size_t>(3 * j)] = static_cast<float>(x + (j % 3 == 1 ? 0.2 * std::sin(phase + j) : 0.0));
    p[static_cast<size_t>(3 * j + 1)] = static_cast<float>(h);
    p[static_cast<size_t>(3 * j + 2)] = static_cast<float>(z);
  }
  return p;
}

TEST(Tracker, TwoPeopleCrossingInTheSamePlaneKeepTheirStreams) {
  // 2D: two figures walk at each other on one line; B vanishes for 0.8 s while they overlap.
  TrackerConfig c;
  c.joints = 17;  // COCO's keypoint count
  Tracker t(c);
  uint32_t a_id = 0, b_id = 0, ids[2];
  for (int k = 0; k < 150; ++k) {
    const double s = k / 30.0, xa = -2.0 + 0.8 * s, xb = 2.0 - 0.8 * s;
    std::vector<float> frame = figure(17, xa, 0.0, 3 * s);
    const bool b_hidden = std::fabs(xa - xb) < 0.32;  // 0.4 s either side of the crossing
    if (!b_hidden) {
      const std::vector<float> b = figure(17, xb, 0.0, 3 * s + 1.0);
      frame.insert(k % 2 ? frame.begin() : frame.end(), b.begin(), b.end());
    }
    const int n = b_hidden ? 1 : 2;
    ASSERT_EQ(t.track(s, frame.data(), nullptr, n, ids), Frame::kTaken);
    const uint32_t got_a = (n == 2 && k % 2) ? ids[1] : ids[0];
    if (k == 0) a_id = got_a, b_id = n == 2 ? (k % 2 ? ids[0] : ids[1]) : 0;
    EXPECT_EQ(got_a, a_id) << "frame " << k;
    if (n == 2) {
      EXPECT_EQ(k % 2 ? ids[0] : ids[1], b_id) << "frame " << k;
    }
  }
  EXPECT_EQ(t.counters().opened, 2u);
}

TEST(Tracker, AStrangerOutsideTheGateOpensANewStream) {
  TrackerConfig c;
  c.joints = 17;
  Tracker t(c);
  uint32_t id[1];
  std::vector<float> p = figure(17, 0.0, 0.0, 0.0);
  ASSERT_EQ(t.track(0.0, p.data(), nullptr, 1, id), Frame::kTaken);
  const uint32_t first = id[0];
  // Gone for 0.5 s; someone appears 3 m away (the gate after 0.5 s: 1 + 2 x 0.5 = 2 body sizes,
  // a body size here ~0.5 m): a new stream; the first person's stays open.
  p = figure(17, 3.0, 0.0, 0.0);
  ASSERT_EQ(t.track(0.5, p.data(), nullptr, 1, id), Frame::kTaken);
  EXPECT_NE(id[0], first);
  EXPECT_EQ(t.open_streams(nullptr, 0), 2);
  // A pose twice the size where the first was: outside the size gate, another stream.
  p = figure(17, 0.0, 0.0, 0.0);
  for (float& v : p) v *= 2.0f;
  ASSERT_EQ(t.track(0.6, p.data(), nullptr, 1, id), Frame::kTaken);
  EXPECT_NE(id[0], first);
  EXPECT_EQ(t.open_streams(nullptr, 0), 3);
}

TEST(Tracker, ConfigOutOfRangeIsRefused) {
  TrackerConfig c;
  EXPECT_THROW(Tracker{c}, kata::Error);  // no joints
  c.joints = 5;
  c.max_poses = 0;
  EXPECT_THROW(Tracker{c}, kata::Error);
  c.max_poses = 4;
  c.coast_seconds = -1.0;
  EXPECT_THROW(Tracker{c}, kata::Error);
  c.coast_seconds = 1.0;
  c.min_confidence = 2.0;
  EXPECT_THROW(Tracker{c}, kata::Error);
  c.min_confidence = 0.5;
  EXPECT_NO_THROW(Tracker{c});
}

}  // namespace
