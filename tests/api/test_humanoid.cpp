// The humanoid (VRM) rig through the public C ABI only (kata/humanoid.h): forward kinematics
// computed here from the poses' quaternions and offsets must put every placed bone's joint where
// the input has it, on every frame of a CMU clip, of MediaPipe landmarks made from one (a
// converter written here), and of a stream's ghosts; Unity's frame must mirror the rig's; the
// chosen twists must be the documented hinges; no finite input may give a NaN.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "kata/kata.h"
#include "support/alloc_counter.hpp"

namespace {

constexpr double kMetresPerUnit = 0.056444;  // CMU BVH units to metres (the "cmu" default)
constexpr int kLandmarks = 33;
constexpr double kDegrees = 180.0 / 3.14159265358979323846;

using Quat = std::array<double, 4>;  // x, y, z, w
using Vec = std::array<double, 3>;

Quat mul(const Quat& a, const Quat& b) {
  return {a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1], a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
          a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3], a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2]};
}
Vec rotate(const Quat& q, const Vec& v) {
  const Quat p = mul(mul(q, {v[0], v[1], v[2], 0.0}), {-q[0], -q[1], -q[2], q[3]});
  return {p[0], p[1], p[2]};
}
Vec add(const Vec& a, const Vec& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec scale(double s, const Vec& a) { return {s * a[0], s * a[1], s * a[2]}; }
double norm(const Vec& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// The VRM parents as kata/humanoid.h lists them (written out here, not read from the library).
const int kParent[KATA_BONE_COUNT] = {-1, 0, 1, 2, 3, 4, 3, 6, 7, 8, 3, 10, 11, 12, 0, 14, 15, 16, 0, 18, 19, 20};

// Forward kinematics of a pose (the header's formula), with the offsets given (the pose's own,
// or the rest's).
std::array<Vec, KATA_BONE_COUNT> forward(const kata_humanoid_pose& p, const float (*offsets)[3]) {
  std::array<Quat, KATA_BONE_COUNT> g;
  std::array<Vec, KATA_BONE_COUNT> x;
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    const Quat local = {p.rotation[b][0], p.rotation[b][1], p.rotation[b][2], p.rotation[b][3]};
    if (kParent[b] < 0) {
      g[0] = local;
      x[0] = {p.hips_position[0], p.hips_position[1], p.hips_position[2]};
      continue;
    }
    const int q = kParent[b];
    x[static_cast<size_t>(b)] = add(x[static_cast<size_t>(q)], rotate(g[static_cast<size_t>(q)], {offsets[b][0], offsets[b][1], offsets[b][2]}));
    g[static_cast<size_t>(b)] = mul(g[static_cast<size_t>(q)], local);
  }
  return x;
}

// A CMU clip's frames and joint positions by name (Y-up metres).
struct Clip {
  kata_context ctx = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  uint32_t joints = 0;
  std::map<std::string, int> index;
  std::vector<std::vector<float>> raw;  // file units, frames 1..
  explicit Clip(const char* name) {
    EXPECT_EQ(kata_context_create(&ctx), KATA_OK);
    const std::string path = std::string(KATA_DATA_DIR) + "/cmu/" + name;
    EXPECT_EQ(kata_clip_load_bvh(ctx, path.c_str(), &clip), KATA_OK) << kata_context_last_error(ctx);
    EXPECT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
    joints = kata_skeleton_joint_count(skel);
    for (uint32_t j = 0; j < joints; ++j) index[kata_skeleton_joint_name(skel, j)] = static_cast<int>(j);
    std::vector<float> p(3 * joints);
    for (uint32_t f = 1; f < kata_clip_frame_count(clip); ++f) {
      EXPECT_EQ(kata_clip_positions(clip, f, p.data(), p.size()), KATA_OK);
      raw.push_back(p);
    }
  }
  ~Clip() {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(clip);
    kata_context_destroy(ctx);
  }
  Vec at(size_t f, const std::string& joint) const {
    const int j = index.at(joint);
    const float* p = raw[f].data() + 3 * j;
    return {kMetresPerUnit * p[0], kMetresPerUnit * p[1], kMetresPerUnit * p[2]};
  }
};

// The joint each bone sits on in a CMU clip (kata/humanoid.h "The rig": "cmu").
const char* const kCmuBoneJoint[KATA_BONE_COUNT] = {
    "Hips",      "Hips",         "Spine",        "Spine1",       "Neck1",     "Head",         "Spine1",      "LeftArm",
    "LeftForeArm", "LeftHand",   "Spine1",       "RightArm",     "RightForeArm", "RightHand", "LeftUpLeg",   "LeftLeg",
    "LeftFoot",  "LeftToeBase",  "RightUpLeg",   "RightLeg",     "RightFoot", "RightToeBase"};

void expect_unit_quaternions(const kata_humanoid_pose& p, size_t f) {
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    const float* q = p.rotation[b];
    const double n = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
    ASSERT_NEAR(n, 1.0, 1e-6) << "frame " << f << " bone " << kata_humanoid_bone_name(b);
    ASSERT_GE(q[3], 0.0f) << "frame " << f << " bone " << kata_humanoid_bone_name(b);
  }
}

// The MediaPipe converter of tests/api/test_anybody.cpp: landmarks on the CMU joints, face and hand
// points offset by fixed vectors, ears symmetric about Head, origin at the hip midpoint, camera
// axes (x, y, z) -> (x, -y, -z).
std::vector<float> to_mediapipe(const Clip& c, size_t f) {
  std::array<Vec, kLandmarks> l;
  const Vec head = c.at(f, "Head");
  const Vec face[11] = {{0, 0.02, 0.10},  {0.02, 0.05, 0.09}, {0.03, 0.05, 0.09}, {0.04, 0.05, 0.08},
                        {-0.02, 0.05, 0.09}, {-0.03, 0.05, 0.09}, {-0.04, 0.05, 0.08}, {0.07, 0, 0},
                        {-0.07, 0, 0},   {0.02, -0.02, 0.09}, {-0.02, -0.02, 0.09}};
  for (int i = 0; i < 11; ++i) l[static_cast<size_t>(i)] = add(head, face[i]);
  l[11] = c.at(f, "LeftArm");
  l[12] = c.at(f, "RightArm");
  l[13] = c.at(f, "LeftForeArm");
  l[14] = c.at(f, "RightForeArm");
  l[15] = c.at(f, "LeftHand");
  l[16] = c.at(f, "RightHand");
  l[17] = add(l[15], {0.06, -0.02, -0.02});
  l[18] = add(l[16], {-0.06, -0.02, -0.02});
  l[19] = add(l[15], {0.08, 0, 0});
  l[20] = add(l[16], {-0.08, 0, 0});
  l[21] = add(l[15], {0.03, 0, 0.03});
  l[22] = add(l[16], {-0.03, 0, 0.03});
  l[23] = c.at(f, "LeftUpLeg");
  l[24] = c.at(f, "RightUpLeg");
  l[25] = c.at(f, "LeftLeg");
  l[26] = c.at(f, "RightLeg");
  l[27] = c.at(f, "LeftFoot");
  l[28] = c.at(f, "RightFoot");
  l[29] = add(l[27], {0, -0.05, -0.05});
  l[30] = add(l[28], {0, -0.05, -0.05});
  l[31] = c.at(f, "LeftToeBase");
  l[32] = c.at(f, "RightToeBase");
  const Vec origin = scale(0.5, add(l[23], l[24]));
  std::vector<float> out(3 * kLandmarks);
  for (int i = 0; i < kLandmarks; ++i) {
    const Vec p = sub(l[static_cast<size_t>(i)], origin);
    out[static_cast<size_t>(3 * i)] = static_cast<float>(p[0]);
    out[static_cast<size_t>(3 * i + 1)] = static_cast<float>(-p[1]);
    out[static_cast<size_t>(3 * i + 2)] = static_cast<float>(-p[2]);
  }
  return out;
}

// Where each bone's joint is for MediaPipe landmarks (Y-up metres): the documented synthesis of
// GPD Hip, Chest, Neck, Head (kata/stream.h "Layouts"), and the landmarks.
std::array<Vec, KATA_BONE_COUNT> mediapipe_joints(const std::vector<float>& lm) {
  auto L = [&](int i) { return Vec{lm[static_cast<size_t>(3 * i)], -lm[static_cast<size_t>(3 * i + 1)], -lm[static_cast<size_t>(3 * i + 2)]}; };
  const Vec h = scale(0.5, add(L(23), L(24))), s = scale(0.5, add(L(11), L(12))), e = scale(0.5, add(L(7), L(8)));
  const Vec lr = sub(L(23), L(24)), u = sub(s, h);
  const Vec f = scale(1.0 / norm(lr), cross(lr, u));
  const Vec hip = add(add(h, scale(0.264, u)), scale(-0.07, f));
  const Vec chest = add(h, scale(0.868, u));
  const Vec neck = scale(0.5, add(chest, e));
  return {hip, hip, chest, chest, neck, e, chest, L(11), L(13), L(15), chest, L(12), L(14), L(16),
          L(23), L(25), L(27), L(31), L(24), L(26), L(28), L(32)};
}

struct Rig {
  kata_humanoid_rig rig = nullptr;
  ~Rig() { kata_humanoid_rig_destroy(rig); }
};

kata_humanoid_pose new_pose() {
  kata_humanoid_pose p;
  std::memset(&p, 0, sizeof p);
  p.struct_size = sizeof p;
  return p;
}

}  // namespace

TEST(Humanoid, BoneNamesAndTreeAreVrms) {
  const char* names[KATA_BONE_COUNT] = {"Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder",
                                         "LeftUpperArm", "LeftLowerArm", "LeftHand", "RightShoulder", "RightUpperArm",
                                         "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot",
                                         "LeftToes", "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"};
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    EXPECT_STREQ(kata_humanoid_bone_name(b), names[b]);
    EXPECT_EQ(kata_humanoid_bone_find(names[b]), b);
    EXPECT_EQ(kata_humanoid_bone_parent(b), kParent[b]);
    EXPECT_LT(kata_humanoid_bone_parent(b), b);
  }
  EXPECT_EQ(kata_humanoid_bone_name(-1), nullptr);
  EXPECT_EQ(kata_humanoid_bone_name(KATA_BONE_COUNT), nullptr);
  EXPECT_EQ(kata_humanoid_bone_parent(KATA_BONE_COUNT), -2);
  EXPECT_EQ(kata_humanoid_bone_find("hips"), -1);
  EXPECT_EQ(kata_humanoid_bone_find(nullptr), -1);
  EXPECT_EQ(KATA_BONE_LEFT_UPPER_LEG, 14);
}

// CMU on its own layout: every bone's joint from FK, with the pose's offsets and with the rest's
// (the clip keeps its bone lengths), on every frame; unit quaternions; Unity's frame mirrors.
TEST(Humanoid, CmuClipForwardKinematicsPutsEveryJointBack) {
  Clip c("02_01.bvh");
  kata_humanoid_desc d;
  kata_humanoid_desc_init(&d);
  d.layout = "cmu";
  Rig r;
  ASSERT_EQ(kata_humanoid_rig_create(c.ctx, c.skel, &d, &r.rig), KATA_OK) << kata_context_last_error(c.ctx);
  EXPECT_EQ(kata_humanoid_rig_placed(r.rig), (1u << KATA_BONE_COUNT) - 1);
  EXPECT_DOUBLE_EQ(kata_humanoid_rig_metres_per_unit(r.rig), kMetresPerUnit);
  EXPECT_EQ(kata_humanoid_rig_calibrated(r.rig), 1);
  EXPECT_EQ(kata_humanoid_rig_bone_source(r.rig, KATA_BONE_LEFT_LOWER_ARM), c.index.at("LeftForeArm"));
  EXPECT_EQ(kata_humanoid_rig_bone_source(r.rig, KATA_BONE_SPINE), -1);
  kata_humanoid_pose rest = new_pose();
  ASSERT_EQ(kata_humanoid_rig_rest_pose(r.rig, KATA_HUMANOID_RIGHT_HANDED, &rest), KATA_OK);
  // The T-pose: arms out along +-X, legs down, feet forward, spine up.
  EXPECT_GT(rest.offset[KATA_BONE_LEFT_LOWER_ARM][0], 0.2f);
  EXPECT_LT(rest.offset[KATA_BONE_RIGHT_LOWER_ARM][0], -0.2f);
  EXPECT_LT(rest.offset[KATA_BONE_LEFT_FOOT][1], -0.3f);
  EXPECT_GT(rest.offset[KATA_BONE_LEFT_TOES][2], 0.05f);
  EXPECT_GT(rest.offset[KATA_BONE_NECK][1], 0.05f);
  const double body = 1.7;  // metres, the scale of "relative"
  double worst = 0, worst_rest = 0, worst_mirror = 0;
  for (size_t f = 0; f < c.raw.size(); ++f) {
    kata_humanoid_pose p = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[f].data(), c.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_OK)
        << kata_humanoid_rig_last_error(r.rig);
    ASSERT_EQ(p.frame, KATA_HUMANOID_RIGHT_HANDED);
    ASSERT_EQ(p.degenerate, 0u) << f;
    expect_unit_quaternions(p, f);
    const auto x = forward(p, p.offset);
    const auto xr = forward(p, rest.offset);
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      const Vec want = c.at(f, kCmuBoneJoint[b]);
      worst = std::max(worst, norm(sub(x[static_cast<size_t>(b)], want)));
      worst_rest = std::max(worst_rest, norm(sub(xr[static_cast<size_t>(b)], want)));
    }
    // Unity: positions (x, y, z) -> (-x, y, z), quaternions (x, y, z, w) -> (x, -y, -z, w); its FK
    // is the mirror of the rig's.
    kata_humanoid_pose u = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[f].data(), c.joints, KATA_HUMANOID_UNITY, &u), KATA_OK);
    ASSERT_EQ(u.frame, KATA_HUMANOID_UNITY);
    EXPECT_EQ(u.rotation[KATA_BONE_LEFT_UPPER_ARM][1], -p.rotation[KATA_BONE_LEFT_UPPER_ARM][1]);
    const auto xu = forward(u, u.offset);
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      const Vec m = {-x[static_cast<size_t>(b)][0], x[static_cast<size_t>(b)][1], x[static_cast<size_t>(b)][2]};
      worst_mirror = std::max(worst_mirror, norm(sub(xu[static_cast<size_t>(b)], m)));
    }
  }
  std::printf("[ figures ] CMU 02_01, %zu frames: FK error %.3g m (pose offsets), %.3g m (rest offsets), Unity mirror %.3g m\n",
              c.raw.size(), worst, worst_rest, worst_mirror);
  EXPECT_LT(worst, 1e-4 * body);
  EXPECT_LT(worst_rest, 1e-4 * body);
  EXPECT_LT(worst_mirror, 1e-5 * body);
}

// The chosen twists: a bent elbow is a hinge about the forearm's local Y (bending forward), a bent
// knee a hinge about the shin's local X (bending back).
TEST(Humanoid, BentElbowsAndKneesAreHinges) {
  Clip c("02_01.bvh");
  Rig r;
  ASSERT_EQ(kata_humanoid_rig_create(c.ctx, c.skel, nullptr, &r.rig), KATA_OK) << kata_context_last_error(c.ctx);
  int elbows = 0, knees = 0;
  for (size_t f = 0; f < c.raw.size(); ++f) {
    kata_humanoid_pose p = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[f].data(), c.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_OK);
    for (int side = 0; side < 2; ++side) {
      const int upper = side ? KATA_BONE_RIGHT_UPPER_ARM : KATA_BONE_LEFT_UPPER_ARM;
      const Vec a = sub(c.at(f, side ? "RightForeArm" : "LeftForeArm"), c.at(f, side ? "RightArm" : "LeftArm"));
      const Vec b = sub(c.at(f, side ? "RightHand" : "LeftHand"), c.at(f, side ? "RightForeArm" : "LeftForeArm"));
      const double bend = std::atan2(norm(cross(a, b)), a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * kDegrees;
      if (bend > 25.0) {
        const float* q = p.rotation[upper + 1];
        EXPECT_LT(std::fabs(q[0]) + std::fabs(q[2]), 1e-4) << "frame " << f << " side " << side;
        // Left: +X turns toward +Z (a negative angle about Y); right: -X toward +Z (positive).
        EXPECT_GT(side ? q[1] : -q[1], 0.0f) << "frame " << f;
        ++elbows;
      }
      const int thigh = side ? KATA_BONE_RIGHT_UPPER_LEG : KATA_BONE_LEFT_UPPER_LEG;
      const Vec t = sub(c.at(f, side ? "RightLeg" : "LeftLeg"), c.at(f, side ? "RightUpLeg" : "LeftUpLeg"));
      const Vec s = sub(c.at(f, side ? "RightFoot" : "LeftFoot"), c.at(f, side ? "RightLeg" : "LeftLeg"));
      const double knee = std::atan2(norm(cross(t, s)), t[0] * s[0] + t[1] * s[1] + t[2] * s[2]) * kDegrees;
      if (knee > 25.0) {
        const float* q = p.rotation[thigh + 1];
        EXPECT_LT(std::fabs(q[1]) + std::fabs(q[2]), 1e-4) << "frame " << f << " side " << side;
        EXPECT_GT(q[0], 0.0f) << "frame " << f;  // -Y turns toward -Z: positive about X
        ++knees;
      }
    }
  }
  std::printf("[ figures ] hinge checks: %d bent elbows, %d bent knees\n", elbows, knees);
  EXPECT_GT(elbows, 20);
  EXPECT_GT(knees, 20);
}

// MediaPipe landmarks made from a CMU clip: FK over the pose's offsets puts every bone's joint on
// its landmark (or the documented synthesised joint); every bone whose both ends are given points
// along its rest direction exactly (the offset is the rest offset scaled).
TEST(Humanoid, MediaPipeLandmarksForwardKinematicsPutsEveryJointBack) {
  Clip c("07_01.bvh");
  kata_skeleton mp = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(c.ctx, "mediapipe", &mp), KATA_OK);
  kata_humanoid_desc d;
  kata_humanoid_desc_init(&d);
  d.layout = "mediapipe";
  Rig r;
  ASSERT_EQ(kata_humanoid_rig_create(c.ctx, mp, &d, &r.rig), KATA_OK) << kata_context_last_error(c.ctx);
  kata_skeleton_destroy(mp);
  EXPECT_EQ(kata_humanoid_rig_calibrated(r.rig), 0);
  EXPECT_EQ(kata_humanoid_rig_placed(r.rig), ((1u << KATA_BONE_COUNT) - 1) & ~(1u << KATA_BONE_UPPER_CHEST));
  EXPECT_EQ(kata_humanoid_rig_bone_source(r.rig, KATA_BONE_LEFT_UPPER_ARM), 11);
  EXPECT_EQ(kata_humanoid_rig_bone_source(r.rig, KATA_BONE_HIPS), -1);
  std::vector<float> frames;
  const size_t n = c.raw.size();
  for (size_t f = 0; f < 60; ++f) {
    const std::vector<float> lm = to_mediapipe(c, f);
    frames.insert(frames.end(), lm.begin(), lm.end());
  }
  ASSERT_EQ(kata_humanoid_rig_calibrate(r.rig, frames.data(), kLandmarks, 60), KATA_OK) << kata_humanoid_rig_last_error(r.rig);
  kata_humanoid_pose rest = new_pose();
  ASSERT_EQ(kata_humanoid_rig_rest_pose(r.rig, KATA_HUMANOID_RIGHT_HANDED, &rest), KATA_OK);
  double worst = 0, worst_direction = 0;
  for (size_t f = 0; f < n; ++f) {
    const std::vector<float> lm = to_mediapipe(c, f);
    kata_humanoid_pose p = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose(r.rig, lm.data(), kLandmarks, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_OK)
        << kata_humanoid_rig_last_error(r.rig);
    expect_unit_quaternions(p, f);
    const auto want = mediapipe_joints(lm);
    const auto x = forward(p, p.offset);
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      if (b == KATA_BONE_UPPER_CHEST) continue;
      worst = std::max(worst, norm(sub(x[static_cast<size_t>(b)], want[static_cast<size_t>(b)])));
      // The direction: every bone but the hips' branches (the hip joints) and those on their
      // parent's joint has its offset along the rest offset.
      const Vec o = {p.offset[b][0], p.offset[b][1], p.offset[b][2]};
      const Vec ro = {rest.offset[b][0], rest.offset[b][1], rest.offset[b][2]};
      if (b == KATA_BONE_HIPS || b == KATA_BONE_LEFT_UPPER_LEG || b == KATA_BONE_RIGHT_UPPER_LEG || norm(ro) == 0) continue;
      worst_direction = std::max(worst_direction, norm(cross(o, ro)) / (norm(o) * norm(ro)));
    }
  }
  std::printf("[ figures ] MediaPipe from CMU 07_01, %zu frames: FK error %.3g m, bone direction error %.3g rad\n",
              n, worst, worst_direction);
  EXPECT_LT(worst, 1e-4 * 1.7);
  EXPECT_LT(worst_direction, 1e-5);
}

// A stream's ghost on its own joints (a CMU student and another subject's CMU clip as teacher) and
// across layouts (a MediaPipe student): FK of the ghost's pose puts every bone's joint on the
// ghost joint it reads.
TEST(Humanoid, StreamGhostsForwardKinematicsPutsEveryJointBack) {
  Clip student("02_01.bvh");
  Clip teacher_clip("02_02.bvh");
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(student.ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "cmu";
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(student.ctx, student.skel, &sd, &s), KATA_OK) << kata_context_last_error(student.ctx);
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher_clip.clip;
  td.first_frame = 1;
  ASSERT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK) << kata_stream_last_error(s);
  Rig r;
  ASSERT_EQ(kata_humanoid_rig_create_for_stream(student.ctx, s, nullptr, &r.rig), KATA_OK)
      << kata_context_last_error(student.ctx);
  const uint32_t gj = kata_stream_ghost_joint_count(s);
  ASSERT_GT(gj, 16u);
  EXPECT_EQ(kata_humanoid_rig_ghost_joint_count(r.rig), gj);
  std::map<std::string, uint32_t> ghost_index;
  for (uint32_t i = 0; i < gj; ++i)
    ghost_index[kata_skeleton_joint_name(student.skel, static_cast<uint32_t>(kata_stream_ghost_joint_source(s, i)))] = i;
  std::vector<float> ghost(3 * gj);
  kata_result_record rec;
  rec.struct_size = sizeof rec;
  double worst = 0, worst_student = 0;
  int ghosts = 0;
  const double dt = 1.0 / 120.0;
  for (size_t f = 0; f < student.raw.size(); ++f) {
    ASSERT_EQ(kata_stream_push(s, f * dt, student.raw[f].data(), student.joints), KATA_OK);
    kata_humanoid_pose p = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose(r.rig, student.raw[f].data(), student.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_OK);
    const auto xs = forward(p, p.offset);
    for (int b = 0; b < KATA_BONE_COUNT; ++b)
      worst_student = std::max(worst_student, norm(sub(xs[static_cast<size_t>(b)], student.at(f, kCmuBoneJoint[b]))));
    if (kata_stream_read_newest(s, &rec, ghost.data(), ghost.size(), nullptr, 0) != KATA_OK || rec.ghost_joint_count == 0)
      continue;
    kata_humanoid_pose g = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose_ghost(r.rig, ghost.data(), gj, KATA_HUMANOID_RIGHT_HANDED, &g), KATA_OK)
        << kata_humanoid_rig_last_error(r.rig);
    expect_unit_quaternions(g, f);
    const auto x = forward(g, g.offset);
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      if (!(g.placed & (1u << b))) continue;
      const uint32_t i = ghost_index.at(kCmuBoneJoint[b] == std::string("Hips") ? "Hips" : kCmuBoneJoint[b]);
      const Vec want = {kMetresPerUnit * ghost[3 * i], kMetresPerUnit * ghost[3 * i + 1], kMetresPerUnit * ghost[3 * i + 2]};
      worst = std::max(worst, norm(sub(x[static_cast<size_t>(b)], want)));
    }
    ++ghosts;
  }
  std::printf("[ figures ] CMU 02_02 on 02_01: %d ghosts, ghost FK error %.3g m; student FK error %.3g m\n", ghosts,
              worst, worst_student);
  EXPECT_GT(ghosts, 100);
  EXPECT_LT(worst, 1e-4 * 1.7);
  EXPECT_LT(worst_student, 1e-4 * 1.7);
  kata_stream_destroy(s);
  kata_model_destroy(model);
}

TEST(Humanoid, MediaPipeStudentGhostAcrossLayouts) {
  Clip c("07_01.bvh");
  Clip teacher_clip("02_01.bvh");
  kata_model model = nullptr;
  ASSERT_EQ(kata_model_load(c.ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK);
  kata_skeleton mp = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(c.ctx, "mediapipe", &mp), KATA_OK);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "mediapipe";
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(c.ctx, mp, &sd, &s), KATA_OK) << kata_context_last_error(c.ctx);
  kata_skeleton_destroy(mp);
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher_clip.clip;
  td.first_frame = 1;
  td.ghost_across = 1;
  ASSERT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK) << kata_stream_last_error(s);
  Rig r;
  ASSERT_EQ(kata_humanoid_rig_create_for_stream(c.ctx, s, nullptr, &r.rig), KATA_OK) << kata_context_last_error(c.ctx);
  ASSERT_EQ(kata_humanoid_rig_ghost_joint_count(r.rig), 16u);
  std::vector<float> ghost(48);
  kata_result_record rec;
  rec.struct_size = sizeof rec;
  double worst = 0;
  int ghosts = 0;
  // GPD order: Hip Chest Neck Head LShoulder LElbow LHand RShoulder RElbow RHand LHip LKnee LFoot RHip RKnee RFoot.
  const int gpd_of_bone[KATA_BONE_COUNT] = {0, 0, 1, -1, 2, 3, 1, 4, 5, 6, 1, 7, 8, 9, 10, 11, 12, -1, 13, 14, 15, -1};
  for (size_t f = 0; f < c.raw.size(); ++f) {
    const std::vector<float> lm = to_mediapipe(c, f);
    ASSERT_EQ(kata_stream_push(s, f / 120.0, lm.data(), kLandmarks), KATA_OK) << kata_stream_last_error(s);
    if (kata_stream_read_newest(s, &rec, ghost.data(), ghost.size(), nullptr, 0) != KATA_OK || rec.ghost_joint_count == 0)
      continue;
    kata_humanoid_pose g = new_pose();
    ASSERT_EQ(kata_humanoid_rig_pose_ghost(r.rig, ghost.data(), 16, KATA_HUMANOID_UNITY, &g), KATA_OK)
        << kata_humanoid_rig_last_error(r.rig);
    expect_unit_quaternions(g, f);
    const auto x = forward(g, g.offset);
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      if (gpd_of_bone[b] < 0) {
        EXPECT_FALSE(g.placed & (1u << b)) << b;
        continue;
      }
      const int j = gpd_of_bone[b];
      // Camera axes to Y-up (x, -y, -z), then Unity's mirror (-x).
      const Vec want = {-ghost[static_cast<size_t>(3 * j)], -ghost[static_cast<size_t>(3 * j + 1)], -ghost[static_cast<size_t>(3 * j + 2)]};
      worst = std::max(worst, norm(sub(x[static_cast<size_t>(b)], want)));
    }
    ++ghosts;
  }
  std::printf("[ figures ] CMU 02_01 across onto MediaPipe 07_01: %d ghosts, FK error (Unity frame) %.3g m\n", ghosts, worst);
  EXPECT_GT(ghosts, 100);
  EXPECT_LT(worst, 1e-4 * 1.7);
  kata_stream_destroy(s);
  kata_model_destroy(model);
}

// Degenerate and hostile input: no NaN from any finite frame, refusals leave the rig usable,
// and a pose allocates nothing.
TEST(Humanoid, DegenerateFramesGiveIdentityNotNaN) {
  Clip c("02_01.bvh");
  Rig r;
  ASSERT_EQ(kata_humanoid_rig_create(c.ctx, c.skel, nullptr, &r.rig), KATA_OK);
  std::vector<float> zero(3 * c.joints, 0.0f), huge = c.raw[10];
  kata_humanoid_pose p = new_pose();
  ASSERT_EQ(kata_humanoid_rig_pose(r.rig, zero.data(), c.joints, KATA_HUMANOID_UNITY, &p), KATA_OK);
  EXPECT_NE(p.degenerate, 0u);
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    EXPECT_EQ(p.rotation[b][3], 1.0f) << b;
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::isfinite(p.offset[b][k]));
  }
  // Every joint on one point but the hands, far away: finite.
  for (uint32_t j = 0; j < c.joints; ++j)
    for (int k = 0; k < 3; ++k) huge[3 * j + k] = j % 5 == 0 ? 1e9f : (j % 3 == 0 ? -1e9f : 3.0f);
  ASSERT_EQ(kata_humanoid_rig_pose(r.rig, huge.data(), c.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_OK);
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    for (int k = 0; k < 4; ++k) EXPECT_TRUE(std::isfinite(p.rotation[b][k])) << b;
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::isfinite(p.offset[b][k])) << b;
  }
  std::vector<float> bad = c.raw[3];
  bad[3 * static_cast<size_t>(c.index.at("LeftForeArm")) + 1] = NAN;
  EXPECT_EQ(kata_humanoid_rig_pose(r.rig, bad.data(), c.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_E_NON_FINITE);
  EXPECT_NE(std::string(kata_humanoid_rig_last_error(r.rig)).find("LeftForeArm"), std::string::npos);
  bad[3 * static_cast<size_t>(c.index.at("LeftForeArm")) + 1] = 2e9f;
  EXPECT_EQ(kata_humanoid_rig_pose(r.rig, bad.data(), c.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[3].data(), c.joints - 1, KATA_HUMANOID_RIGHT_HANDED, &p),
            KATA_E_WRONG_JOINT_COUNT);
  EXPECT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[3].data(), c.joints, 7, &p), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_humanoid_rig_pose_ghost(r.rig, c.raw[3].data(), c.joints, 0, &p), KATA_E_STATE);
  kata_humanoid_pose small = new_pose();
  small.struct_size = 8;
  EXPECT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[3].data(), c.joints, 0, &small), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[3].data(), c.joints, KATA_HUMANOID_RIGHT_HANDED, &p), KATA_OK);
  EXPECT_EQ(p.degenerate, 0u);
  // Unknown layout: refused on the context.
  kata_humanoid_desc d;
  kata_humanoid_desc_init(&d);
  d.layout = "no-such-layout";
  kata_humanoid_rig other = nullptr;
  EXPECT_EQ(kata_humanoid_rig_create(c.ctx, c.skel, &d, &other), KATA_E_NOT_FOUND);
  EXPECT_EQ(other, nullptr);
  d.layout = "cmu";
  d.metres_per_unit = -1;
  EXPECT_EQ(kata_humanoid_rig_create(c.ctx, c.skel, &d, &other), KATA_E_INVALID_ARGUMENT);
  // The per-frame call allocates nothing.
  if (kata::test::kAllocCounting) {
    kata::test::arm_alloc_counter();
    for (size_t f = 0; f < 50; ++f)
      ASSERT_EQ(kata_humanoid_rig_pose(r.rig, c.raw[f].data(), c.joints, KATA_HUMANOID_UNITY, &p), KATA_OK);
    EXPECT_EQ(kata::test::disarm_alloc_counter(), 0);
  }
}
