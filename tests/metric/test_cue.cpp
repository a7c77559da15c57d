// The correction cue's geometry (metric/cue.hpp): on hand-built student/teacher pairs whose
// angles are known by construction, the joint to move, the angle at it and the action; and the
// phrase. The figures expected here come from the construction (a bone turned by a given angle
// about a given axis), not from the code under test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "metric/cue.hpp"
#include "metric/pose_error.hpp"

namespace kata::metric {
namespace {

constexpr double kPi = 3.14159265358979323846;
double rad(double d) { return d * kPi / 180.0; }

// A standing pose in the local frame (x left, y up, z forward; hip at the origin), as GPD joints.
struct Body {
  double j[gpd::kJoints][3] = {{0, 0, 0},      {0, 0.15, 0},     {0, 0.3, 0},       {0, 0.4, 0},
                               {0.1, 0.3, 0},  {0.1, 0.15, 0},   {0.1, 0.0, 0},     {-0.1, 0.3, 0},
                               {-0.1, 0.15, 0}, {-0.1, 0.0, 0},  {0.05, 0, 0},      {0.05, -0.25, 0},
                               {0.05, -0.5, 0}, {-0.05, 0, 0},   {-0.05, -0.25, 0}, {-0.05, -0.5, 0}};
  // Joint c placed from joint `from` by length r along (sin a cos b ..): direction d.
  void place(int c, int from, double r, double dx, double dy, double dz) {
    const double n = std::sqrt(dx * dx + dy * dy + dz * dz);
    j[c][0] = j[from][0] + r * dx / n, j[c][1] = j[from][1] + r * dy / n, j[c][2] = j[from][2] + r * dz / n;
  }
  void pose(float* out) const {
    float x[gpd::kDims] = {};
    for (int c = 1; c < gpd::kJoints; ++c)
      for (int k = 0; k < 3; ++k) x[3 * (c - 1) + k] = static_cast<float>(j[c][k]);
    x[3 * (gpd::kJoints - 1)] = 1.0f;  // hip height
    pose_frames(x, out);
  }
};

struct Got {
  int joint = -1;
  double degrees = 0.0;
  CueAction action = CueAction::kNone;
};
// The bone with the largest angle at its joint, as the Scorer picks within a part.
Got cue_of(const Body& student, const Body& teacher) {
  float s[kPoseFloats], t[kPoseFloats];
  student.pose(s);
  teacher.pose(t);
  BoneCue b{};
  bone_cue(s, t, b);
  int best = 1;
  for (int c = 1; c < gpd::kJoints; ++c) {
    EXPECT_TRUE(std::isfinite(b.degrees[c]) && std::isfinite(b.change[c])) << c;
    if (b.degrees[c] > b.degrees[best]) best = c;
  }
  return {cue_joint(best), b.degrees[best], cue_action(best, b.degrees[best], b.change[best])};
}

// The left shin at `bend` degrees back from the thigh's line (a knee bent by `bend`).
Body knee(double bend) {
  Body b;
  b.place(12, 11, 0.25, 0, -std::cos(rad(bend)), -std::sin(rad(bend)));
  return b;
}

TEST(Cue, KneeStraighterBendsMoreBentStraightens) {
  Got g = cue_of(knee(10), knee(40));
  EXPECT_EQ(g.joint, 11);
  EXPECT_NEAR(g.degrees, 30.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kBend);
  g = cue_of(knee(70), knee(40));
  EXPECT_EQ(g.joint, 11);
  EXPECT_NEAR(g.degrees, 30.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kStraighten);
}

TEST(Cue, ElbowLikeTheKnee) {
  auto elbow = [](double bend) {
    Body b;
    b.place(9, 8, 0.15, 0, -std::cos(rad(bend)), std::sin(rad(bend)));  // right forearm forward
    return b;
  };
  Got g = cue_of(elbow(20), elbow(45));
  EXPECT_EQ(g.joint, 8);
  EXPECT_NEAR(g.degrees, 25.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kBend);
  g = cue_of(elbow(90), elbow(45));
  EXPECT_EQ(g.action, CueAction::kStraighten);
}

// A turned hip swings the whole leg: the cue names the hip, and the knee's own angle is 0.
TEST(Cue, HipForwardNamesTheHipNotTheKnee) {
  auto leg = [](double forward) {
    Body b;
    b.place(11, 10, 0.25, 0, -std::cos(rad(forward)), std::sin(rad(forward)));
    b.place(12, 11, 0.25, 0, -std::cos(rad(forward)), std::sin(rad(forward)));
    return b;
  };
  float s[kPoseFloats], t[kPoseFloats];
  leg(0).pose(s);
  leg(30).pose(t);
  BoneCue b{};
  bone_cue(s, t, b);
  EXPECT_NEAR(b.degrees[11], 30.0, 1e-3);
  EXPECT_NEAR(b.degrees[12], 0.0, 1e-3);
  const Got g = cue_of(leg(0), leg(30));
  EXPECT_EQ(g.joint, 10);
  EXPECT_EQ(g.action, CueAction::kRaise);  // the student's thigh is lower than the teacher's
  EXPECT_EQ(cue_of(leg(45), leg(30)).action, CueAction::kLower);
}

TEST(Cue, ShoulderRaiseLowerOrTurn) {
  auto arm = [](double up, double forward) {  // upper arm from hanging, up (abduction) then forward
    Body b;
    const double dx = std::sin(rad(up)) * std::cos(rad(forward)), dy = -std::cos(rad(up));
    const double dz = std::sin(rad(up)) * std::sin(rad(forward));
    b.place(5, 4, 0.15, dx, dy, dz);
    b.place(6, 5, 0.15, dx, dy, dz);
    return b;
  };
  Got g = cue_of(arm(30, 0), arm(60, 0));
  EXPECT_EQ(g.joint, 4);
  EXPECT_NEAR(g.degrees, 30.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kRaise);
  EXPECT_EQ(cue_of(arm(90, 0), arm(60, 0)).action, CueAction::kLower);
  // Horizontal, swung forward by 40 degrees: the height is the same, so "turn".
  g = cue_of(arm(90, 40), arm(90, 0));
  EXPECT_EQ(g.joint, 4);
  EXPECT_NEAR(g.degrees, 40.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kTurn);
}

// The chest leans forward (Chest->Neck; the head and shoulders move with it): "straighten"; back: "bend".
TEST(Cue, ChestLeanAndSideways) {
  auto chest = [](double forward, double side) {  // the upper body turned about the Chest as one
    Body b;
    const double f = rad(forward), a = rad(side);
    for (int c = 2; c <= 9; ++c) {
      double v[3] = {b.j[c][0] - b.j[1][0], b.j[c][1] - b.j[1][1], b.j[c][2] - b.j[1][2]};
      const double y = v[1] * std::cos(f) - v[2] * std::sin(f), z = v[1] * std::sin(f) + v[2] * std::cos(f);
      v[1] = y, v[2] = z;
      const double x = v[0] * std::cos(a) + v[1] * std::sin(a);
      v[1] = -v[0] * std::sin(a) + v[1] * std::cos(a), v[0] = x;
      for (int k = 0; k < 3; ++k) b.j[c][k] = b.j[1][k] + v[k];
    }
    return b;
  };
  Got g = cue_of(chest(30, 0), chest(0, 0));
  EXPECT_EQ(g.joint, 1);
  EXPECT_NEAR(g.degrees, 30.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kStraighten);
  EXPECT_EQ(cue_of(chest(-30, 0), chest(0, 0)).action, CueAction::kBend);
  g = cue_of(chest(0, 30), chest(0, 0));
  EXPECT_EQ(g.joint, 1);
  EXPECT_EQ(g.action, CueAction::kTurn);
}

TEST(Cue, HeadForwardRaises) {
  auto head = [](double forward) {
    Body b;
    b.place(3, 2, 0.1, 0, std::cos(rad(forward)), std::sin(rad(forward)));
    return b;
  };
  Got g = cue_of(head(25), head(0));
  EXPECT_EQ(g.joint, 2);
  EXPECT_NEAR(g.degrees, 25.0, 1e-3);
  EXPECT_EQ(g.action, CueAction::kRaise);
  EXPECT_EQ(cue_of(head(-25), head(0)).action, CueAction::kLower);
}

TEST(Cue, DegeneratePosesGiveNoNaN) {
  float zero[kPoseFloats] = {}, t[kPoseFloats];
  Body().pose(t);
  BoneCue b{};
  bone_cue(zero, t, b);
  for (int c = 0; c < gpd::kJoints; ++c) EXPECT_EQ(b.degrees[c], 0.0f) << c;
  bone_cue(t, t, b);
  for (int c = 1; c < gpd::kJoints; ++c) EXPECT_NEAR(b.degrees[c], 0.0f, 1e-3) << c;
}

TEST(Cue, Phrase) {
  char buf[64];
  EXPECT_EQ(cue_text(11, 29.6f, static_cast<int>(CueAction::kBend), buf, sizeof buf), 27);
  EXPECT_STREQ(buf, "left knee: bend 30 deg more");
  cue_text(7, 25.0f, static_cast<int>(CueAction::kRaise), buf, sizeof buf);
  EXPECT_STREQ(buf, "right shoulder: raise 25 deg");
  cue_text(0, 12.0f, static_cast<int>(CueAction::kTurn), buf, sizeof buf);
  EXPECT_STREQ(buf, "lower back: turn 12 deg");
  EXPECT_EQ(cue_text(-1, 12.0f, 0, buf, sizeof buf), 0);
  EXPECT_STREQ(buf, "");
  EXPECT_EQ(cue_text(3, 12.0f, 0, buf, sizeof buf), 0);  // the head is never a cue joint
  char small[8];
  EXPECT_EQ(cue_text(11, 30.0f, static_cast<int>(CueAction::kStraighten), small, sizeof small), 28);
  EXPECT_STREQ(small, "left kn");
  for (int c = 1; c < gpd::kJoints; ++c) EXPECT_NE(std::string(cue_joint_words(cue_joint(c))), "") << c;
}

}  // namespace
}  // namespace kata::metric
