// BVH motion for a retargeted ghost: per-joint rotations on the student's own BVH hierarchy whose
// forward kinematics reproduces the ghost's joint positions, so a BVH viewer (Blender) can play
// the ghost. Each joint keeps the teacher's global rotation (so twist about a bone, the head's and
// the hands' orientation follow the teacher) composed with the smallest rotation (a swing) that
// turns its child bone onto the ghost's bone direction.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "io/bvh.hpp"
#include "retarget/joint_set.hpp"

namespace kata::retarget {

// Turns ghost positions (on a "cmu"-preset joint selection) into motion rows of the student's
// hierarchy. Requires: teacher and student clips with the same hierarchy and channel layout,
// three rotation channels per joint, and every joint outside the selection sitting on its parent
// (zero offset), as for the CMU conversion. A joint with one moving child (every joint of the
// CMU hierarchy) reproduces the ghost exactly; one with several (not in CMU) gets the
// least-squares rotation over its children, exact only when the ghost keeps their rest angles.
// Buffers sized at construction.
class GhostBvh {
 public:
  // Throws kata::Error(kInvalidArgument) when the requirements above do not hold.
  GhostBvh(const BvhClip& teacher, const BvhClip& student, const JointSelection& selection);
  // One motion row (student.channel_count values) for teacher frame `frame` whose FK puts every
  // selected joint on `ghost` (selected joints x 3, row-major, the student's units). Angles are
  // kept continuous with the previous call's (no +-360 degree or Euler-branch jumps).
  void motion_row(const BvhClip& teacher, int frame, const double* ghost, double* row);

 private:
  int n_;                                  // student joints
  std::vector<int> selected_of_;           // student joint -> selection index whose position it has
  std::vector<std::vector<int>> movers_;   // per joint: children with a non-zero offset
  std::vector<Eigen::Vector3d> offsets_;   // student rest offsets
  std::vector<std::vector<Channel>> channels_;
  std::vector<int> channel_offset_;
  std::vector<Eigen::Matrix3d> teacher_global_, global_;
  std::vector<Eigen::Vector3d> position_;  // ghost position of every student joint
  std::vector<double> previous_;           // previous row, for angle continuity
  bool has_previous_ = false;
};

}  // namespace kata::retarget
