// A ghost as local rotations on the student's own hierarchy (what a game engine animates): for any
// skeleton with a rest pose, per joint the rotation relative to its parent and the root's
// position, whose forward kinematics
//   G_root = L_root, X_root = root position;  G_j = G_parent(j) L_j,
//   X_j = X_parent(j) + G_parent(j) offset_j
// puts the ghost's joints on the ghost's positions.
//
// How each joint's rotation is chosen (top-down, so X_j is known when j is reached): its
// "aims" are, for every child c with a bone (non-zero rest offset), the first ghost joint at or
// below c, and, through children sitting on j (zero offset, e.g. CMU's LHipJoint on Hips), those
// children's aims. One aim: the smallest rotation (a swing, added to the parent's orientation)
// turning the rest direction onto the ghost's direction; several: the proper rotation best
// turning them all (Kabsch, least squares). No aim (a leaf): the parent's orientation.
// Exactness: a joint whose bones are all ghost joints and that carries one bone (every joint of a
// CMU hierarchy: branches go through zero-offset joints) is reproduced exactly, since the ghost
// keeps the student's bone lengths. Where one joint carries several bones (a game rig's Hips with
// Spine and both UpLegs), a rotation moves them rigidly: they are reproduced exactly when the
// ghost keeps their rest angles, else as closely as a rotation can (residual() says how far).
// Joints with a bone outside the ghost (e.g. CMU's Spine under the "gpd" joint set) are aimed
// through their rest chain: approximate.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "skeleton/skeleton.hpp"

namespace kata::retarget {

class LocalRotations {
 public:
  // skeleton: the student's, with a rest pose. ghost_source[i]: the skeleton joint ghost joint i
  // stands for (-1: none, e.g. a synthesised GPD joint). Throws kata::Error(kInvalidArgument)
  // without a rest pose or with an index outside the skeleton. Buffers sized here.
  LocalRotations(const Skeleton& skeleton, const std::vector<int>& ghost_source);

  int joint_count() const { return n_; }
  int ghost_joint_count() const { return static_cast<int>(ghost_source_.size()); }

  // ghost: ghost joints x 3 (the skeleton's units and axes). Writes local rotations as unit
  // quaternions (x, y, z, w) per skeleton joint (joints x 4; the root's is its world rotation),
  // the root's position (3) and, when positions is not null, every joint's FK position (joints x
  // 3). Non-finite ghost values give non-finite output: the caller checks its input. No
  // allocation.
  void solve(const double* ghost, double* rotations, double* root_position, double* positions);

  // After solve(): the largest distance between a ghost joint and its FK position.
  double residual() const { return residual_; }

 private:
  struct Aim {
    Eigen::Vector3d rest;  // rest vector from the aiming joint to the target (rest pose, world axes)
    int ghost = -1;        // ghost joint index
  };
  int n_;
  std::vector<int> parents_;
  std::vector<Eigen::Vector3d> offsets_;
  std::vector<int> ghost_source_;
  std::vector<int> ghost_of_;            // skeleton joint -> ghost index or -1
  std::vector<std::vector<Aim>> aims_;   // per skeleton joint
  std::vector<Eigen::Matrix3d> global_;  // scratch
  std::vector<Eigen::Vector3d> position_;
  double residual_ = 0.0;
};

}  // namespace kata::retarget
