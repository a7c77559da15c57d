// kata::humanoid::Rig from the inside: the rotations are the body's own (a frame turned as a whole
// turns only the hips), the rest is the skeleton's, and random finite frames, coincident and
// collinear points included, give unit quaternions and finite offsets, never a NaN.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "humanoid/rig.hpp"
#include "support/clips.hpp"

namespace {

using kata::humanoid::Pose;
using kata::humanoid::Points;
using kata::humanoid::Rig;

Rig cmu_rig() {
  const kata::BvhClip& c = kata::test::clip("02_01");
  const auto map = kata::make_gpd_map(c.skeleton, kata::preset_joint_names("cmu"));
  return Rig(kata::humanoid::make_mapping(c.skeleton, map, "cmu", kata::UpAxis::kY, 0.056444));
}

Eigen::Quaterniond quat(const Eigen::Vector4d& v) { return Eigen::Quaterniond(v[3], v[0], v[1], v[2]); }

}  // namespace

TEST(HumanoidRig, TurningTheWholeFrameTurnsOnlyTheHips) {
  Rig rig = cmu_rig();
  const kata::BvhClip& c = kata::test::clip("02_01");
  const std::vector<float>& frames = kata::test::clip_positions("02_01");
  const int joints = c.skeleton.joint_count();
  Points rest;
  rig.points(frames.data(), rest);
  rig.measure(&rest, 1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<float> turned(static_cast<size_t>(3 * joints));
  for (int f = 0; f < 300; f += 7) {
    const float* xyz = frames.data() + static_cast<size_t>(3 * joints * f);
    const Eigen::Quaterniond q =
        Eigen::Quaterniond(Eigen::AngleAxisd(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()));
    const Eigen::Vector3d shift(u(rng), u(rng), u(rng));
    for (int j = 0; j < joints; ++j) {
      const Eigen::Vector3d p = q * Eigen::Vector3d(xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]) + shift;
      for (int k = 0; k < 3; ++k) turned[static_cast<size_t>(3 * j + k)] = static_cast<float>(p[k]);
    }
    Points a, b;
    rig.points(xyz, a);
    rig.points(turned.data(), b);
    Pose pa, pb;
    rig.pose(a, pa);
    rig.pose(b, pb);
    // The hips: q times the original; every other bone's local rotation and offset unchanged.
    EXPECT_LT(quat(pb.rotation[0]).angularDistance(q * quat(pa.rotation[0])), 2e-5) << f;
    for (int bone = 1; bone < kata::humanoid::kBoneCount; ++bone) {
      EXPECT_LT(quat(pb.rotation[static_cast<size_t>(bone)]).angularDistance(quat(pa.rotation[static_cast<size_t>(bone)])), 2e-5)
          << "frame " << f << " bone " << kata::humanoid::kBoneNames[static_cast<size_t>(bone)];
      EXPECT_LT((pb.offset[static_cast<size_t>(bone)] - pa.offset[static_cast<size_t>(bone)]).norm(), 1e-5);
    }
  }
}

TEST(HumanoidRig, RandomFiniteFramesNeverGiveANaN) {
  Rig rig = cmu_rig();
  const int joints = kata::test::clip("02_01").skeleton.joint_count();
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1000.0f, 1000.0f);
  std::uniform_int_distribution<int> pick(0, joints - 1), kind(0, 3);
  std::vector<float> xyz(static_cast<size_t>(3 * joints));
  Points pts;
  Pose p;
  for (int trial = 0; trial < 20000; ++trial) {
    for (float& v : xyz) v = u(rng);
    // Coincident, collinear and zero points, and a flattened axis.
    const int k = kind(rng);
    for (int n = 0; n < joints / 2; ++n) {
      const size_t a = static_cast<size_t>(3 * pick(rng)), b = static_cast<size_t>(3 * pick(rng));
      for (size_t c = 0; c < 3; ++c) {
        if (k == 0) xyz[a + c] = xyz[b + c];
        if (k == 1) xyz[a + c] = 0.0f;
        if (k == 2) xyz[a + c] = 2.0f * xyz[b + c];
      }
      if (k == 3) xyz[a + 1] = 0.0f;
    }
    if (trial == 0) std::fill(xyz.begin(), xyz.end(), 0.0f);
    rig.points(xyz.data(), pts);
    if (!rig.measured() && rig.complete(pts)) rig.measure(&pts, 1);
    rig.pose(pts, p);
    for (int b = 0; b < kata::humanoid::kBoneCount; ++b) {
      const auto& q = p.rotation[static_cast<size_t>(b)];
      ASSERT_TRUE(q.allFinite() && p.offset[static_cast<size_t>(b)].allFinite()) << trial << " " << b;
      ASSERT_NEAR(q.norm(), 1.0, 1e-9) << trial << " " << b;
    }
  }
}
