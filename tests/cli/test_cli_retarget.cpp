// `kata retarget` as a user runs it: a teacher clip onto another subject's body, written as
// .npy positions (frames, joints, 3) whose bones have the student's lengths, and as a BVH on the
// student's hierarchy whose forward kinematics gives the same positions.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "io/bvh.hpp"
#include "io/npy.hpp"

namespace {

int run_cli(const std::string& args) {
  const std::string cmd = std::string(KATA_CLI) + " " + args + " >/dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(CliRetarget, GhostHasTheStudentsBonesAndItsBvhReplaysIt) {
  const std::string data = std::string(KATA_DATA_DIR) + "/cmu/";
  const std::string npy = kata::test::temp_path("kata_ghost.npy"), bvh = kata::test::temp_path("kata_ghost.bvh");
  const std::string common = "retarget --teacher " + data + "05_03.bvh --student " + data + "02_01.bvh --preset cmu";
  ASSERT_EQ(run_cli(common + " --out " + npy), 0);
  ASSERT_EQ(run_cli(common + " --out " + bvh), 0);

  const kata::BvhClip teacher = kata::load_bvh(data + "05_03.bvh");
  const kata::BvhClip student = kata::load_bvh(data + "02_01.bvh");
  // The 21 joints that carry a bone in the CMU conversion: every joint with a non-zero offset, plus the root.
  std::vector<int> joints;
  for (int j = 0; j < student.skeleton.joint_count(); ++j)
    if (j == 0 || student.skeleton.offsets[j].norm() > 0) joints.push_back(j);
  ASSERT_EQ(joints.size(), 21u);

  std::vector<size_t> shape;
  const std::vector<double> ghost = kata::read_npy(npy, &shape);
  ASSERT_EQ(shape, (std::vector<size_t>{static_cast<size_t>(teacher.frame_count()), 21, 3}));

  // Bones: each kept joint's nearest kept ancestor; its rest distance in the student skeleton is
  // the length of the summed offsets in between (zero-offset joints add nothing).
  const Eigen::MatrixX3d rest = kata::rest_positions(student.skeleton);
  double worst = 0.0;
  for (size_t k = 1; k < joints.size(); ++k) {
    int a = student.skeleton.parents[joints[k]];
    while (a != 0 && student.skeleton.offsets[a].norm() == 0) a = student.skeleton.parents[a];
    const size_t pk = static_cast<size_t>(std::find(joints.begin(), joints.end(), a) - joints.begin());
    ASSERT_LT(pk, joints.size());
    const double want = (rest.row(joints[k]) - rest.row(a)).norm();
    for (int f = 0; f < teacher.frame_count(); ++f) {
      const double* p = ghost.data() + static_cast<size_t>(f) * 63;
      const double got = std::sqrt(std::pow(p[3 * k] - p[3 * pk], 2) + std::pow(p[3 * k + 1] - p[3 * pk + 1], 2) +
                                   std::pow(p[3 * k + 2] - p[3 * pk + 2], 2));
      worst = std::max(worst, std::fabs(got - want) / want);
    }
  }
  EXPECT_LT(worst, 0.005) << "every bone within 0.5% of the student's length on every frame";

  // The BVH is on the student's hierarchy and replays the same positions.
  const kata::BvhClip g = kata::load_bvh(bvh);
  ASSERT_EQ(g.frame_count(), teacher.frame_count());
  ASSERT_EQ(g.skeleton.names, student.skeleton.names);
  Eigen::MatrixX3d w(g.skeleton.joint_count(), 3);
  double max_diff = 0.0;
  for (int f = 0; f < g.frame_count(); ++f) {
    kata::world_positions(g, f, w);
    for (size_t k = 0; k < joints.size(); ++k)
      for (int c = 0; c < 3; ++c)
        max_diff = std::max(max_diff, std::fabs(w(joints[k], c) - ghost[static_cast<size_t>(f) * 63 + 3 * k + c]));
  }
  EXPECT_LT(max_diff, 1e-3) << "file units (CMU: 5.6 cm); the BVH stores 6 decimals or more";
  std::remove(npy.c_str());
  std::remove(bvh.c_str());
}

}  // namespace
