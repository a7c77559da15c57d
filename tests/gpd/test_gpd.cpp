// GPD v1 layout and values on hand-derived poses, degenerate geometry, the local frame and the
// kinetics kernels. Expected numbers are worked out by hand in the comments, not taken from the
// implementation.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "gpd_test_util.hpp"

namespace {

using namespace gpd_test;
constexpr double kPi = 3.14159265358979323846;
const double kS2 = std::sqrt(2.0), kS6 = std::sqrt(6.0), kS10 = std::sqrt(10.0), kS18 = std::sqrt(18.0),
             kS34 = std::sqrt(34.0);

// A posed skeleton on the unit grid (local frame, body heights):
//   Hip (0,0,0)  Chest (0,1,0)  Neck (0,2,0)  Head (0,2,1) (head bowed forward, +Z)
//   left arm along +X then forearm up:      LShoulder (1,2,0) LElbow (2,2,0) LHand (2,3,0)
//   right arm along -X then forearm forward: RShoulder (-1,2,0) RElbow (-2,2,0) RHand (-2,2,1)
//   left leg down then shin forward:         LHip (1,0,0) LKnee (1,-1,0) LFoot (1,-1,1)
//   right leg straight down:                 RHip (-1,0,0) RKnee (-1,-1,0) RFoot (-1,-2,0)
// Plane normals unit((J2-J1) x (J3-J1)): plane 0 (Chest,Neck,Head): (0,1,0)x(0,1,1) = (1,0,0);
// plane 1: (1,0,0)x(1,1,0) = (0,0,1); plane 2: (-1,0,0)x(-1,0,1) = (0,1,0);
// plane 3: (0,-1,0)x(0,-1,1) = (-1,0,0); plane 4: straight leg, degenerate.
const std::array<float, 48> kGrid = {0, 0, 0,  0, 1, 0,  0, 2, 0,   0, 2, 1,  1, 2, 0,   2, 2, 0,
                                     2, 3, 0,  -1, 2, 0, -2, 2, 0,  -2, 2, 1, 1, 0, 0,   1, -1, 0,
                                     1, -1, 1, -1, 0, 0, -1, -1, 0, -1, -2, 0};
constexpr float kGridHip = 0.9f;

// Feature vectors of kGrid from the reference and every fast path (fresh state each).
struct Computed {
  std::string name;
  std::vector<double> v;
};
std::vector<Computed> compute_all(const std::array<float, 48>& pose, float hip, const GeometryState& start) {
  std::vector<Computed> all;
  GeometryState s = start;
  std::vector<double> ref(kStaticDims, std::nan(""));
  detail::static_features_reference(pose.data(), hip, s, ref.data());
  all.push_back({"reference", ref});
  for (Path p : fast_paths()) {
    GeometryState sf = start;
    std::vector<float> f(kStaticDims, std::nanf(""));
    run_fast(p, pose.data(), hip, sf, f.data());
    all.push_back({path_name(p), std::vector<double>(f.begin(), f.end())});
  }
  GeometryState sd = start;
  std::vector<float> f(kStaticDims, std::nanf(""));
  static_features(pose.data(), hip, sd, f.data());
  all.push_back({"dispatch", std::vector<double>(f.begin(), f.end())});
  return all;
}

// Checks out[offset + i] == expected[i] in every implementation.
void expect_block(const std::vector<Computed>& all, int offset, const std::vector<double>& expected, double tol,
                  const char* what) {
  for (const auto& c : all) {
    for (size_t i = 0; i < expected.size(); ++i) {
      EXPECT_NEAR(c.v[offset + i], expected[i], tol) << c.name << " " << what << " entry " << i;
    }
  }
}
// Checks a single entry in every implementation.
void expect_at(const std::vector<Computed>& all, int dim, double expected, double tol) {
  for (const auto& c : all) EXPECT_NEAR(c.v[dim], expected, tol) << c.name << " " << block_of(dim);
}

TEST(GpdLayout, OffsetsAndCounts) {
  EXPECT_EQ(kOffsetJc, 0);
  EXPECT_EQ(kOffsetJJd, 46);
  EXPECT_EQ(kOffsetJJo, 166);
  EXPECT_EQ(kOffsetJLd, 526);
  EXPECT_EQ(kOffsetLLa, 946);
  EXPECT_EQ(kOffsetJPd, 1381);
  EXPECT_EQ(kOffsetLPa, 1446);
  EXPECT_EQ(kOffsetPPa, 1581);
  EXPECT_EQ(kOffsetJk, 1591);
  EXPECT_EQ(kStaticDims, 1591);
  EXPECT_EQ(kDims, 1683);
  EXPECT_EQ(kOffsetJk + kKineticDims, 1683);
}

TEST(GpdLayout, LinesAndPlanesInSpecOrder) {
  // Spec section 3, typed from the text: bones by child, grandparent -> end site, end-site pairs.
  const int lines[30][2] = {{0, 1},  {1, 2},  {2, 3},  {2, 4},  {4, 5},   {5, 6},  {2, 7},  {7, 8},
                            {8, 9},  {0, 10}, {10, 11}, {11, 12}, {0, 13}, {13, 14}, {14, 15}, {1, 3},
                            {4, 6},  {7, 9},  {10, 12}, {13, 15}, {3, 6},  {3, 9},  {3, 12}, {3, 15},
                            {6, 9},  {6, 12}, {6, 15}, {9, 12}, {9, 15}, {12, 15}};
  for (int l = 0; l < kLines; ++l) {
    EXPECT_EQ(kLineJoints[l][0], lines[l][0]) << "line " << l;
    EXPECT_EQ(kLineJoints[l][1], lines[l][1]) << "line " << l;
  }
  const int planes[5][3] = {{1, 2, 3}, {4, 5, 6}, {7, 8, 9}, {10, 11, 12}, {13, 14, 15}};
  for (int p = 0; p < kPlanes; ++p) {
    for (int v = 0; v < 3; ++v) EXPECT_EQ(kPlaneJoints[p][v], planes[p][v]) << "plane " << p;
  }
}

TEST(GpdHandValues, Jc) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  std::vector<double> jc(kGrid.begin() + 3, kGrid.end());  // joints 1..15
  jc.push_back(kGridHip);
  expect_block(all, kOffsetJc, jc, 0.0, "Jc");
}

TEST(GpdHandValues, JJdAndJJo) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  // Pair index: (i, j) -> sum_{k<i} (15-k) + (j-i-1). (0,1)=0, (0,15)=14, (1,2)=15, (2,3)=29,
  // (3,4)=42 so (3,9)=47, (4,5)=54 so (4,6)=55, (14,15)=119.
  struct Pair {
    int index;
    double d, ux, uy, uz;
  };
  const Pair pairs[] = {
      {0, 1, 0, 1, 0},                                   // Hip->Chest (0,1,0)
      {1, 2, 0, 1, 0},                                   // Hip->Neck (0,2,0)
      {14, std::sqrt(5.0), -1 / std::sqrt(5.0), -2 / std::sqrt(5.0), 0},  // Hip->RFoot (-1,-2,0)
      {15, 1, 0, 1, 0},                                  // Chest->Neck
      {29, 1, 0, 0, 1},                                  // Neck->Head (0,0,1)
      {47, 2, -1, 0, 0},                                 // Head->RHand (-2,0,0)
      {55, kS2, 1 / kS2, 1 / kS2, 0},                    // LShoulder->LHand (1,1,0)
      {119, 1, 0, -1, 0},                                // RKnee->RFoot (0,-1,0)
  };
  for (const auto& p : pairs) {
    expect_at(all, kOffsetJJd + p.index, p.d, 1e-6);
    expect_at(all, kOffsetJJo + 3 * p.index, p.ux, 1e-6);
    expect_at(all, kOffsetJJo + 3 * p.index + 1, p.uy, 1e-6);
    expect_at(all, kOffsetJJo + 3 * p.index + 2, p.uz, 1e-6);
  }
  // Every JJd entry is the length of its JJo difference: unit vectors have length 1 here
  // (no coincident joints in kGrid).
  for (const auto& c : all) {
    for (int p = 0; p < detail::kPairCount; ++p) {
      const double* u = &c.v[kOffsetJJo + 3 * p];
      EXPECT_NEAR(u[0] * u[0] + u[1] * u[1] + u[2] * u[2], 1.0, 1e-6) << c.name << " pair " << p;
    }
  }
}

TEST(GpdHandValues, JLd) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  // Line 0 (Hip->Chest) is the Y axis: distance sqrt(x^2 + z^2) of joints 2..15.
  expect_block(all, kOffsetJLd, {0, 1, 1, 2, 2, 1, 2, std::sqrt(5.0), 1, 1, kS2, 1, 1, 1}, 1e-6, "JLd line 0");
  // Line 3 (Neck->LShoulder): the X-parallel line y=2, z=0; distance sqrt((y-2)^2 + z^2) of
  // joints 0,1,3,5..15.
  expect_block(all, kOffsetJLd + 3 * 14, {2, 1, 1, 0, 1, 0, 0, 1, 2, 3, kS10, 2, 3, 4}, 1e-6, "JLd line 3");
  // Line 16 (LShoulder->LHand) through (1,2,0) along (1,1,0)/sqrt2: for w = P - (1,2,0) the
  // distance is sqrt(|w|^2 - (w.u)^2). Joint 0: w=(-1,-2,0), w.u=-3/sqrt2 -> sqrt(5-4.5).
  expect_at(all, kOffsetJLd + 16 * 14 + 0, std::sqrt(0.5), 1e-6);
  // Joint 5 (LElbow) w=(1,0,0): sqrt(1 - 0.5).
  expect_at(all, kOffsetJLd + 16 * 14 + 4, std::sqrt(0.5), 1e-6);  // joints 0,1,2,3,5 -> 5th
  // Last line 29 (LFoot->RFoot) through (1,-1,1) along (-2,-1,-1); joint 0: w=(-1,1,-1),
  // w x d = (-2,1,3), distance sqrt(14)/sqrt(6).
  expect_at(all, kOffsetJLd + 29 * 14, std::sqrt(14.0 / 6.0), 1e-6);
  // Its last entry, joint 14 (RKnee (-1,-1,0)): w=(-2,0,-1), w x d = (0*-1 - -1*-1,
  // -1*-2 - -2*-1, -2*-1 - 0*-2) = (-1, 0, 2): sqrt(5)/sqrt(6).
  expect_at(all, kOffsetJLd + 29 * 14 + 13, std::sqrt(5.0 / 6.0), 1e-6);
}

TEST(GpdHandValues, LLa) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  // Pair index: (l, m) -> sum_{k<l} (29-k) + (m-l-1). (3,4) = 84, (16,17) = 344.
  expect_at(all, kOffsetLLa + 0, 0.0, 1e-3);                 // lines 0,1 both +Y (acos 1: spec tol)
  expect_at(all, kOffsetLLa + 1, kPi / 2, 1e-6);             // +Y vs +Z
  expect_at(all, kOffsetLLa + 5, kPi / 2, 1e-6);             // line 6 is -X
  expect_at(all, kOffsetLLa + 9, kPi, 1e-3);                 // line 10 is -Y
  expect_at(all, kOffsetLLa + 14, kPi / 4, 1e-6);            // line 15 (0,1,1)/sqrt2
  expect_at(all, kOffsetLLa + 86, kPi, 1e-3);                // lines 3 (+X) and 6 (-X)
  expect_at(all, kOffsetLLa + 344, 2 * kPi / 3, 1e-6);       // (1,1,0)/s2 . (-1,0,1)/s2 = -1/2
  // Last pair (28, 29): (1,-4,-1)/sqrt18 . (-2,-1,-1)/sqrt6 = 3/sqrt108.
  expect_at(all, kOffsetLLa + 434, std::acos(3 / std::sqrt(108.0)), 1e-6);
}

TEST(GpdHandValues, JPdEveryEntry) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  // Plane 0, n=(1,0,0), J1 Chest: x of joints 0,4..15.
  expect_block(all, kOffsetJPd + 0, {0, 1, 2, 2, -1, -2, -2, 1, 1, 1, -1, -1, -1}, 1e-6, "JPd plane 0");
  // Plane 1, n=(0,0,1), J1 LShoulder: z of joints 0..3,7..15.
  expect_block(all, kOffsetJPd + 13, {0, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0}, 1e-6, "JPd plane 1");
  // Plane 2, n=(0,1,0), J1 RShoulder (y=2): y-2 of joints 0..6,10..15.
  expect_block(all, kOffsetJPd + 26, {-2, -1, 0, 0, 0, 0, 1, -2, -3, -3, -2, -3, -4}, 1e-6, "JPd plane 2");
  // Plane 3, n=(-1,0,0), J1 LHip (x=1): 1-x of joints 0..9,13..15.
  expect_block(all, kOffsetJPd + 39, {1, 1, 1, 1, 0, -1, -1, 2, 3, 3, 2, 2, 2}, 1e-6, "JPd plane 3");
  // Plane 4 is degenerate with no history: n = 0.
  expect_block(all, kOffsetJPd + 52, std::vector<double>(13, 0.0), 0.0, "JPd plane 4");
}

TEST(GpdHandValues, LPa) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  const double h = kPi / 2, q = kPi / 4;
  // Plane 0, n=(1,0,0): acos(dir.x) of lines 0,3..14,16..29 (1, 2, 15 lie in the plane).
  expect_block(all, kOffsetLPa + 0,
               {h, 0, 0, h, kPi, kPi, h, 0, h, h, kPi, h, h, q, 3 * q, h, h, std::acos(2 / kS6), kPi,
                std::acos(1 / kS10), std::acos(-1 / kS18), std::acos(-4 / kS18), std::acos(-1 / kS18),
                std::acos(-3 / kS34), q, std::acos(1 / kS18), std::acos(-2 / kS6)},
               1e-3, "LPa plane 0");
  // Plane 1, n=(0,0,1): acos(dir.z) of lines 0..3,6..15,17..29 (4, 5, 16 lie in the plane).
  expect_block(all, kOffsetLPa + 27,
               {h, h, 0, h, h, h, 0, h, h, 0, h, h, h, q, q, q, h, std::acos(-1 / kS6), h, h,
                std::acos(-1 / kS18), std::acos(1 / kS18), std::acos(1 / kS18), h, h, std::acos(-1 / kS18),
                std::acos(-1 / kS6)},
               1e-3, "LPa plane 1");
  // Plane 4 is degenerate with no history: every angle is acos(0).
  expect_block(all, kOffsetLPa + 4 * 27, std::vector<double>(27, h), 1e-6, "LPa plane 4");
  // Away from 0 and pi the float paths are much tighter than 1e-3.
  expect_at(all, kOffsetLPa + 17, std::acos(2 / kS6), 1e-5);
  expect_at(all, kOffsetLPa + 27 + 17, std::acos(-1 / kS6), 1e-5);
}

TEST(GpdHandValues, PPaEveryEntry) {
  const auto all = compute_all(kGrid, kGridHip, GeometryState{});
  const double h = kPi / 2;
  // n0 = +X, n1 = +Z, n2 = +Y, n3 = -X, n4 = 0: pairs (0,1) (0,2) (0,3) (0,4) (1,2) ... (3,4).
  expect_block(all, kOffsetPPa, {h, h, kPi, h, h, h, h, h, h, h}, 1e-3, "PPa");
}

TEST(GpdDegenerate, PreviousNormalIsKept) {
  // First a frame whose right leg bends: RFoot at (-1,-1,-1): (0,-1,0)x(0,-1,-1) = (1,0,0).
  auto bent = kGrid;
  bent[45] = -1;
  bent[46] = -1;
  bent[47] = -1;
  for (const char* impl : {"reference", "fast"}) {
    GeometryState s;
    std::vector<double> out(kStaticDims);
    std::vector<float> outf(kStaticDims);
    if (impl[0] == 'r') {
      detail::static_features_reference(bent.data(), 0.9f, s, out.data());
    } else {
      static_features(bent.data(), 0.9f, s, outf.data());
    }
    ASSERT_TRUE(s.has_normal[4]) << impl;
    EXPECT_NEAR(s.normal[4][0], 1.0, 1e-6) << impl;
    // Then kGrid's straight leg: the normal stays (1,0,0).
    std::vector<Computed> all = compute_all(kGrid, kGridHip, s);
    for (const auto& c : all) {
      if ((impl[0] == 'r') != (c.name == "reference")) continue;
      const std::vector<Computed> one{c};
      // PPa (0,4): n0 = n4 = +X -> 0; (3,4): -X vs +X -> pi; (1,4), (2,4): pi/2.
      expect_at(one, kOffsetPPa + 3, 0.0, 1e-3);
      expect_at(one, kOffsetPPa + 9, kPi, 1e-3);
      expect_at(one, kOffsetPPa + 6, kPi / 2, 1e-6);
      // JPd plane 4, J1 RHip (x=-1): x+1 of joints 0..12.
      expect_block(one, kOffsetJPd + 52, {1, 1, 1, 1, 2, 3, 3, 0, -1, -1, 2, 2, 2}, 1e-6, "JPd plane 4");
    }
  }
}

// Every value finite, every fast path equal to the reference.
void expect_finite_and_agreeing(const std::array<float, 48>& pose, const char* what) {
  const auto all = compute_all(pose, 0.5f, GeometryState{});
  for (const auto& c : all) {
    for (int d = 0; d < kStaticDims; ++d) {
      ASSERT_TRUE(std::isfinite(c.v[d])) << what << " " << c.name << " " << block_of(d);
      EXPECT_NEAR(c.v[d], all[0].v[d], tolerance(d, all[0].v[d])) << what << " " << c.name << " " << block_of(d);
    }
  }
}

TEST(GpdDegenerate, AllJointsAtOnePoint) {
  std::array<float, 48> pose{};
  for (int j = 0; j < 16; ++j) {
    pose[3 * j] = 0.25f;
    pose[3 * j + 1] = -0.5f;
    pose[3 * j + 2] = 1.0f;
  }
  expect_finite_and_agreeing(pose, "one point");
  const auto all = compute_all(pose, 0.5f, GeometryState{});
  for (const auto& c : all) {
    // Zero vectors: JJd, JJo, JLd, JPd are 0; every angle is acos(0) = pi/2.
    for (int d = kOffsetJJd; d < kOffsetLLa; ++d) EXPECT_EQ(c.v[d], 0.0) << c.name << " " << block_of(d);
    for (int d = kOffsetJPd; d < kOffsetLPa; ++d) EXPECT_EQ(c.v[d], 0.0) << c.name << " " << block_of(d);
    for (int d = kOffsetLLa; d < kOffsetJPd; ++d) EXPECT_NEAR(c.v[d], kPi / 2, 1e-6) << c.name << " " << block_of(d);
    for (int d = kOffsetLPa; d < kStaticDims; ++d) EXPECT_NEAR(c.v[d], kPi / 2, 1e-6) << c.name << " " << block_of(d);
  }
}

TEST(GpdDegenerate, TPoseStraightLimbs) {
  // Arms straight along X, legs straight down, neck/head straight up: every plane collinear.
  const std::array<float, 48> tpose = {0, 0, 0,      0, 0.25f, 0, 0, 0.5f, 0,   0, 0.6f, 0,
                                       0.1f, 0.5f, 0, 0.3f, 0.5f, 0, 0.5f, 0.5f, 0, -0.1f, 0.5f, 0,
                                       -0.3f, 0.5f, 0, -0.5f, 0.5f, 0, 0.1f, 0, 0, 0.1f, -0.25f, 0,
                                       0.1f, -0.5f, 0, -0.1f, 0, 0, -0.1f, -0.25f, 0, -0.1f, -0.5f, 0};
  expect_finite_and_agreeing(tpose, "T-pose");
  for (const auto& c : compute_all(tpose, 0.5f, GeometryState{})) {
    for (int d = kOffsetPPa; d < kStaticDims; ++d) EXPECT_NEAR(c.v[d], kPi / 2, 1e-6) << c.name;
  }
  // A slightly bent elbow (sine of the angle ~0.0005 < 1e-3) is still degenerate.
  auto almost = tpose;
  almost[3 * 6 + 1] = 0.5f + 0.0001f;  // LHand lifted 1e-4, 0.4 from LShoulder: sine ~2.5e-4
  GeometryState s;
  std::vector<double> out(kStaticDims);
  detail::static_features_reference(almost.data(), 0.5f, s, out.data());
  EXPECT_FALSE(s.has_normal[1]);
  // Lifted 2e-3 (sine ~5e-3) it is a plane.
  almost[3 * 6 + 1] = 0.5f + 0.002f;
  detail::static_features_reference(almost.data(), 0.5f, s, out.data());
  EXPECT_TRUE(s.has_normal[1]);
}

TEST(GpdDegenerate, ZeroLengthLine) {
  // LElbow on LShoulder: line 4 (LShoulder->LElbow) has zero length; the JLd of line 4 is the
  // distance of each joint to that point, its LLa angles are acos(0).
  auto pose = kGrid;
  pose[15] = pose[12];
  pose[16] = pose[13];
  pose[17] = pose[14];
  expect_finite_and_agreeing(pose, "zero line");
  const auto all = compute_all(pose, kGridHip, GeometryState{});
  // Joints 0,1,2,3,6,...: Hip (0,0,0) to (1,2,0) -> sqrt5; Chest -> sqrt2; Neck -> 1;
  // Head (0,2,1) -> sqrt2; LHand (2,3,0) -> sqrt2.
  expect_block(all, kOffsetJLd + 4 * 14, {std::sqrt(5.0), kS2, 1, kS2, kS2}, 1e-6, "JLd line 4");
  // LLa (0,4): index 3.
  expect_at(all, kOffsetLLa + 3, kPi / 2, 1e-6);
}

TEST(GpdLocalFrame, TPoseFacingPlusZStays) {
  // World T-pose facing +Z, left = +X, hip at (3, 10, -2), H = 20: the local frame only
  // translates and scales it.
  std::array<float, 48> world{};
  for (int j = 0; j < 16; ++j) {
    world[3 * j] = 3.0f + 2.0f * kGrid[3 * j];
    world[3 * j + 1] = 10.0f + 2.0f * kGrid[3 * j + 1];
    world[3 * j + 2] = -2.0f + 2.0f * kGrid[3 * j + 2];
  }
  GeometryState s;
  float local[48], hip = 0;
  to_local_frame(world.data(), 20.0, s, local, &hip);
  for (int i = 0; i < 48; ++i) EXPECT_NEAR(local[i], kGrid[i] / 10.0, 1e-6) << i;
  EXPECT_NEAR(hip, 0.5, 1e-7);
  EXPECT_TRUE(s.has_yaw);
}

TEST(GpdLocalFrame, RotatedBodyIsTurnedBack) {
  // kGrid turned about +Y by theta (x' = c x + s z, z' = -s x + c z): the body's left, u, now
  // points along (c, -s). to_local_frame must undo the turn for every theta, and u must end up
  // along +X (not -X) and the head, bowed towards +Z in kGrid, towards +Z again.
  for (double theta : {0.3, 1.5707963, 2.5, -2.9, 3.14159}) {
    const double c = std::cos(theta), s = std::sin(theta);
    std::array<float, 48> world{};
    for (int j = 0; j < 16; ++j) {
      const double x = kGrid[3 * j], y = kGrid[3 * j + 1], z = kGrid[3 * j + 2];
      world[3 * j] = static_cast<float>(c * x + s * z);
      world[3 * j + 1] = static_cast<float>(y + 1.0);
      world[3 * j + 2] = static_cast<float>(-s * x + c * z);
    }
    GeometryState st;
    float local[48], hip = 0;
    to_local_frame(world.data(), 1.0, st, local, &hip);
    for (int i = 0; i < 48; ++i) EXPECT_NEAR(local[i], kGrid[i], 2e-6) << "theta " << theta << " coord " << i;
    EXPECT_NEAR(hip, 1.0, 1e-7);
    EXPECT_GT(local[3 * 10], 0.0f);     // LHip on +X
    EXPECT_GT(local[3 * 3 + 2], 0.5f);  // Head towards +Z
  }
}

TEST(GpdLocalFrame, VerticalBodyKeepsPreviousYaw) {
  // First a frame turned by 90 degrees about Y (left along -Z): yaw remembered.
  std::array<float, 48> world{};
  for (int j = 0; j < 16; ++j) {
    world[3 * j] = kGrid[3 * j + 2];
    world[3 * j + 1] = kGrid[3 * j + 1];
    world[3 * j + 2] = -kGrid[3 * j];
  }
  GeometryState st;
  float local[48], hip = 0;
  to_local_frame(world.data(), 1.0, st, local, &hip);
  // Then a frame whose hips and shoulders line up vertically (|u| = 0 on XZ): the previous
  // yaw applies, so a joint at world (0,0,-1) maps to local (+1,0,0) as in the first frame.
  std::array<float, 48> lying{};
  lying[3 * 10 + 1] = 1;   // LHip (0,1,0)
  lying[3 * 13 + 1] = -1;  // RHip (0,-1,0)
  lying[3 * 5 + 2] = -1;   // LElbow (0,0,-1)
  to_local_frame(lying.data(), 1.0, st, local, &hip);
  EXPECT_NEAR(local[15], 1.0, 1e-6);
  EXPECT_NEAR(local[17], 0.0, 1e-6);
  // With no history the yaw is 0: identity.
  GeometryState fresh;
  to_local_frame(lying.data(), 1.0, fresh, local, &hip);
  EXPECT_NEAR(local[15], 0.0, 1e-6);
  EXPECT_NEAR(local[17], -1.0, 1e-6);
  EXPECT_FALSE(fresh.has_yaw);
}

// --- Kinetics (spec section 5) ---

// f(t) = a + b t + c t^2: exact derivatives b + 2 c t and 2 c.
struct Quadratic {
  double a, b, c;
  double f(double t) const { return a + b * t + c * t * t; }
  double v(double t) const { return b + 2 * c * t; }
  double acc() const { return 2 * c; }
};

TEST(GpdKinetics, WeightsExactOnQuadraticsUnevenSteps) {
  const Quadratic q{0.7, -1.3, 2.9};
  for (auto [t0, h1, h2] : {std::array<double, 3>{0.4, 0.01, 0.017}, std::array<double, 3>{-1.0, 0.2, 0.05},
                            std::array<double, 3>{2.0, 1.0 / 120, 1.0 / 120}}) {
    const double t1 = t0 + h1, t2 = t1 + h2;
    const double f[3] = {q.f(t0), q.f(t1), q.f(t2)};
    const DifferenceWeights b = backward_weights(h1, h2), c = central_weights(h1, h2);
    auto apply = [&](const double* w) { return w[0] * f[0] + w[1] * f[1] + w[2] * f[2]; };
    const double scale = 1.0 / (h1 * h2);  // the weights' size: relative rounding of the sums
    EXPECT_NEAR(apply(b.wv), q.v(t2), 1e-13 * scale) << "backward v at t2";
    EXPECT_NEAR(apply(c.wv), q.v(t1), 1e-13 * scale) << "central v at t1";
    EXPECT_NEAR(apply(b.wa), q.acc(), 1e-12 * scale) << "backward a";
    EXPECT_NEAR(apply(c.wa), q.acc(), 1e-12 * scale) << "central a";
    // Derivatives of a constant are zero: weights sum to 0.
    EXPECT_NEAR(b.wv[0] + b.wv[1] + b.wv[2], 0.0, 1e-12 * scale);
    EXPECT_NEAR(c.wa[0] + c.wa[1] + c.wa[2], 0.0, 1e-12 * scale);
  }
  // Hand values, h1 = 1, h2 = 2: backward v = 2/3 f0 - 3/2 f1 + 5/6 f2; central
  // v = -2/3 f0 + 1/2 f1 + 1/6 f2; a = 2/3 f0 - f1 + 1/3 f2.
  const DifferenceWeights b = backward_weights(1, 2), c = central_weights(1, 2);
  EXPECT_DOUBLE_EQ(b.wv[0], 2.0 / 3);
  EXPECT_DOUBLE_EQ(b.wv[1], -1.5);
  EXPECT_DOUBLE_EQ(b.wv[2], 5.0 / 6);
  EXPECT_DOUBLE_EQ(c.wv[0], -2.0 / 3);
  EXPECT_DOUBLE_EQ(c.wv[1], 0.5);
  EXPECT_DOUBLE_EQ(c.wv[2], 1.0 / 6);
  for (const auto* w : {&b, &c}) {
    EXPECT_DOUBLE_EQ(w->wa[0], 2.0 / 3);
    EXPECT_DOUBLE_EQ(w->wa[1], -1.0);
    EXPECT_DOUBLE_EQ(w->wa[2], 1.0 / 3);
  }
}

// Three block-1 samples where value i follows its own quadratic.
struct Samples {
  std::vector<Quadratic> q;
  float f[3][kJcDims];
};
Samples make_samples(const double t[3]) {
  Samples s;
  for (int i = 0; i < kJcDims; ++i) s.q.push_back({0.01 * i - 0.2, 0.3 - 0.02 * i, 0.5 + 0.1 * (i % 7)});
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < kJcDims; ++i) s.f[k][i] = static_cast<float>(s.q[i].f(t[k]));
  }
  return s;
}

// Expected block 9 from per-value (v, a): joints (vx,vy,vz,ax,ay,az), then hip (v, a).
void expect_block9(const float* out, const std::vector<double>& v, const std::vector<double>& a, double tol) {
  for (int j = 0; j < 15; ++j) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(out[6 * j + c], v[3 * j + c], tol) << "v joint " << j + 1 << " axis " << c;
      EXPECT_NEAR(out[6 * j + 3 + c], a[3 * j + c], tol) << "a joint " << j + 1 << " axis " << c;
    }
  }
  EXPECT_NEAR(out[90], v[45], tol) << "hip height v";
  EXPECT_NEAR(out[91], a[45], tol) << "hip height a";
}

TEST(GpdKinetics, BlockLayoutAndValues) {
  const double t[3] = {0.0, 0.1, 0.25};  // h1 = 0.1, h2 = 0.15
  const Samples s = make_samples(t);
  // The samples are float-rounded (~3e-8); with weights ~1/h^2 ~ 100 that is ~1e-5 at most.
  std::vector<double> v(kJcDims), a(kJcDims);
  float out[kKineticDims];
  for (int i = 0; i < kJcDims; ++i) {
    v[i] = s.q[i].v(t[2]);
    a[i] = s.q[i].acc();
  }
  kinetics(s.f[0], s.f[1], s.f[2], backward_weights(0.1, 0.15), out);
  expect_block9(out, v, a, 5e-5);
  for (int i = 0; i < kJcDims; ++i) v[i] = s.q[i].v(t[1]);
  kinetics(s.f[0], s.f[1], s.f[2], central_weights(0.1, 0.15), out);
  expect_block9(out, v, a, 5e-5);
}

TEST(GpdKinetics, SegmentStartAndTwoPoint) {
  const double t[3] = {0.0, 0.1, 0.25};
  const Samples s = make_samples(t);
  float out[kKineticDims];
  for (float& x : out) x = 1.0f;
  kinetics_zero(out);
  for (float x : out) EXPECT_EQ(x, 0.0f);
  // Second frame, backward: v = (f1 - f0)/h1, a = 0.
  kinetics_two_point(s.f[0], s.f[1], 0.1, out);
  std::vector<double> v(kJcDims), a(kJcDims, 0.0);
  for (int i = 0; i < kJcDims; ++i) v[i] = (double(s.f[1][i]) - s.f[0][i]) / 0.1;
  expect_block9(out, v, a, 1e-6);
  // Null samples whose weights are zero: only f2 counts.
  DifferenceWeights w{};
  w.wv[2] = 2.0;
  w.wa[2] = -1.0;
  kinetics(nullptr, nullptr, s.f[2], w, out);
  for (int i = 0; i < kJcDims; ++i) {
    v[i] = 2.0 * s.f[2][i];
    a[i] = -1.0 * s.f[2][i];
  }
  expect_block9(out, v, a, 1e-6);
}

}  // namespace
