// The ghost as local rotations on the student's hierarchy, through the C ABI:
// forward kinematics computed here, from the quaternions and kata_skeleton_joint_offset, must put
// every ghost joint back on the ghost. On a CMU student (a real retarget of another subject's
// clip) and on a game-style rig whose hips and chest carry several bones each.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "kata/kata.h"

namespace {

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

// Forward kinematics of local rotations (x, y, z, w per joint) and a root position.
std::vector<Vec> forward(kata_skeleton skel, const std::vector<float>& rotations, const float* root) {
  const uint32_t n = kata_skeleton_joint_count(skel);
  std::vector<Quat> global(n);
  std::vector<Vec> pos(n);
  for (uint32_t j = 0; j < n; ++j) {
    const Quat local = {rotations[4 * j], rotations[4 * j + 1], rotations[4 * j + 2], rotations[4 * j + 3]};
    const int p = kata_skeleton_joint_parent(skel, j);
    if (p < 0) {
      global[j] = local;
      pos[j] = {root[0], root[1], root[2]};
      continue;
    }
    double offset[3];
    EXPECT_EQ(kata_skeleton_joint_offset(skel, j, offset), KATA_OK);
    const Vec o = rotate(global[static_cast<size_t>(p)], {offset[0], offset[1], offset[2]});
    pos[j] = {pos[static_cast<size_t>(p)][0] + o[0], pos[static_cast<size_t>(p)][1] + o[1], pos[static_cast<size_t>(p)][2] + o[2]};
    global[j] = mul(global[static_cast<size_t>(p)], local);
  }
  return pos;
}

// Random local rotations (x, y, z, w): a random axis, an angle up to +-max_root for the root and
// +-max_joint (radians) for the other joints.
std::vector<float> random_rotations(std::mt19937& rng, uint32_t n, double max_root, double max_joint) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<float> rotations(4 * n);
  for (uint32_t j = 0; j < n; ++j) {
    Vec axis = {unit(rng), unit(rng), unit(rng)};
    const double len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    const double angle = (j == 0 ? max_root : max_joint) * unit(rng);
    for (int k = 0; k < 3; ++k) rotations[4 * j + k] = static_cast<float>(std::sin(angle / 2) * axis[k] / len);
    rotations[4 * j + 3] = static_cast<float>(std::cos(angle / 2));
  }
  return rotations;
}

// Largest distance between each ghost joint and the FK position of the joint it stands for.
double fk_error(kata_retargeter rt, kata_skeleton skel, const std::vector<float>& ghost, std::vector<float>* fk_out,
                double* residual) {
  const uint32_t n = kata_retargeter_rotation_joint_count(rt);
  std::vector<float> rotations(4 * n), positions(3 * n);
  float root[3];
  EXPECT_EQ(kata_retargeter_local_rotations(rt, ghost.data(), ghost.size(), rotations.data(), rotations.size(), root,
                                            positions.data(), positions.size(), residual),
            KATA_OK)
      << kata_retargeter_last_error(rt);
  for (uint32_t j = 0; j < n; ++j) {
    const double norm = std::sqrt(rotations[4 * j] * rotations[4 * j] + rotations[4 * j + 1] * rotations[4 * j + 1] +
                                  rotations[4 * j + 2] * rotations[4 * j + 2] + rotations[4 * j + 3] * rotations[4 * j + 3]);
    EXPECT_NEAR(norm, 1.0, 1e-5);
    EXPECT_GE(rotations[4 * j + 3], 0.0f);
  }
  const std::vector<Vec> fk = forward(skel, rotations, root);
  if (fk_out) *fk_out = positions;
  double worst = 0;
  for (uint32_t i = 0; i < kata_retargeter_joint_count(rt); ++i) {
    const int s = kata_retargeter_joint_source(rt, i);
    const Vec& p = fk[static_cast<size_t>(s)];
    const double d = std::sqrt(std::pow(p[0] - ghost[3 * i], 2) + std::pow(p[1] - ghost[3 * i + 1], 2) +
                               std::pow(p[2] - ghost[3 * i + 2], 2));
    worst = std::max(worst, d);
    // The library's own FK positions agree with ours.
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(positions[3 * static_cast<size_t>(s) + k], p[k], 1e-3);
  }
  return worst;
}

// Body height of a skeleton's rest pose (the GPD H) through a stream with the given preset.
double body_height(kata_context ctx, kata_skeleton skel, const char* preset) {
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = preset;
  kata_stream s = nullptr;
  EXPECT_EQ(kata_stream_open(ctx, skel, &d, &s), KATA_OK) << kata_context_last_error(ctx);
  const double h = kata_stream_body_height(s);
  kata_stream_destroy(s);
  return h;
}

TEST(LocalRotations, CmuTeacherOnACmuStudentReproducesTheGhostThroughFk) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip teacher = nullptr, student_clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &teacher), KATA_OK);
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student_clip), KATA_OK);
  kata_skeleton student = nullptr;
  ASSERT_EQ(kata_clip_skeleton(student_clip, &student), KATA_OK);
  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create(ctx, student, nullptr, &rt), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_retargeter_rotation_joint_count(rt), kata_skeleton_joint_count(student));
  const double height = body_height(ctx, student, "cmu");
  const uint32_t tn = kata_skeleton_joint_count(student);
  std::vector<float> frame(3 * tn), ghost(3 * kata_retargeter_joint_count(rt));
  double worst = 0, worst_residual = 0;
  for (uint32_t f = 1; f < kata_clip_frame_count(teacher); f += 3) {
    ASSERT_EQ(kata_clip_positions(teacher, f, frame.data(), frame.size()), KATA_OK);
    ASSERT_EQ(kata_retargeter_solve(rt, frame.data(), tn, ghost.data(), ghost.size(), nullptr), KATA_OK);
    double residual = -1;
    worst = std::max(worst, fk_error(rt, student, ghost, nullptr, &residual));
    worst_residual = std::max(worst_residual, residual);
  }
  std::printf("[ figures ] CMU 02_01 on 07_01 (31 joints, 21 ghost joints): FK of the rotations vs the ghost, worst "
              "%.3g body heights (library residual %.3g)\n",
              worst / height, worst_residual / height);
  EXPECT_LT(worst, 1e-4 * height);
  EXPECT_LT(worst_residual, 1e-4 * height);

  // No rest pose, no rotations: a state error, nothing written.
  kata_skeleton bare = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(ctx, "gpd", &bare), KATA_OK);
  double offset[3];
  EXPECT_EQ(kata_skeleton_joint_offset(bare, 1, offset), KATA_E_STATE);
  EXPECT_EQ(kata_skeleton_joint_offset(student, 999, offset), KATA_E_INVALID_ARGUMENT);
  std::vector<float> rotations(4 * tn);
  float root[3];
  EXPECT_EQ(kata_retargeter_local_rotations(rt, ghost.data(), ghost.size() - 3, rotations.data(), rotations.size(),
                                            root, nullptr, 0, nullptr),
            KATA_E_WRONG_JOINT_COUNT);
  EXPECT_EQ(kata_retargeter_local_rotations(rt, ghost.data(), ghost.size(), rotations.data(), rotations.size() - 1,
                                            root, nullptr, 0, nullptr),
            KATA_E_BUFFER_TOO_SMALL);
  ghost[4] = NAN;
  EXPECT_EQ(kata_retargeter_local_rotations(rt, ghost.data(), ghost.size(), rotations.data(), rotations.size(), root,
                                            nullptr, 0, nullptr),
            KATA_E_NON_FINITE);
  kata_skeleton_destroy(bare);
  kata_retargeter_destroy(rt);
  kata_skeleton_destroy(student);
  kata_clip_destroy(student_clip);
  kata_clip_destroy(teacher);
  kata_context_destroy(ctx);
}

// A game-engine style rig (metres, Y-up): the hips carry the spine and both legs, the chest the
// neck and both arms, each as a bone of its own (no zero-offset joints), plus toes and hand ends
// outside any GPD joint.
struct Rig {
  std::vector<std::string> names = {"Hips",     "Spine",       "Chest",     "Neck",      "Head",
                                    "LeftArm",  "LeftForeArm", "LeftHand",  "RightArm",  "RightForeArm",
                                    "RightHand", "LeftUpLeg",  "LeftLeg",   "LeftFoot",  "LeftToe",
                                    "RightUpLeg", "RightLeg",  "RightFoot", "RightToe"};
  std::vector<int32_t> parents = {-1, 0, 1, 2, 3, 2, 5, 6, 2, 8, 9, 0, 11, 12, 13, 0, 15, 16, 17};
  std::vector<double> offsets = {0, 0.95, 0,    0, 0.12, 0.01, 0, 0.25, -0.02, 0, 0.14, 0,    0, 0.14, 0.01,
                                 0.17, 0.1, 0,  0.27, 0, 0,    0.25, 0, 0,    -0.17, 0.1, 0, -0.27, 0, 0,
                                 -0.25, 0, 0,   0.09, -0.06, 0, 0, -0.42, 0.01, 0, -0.41, -0.02, 0, -0.06, 0.13,
                                 -0.09, -0.06, 0, 0, -0.42, 0.01, 0, -0.41, -0.02, 0, -0.06, 0.13};
};

TEST(LocalRotations, GameRigWithBranchingHipsAndChestIsReproducedExactlyWhenReachable) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  Rig rig;
  std::vector<const char*> names;
  for (const std::string& n : rig.names) names.push_back(n.c_str());
  const uint32_t n = static_cast<uint32_t>(names.size());
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_skeleton_create(ctx, n, names.data(), rig.parents.data(), rig.offsets.data(), &skel), KATA_OK)
      << kata_context_last_error(ctx);
  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create(ctx, skel, nullptr, &rt), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_retargeter_joint_count(rt), n) << "every joint of the rig carries a bone";
  const char* map = "Hip = Hips\nChest = Chest\nNeck = Neck\nHead = Head\nLShoulder = LeftArm\nLElbow = LeftForeArm\n"
                    "LHand = LeftHand\nRShoulder = RightArm\nRElbow = RightForeArm\nRHand = RightHand\n"
                    "LHip = LeftUpLeg\nLKnee = LeftLeg\nLFoot = LeftFoot\nRHip = RightUpLeg\nRKnee = RightLeg\n"
                    "RFoot = RightFoot\n";
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open_name_map(ctx, skel, &d, map, &s), KATA_OK) << kata_context_last_error(ctx);
  const double height = kata_stream_body_height(s);
  kata_stream_destroy(s);

  // Reachable ghosts: the rig's own FK of random local rotations (up to 60 degrees per joint) and
  // a random root position. The solver must find rotations putting every joint back, including
  // the branching hips and chest.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  double worst = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const std::vector<float> rotations = random_rotations(rng, n, 3.14159, 1.0472);
    const float root[3] = {static_cast<float>(unit(rng)), static_cast<float>(0.9 + 0.1 * unit(rng)),
                           static_cast<float>(unit(rng))};
    const std::vector<Vec> fk = forward(skel, rotations, root);
    std::vector<float> ghost(3 * n);
    for (uint32_t i = 0; i < n; ++i) {
      const int src = kata_retargeter_joint_source(rt, i);
      for (int k = 0; k < 3; ++k) ghost[3 * i + k] = static_cast<float>(fk[static_cast<size_t>(src)][k]);
    }
    double residual = -1;
    worst = std::max(worst, fk_error(rt, skel, ghost, nullptr, &residual));
  }
  std::printf("[ figures ] game rig (19 joints, hips and chest with 3 bones each), 50 random reachable poses: FK of "
              "the solved rotations vs the pose, worst %.3g body heights\n",
              worst / height);
  EXPECT_LT(worst, 1e-4 * height);

  // A real retarget onto the rig: teacher poses of another build (legs 1.2x, arms 0.85x, wider
  // hips) through the retargeter. The ghost's hips and chest need not keep the rig's rest angles,
  // so rotations reproduce it only as closely as a rigid hip/chest can (the residual).
  std::vector<double> other = rig.offsets;
  for (uint32_t j = 1; j < n; ++j) {
    const double scale = (j >= 11) ? 1.2 : (j >= 5 ? 0.85 : 1.0);
    for (int k = 0; k < 3; ++k) other[3 * j + k] *= scale;
  }
  other[3 * 11] *= 1.3;
  other[3 * 15] *= 1.3;
  kata_skeleton teacher = nullptr;
  ASSERT_EQ(kata_skeleton_create(ctx, n, names.data(), rig.parents.data(), other.data(), &teacher), KATA_OK);
  double worst_residual = 0, worst_fk = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const std::vector<float> rotations = random_rotations(rng, n, 0.6, 0.6);
    const float root[3] = {0.0f, 1.0f, 0.0f};
    const std::vector<Vec> pose = forward(teacher, rotations, root);
    std::vector<float> frame(3 * n), ghost(3 * n);
    for (uint32_t j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) frame[3 * j + k] = static_cast<float>(pose[j][k]);
    ASSERT_EQ(kata_retargeter_solve(rt, frame.data(), n, ghost.data(), ghost.size(), nullptr), KATA_OK);
    double residual = -1;
    const double e = fk_error(rt, skel, ghost, nullptr, &residual);
    EXPECT_NEAR(e, residual, 1e-5 * height) << "the library's residual is the FK error measured here";
    worst_fk = std::max(worst_fk, e);
    worst_residual = std::max(worst_residual, residual);
  }
  std::printf("[ figures ] retargeted ghosts on the game rig (another build's poses, 50): FK vs ghost worst %.3g body "
              "heights (the ghost's hips/chest off the rig's rest angles)\n",
              worst_fk / height);
  EXPECT_LT(worst_fk, 0.05 * height);
  kata_skeleton_destroy(teacher);
  kata_retargeter_destroy(rt);
  kata_skeleton_destroy(skel);
  kata_context_destroy(ctx);
}

}  // namespace
