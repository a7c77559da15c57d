// Ghost positions -> local rotations on the student's hierarchy (see local_rotations.hpp).
#include "retarget/local_rotations.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "common/error.hpp"

namespace kata::retarget {

LocalRotations::LocalRotations(const Skeleton& skeleton, const std::vector<int>& ghost_source)
    : n_(skeleton.joint_count()),
      parents_(skeleton.parents),
      offsets_(skeleton.offsets),
      ghost_source_(ghost_source),
      ghost_of_(static_cast<size_t>(n_), -1),
      aims_(static_cast<size_t>(n_)),
      global_(static_cast<size_t>(n_)),
      position_(static_cast<size_t>(n_)) {
  if (!skeleton.has_rest_pose)
    throw Error(ErrorKind::kInvalidArgument,
                "local rotations: the student skeleton has no rest pose (rotations need its rest offsets)");
  for (size_t i = 0; i < ghost_source_.size(); ++i) {
    const int s = ghost_source_[i];
    if (s < -1 || s >= n_)
      throw Error(ErrorKind::kInvalidArgument, "local rotations: ghost joint " + std::to_string(i) +
                                                   " stands for joint " + std::to_string(s) + ", outside the skeleton");
    if (s >= 0 && ghost_of_[static_cast<size_t>(s)] < 0) ghost_of_[static_cast<size_t>(s)] = static_cast<int>(i);
  }
  const Eigen::MatrixX3d rest = rest_positions(skeleton);
  double longest = 0.0;
  for (int j = 1; j < n_; ++j) longest = std::max(longest, offsets_[static_cast<size_t>(j)].norm());
  auto has_bone = [&](int j) { return offsets_[static_cast<size_t>(j)].norm() > 1e-6 * longest; };
  std::vector<std::vector<int>> children(static_cast<size_t>(n_));
  for (int j = 1; j < n_; ++j) children[static_cast<size_t>(parents_[static_cast<size_t>(j)])].push_back(j);

  // The first ghost joint at or below c (depth first, children in order), or -1.
  auto first_ghost_below = [&](int c, auto&& self) -> int {
    if (ghost_of_[static_cast<size_t>(c)] >= 0) return c;
    for (int k : children[static_cast<size_t>(c)]) {
      const int d = self(k, self);
      if (d >= 0) return d;
    }
    return -1;
  };
  // Joint j's aims through child c: a bone aims at its first ghost joint; a child sitting on j
  // passes its own children's aims up.
  auto collect = [&](int j, int c, auto&& self) -> void {
    if (has_bone(c)) {
      const int d = first_ghost_below(c, first_ghost_below);
      if (d >= 0) aims_[static_cast<size_t>(j)].push_back({(rest.row(d) - rest.row(j)).transpose(), ghost_of_[static_cast<size_t>(d)]});
      return;
    }
    for (int k : children[static_cast<size_t>(c)]) self(j, k, self);
  };
  for (int j = 0; j < n_; ++j)
    for (int c : children[static_cast<size_t>(j)]) collect(j, c, collect);
}

void LocalRotations::solve(const double* ghost, double* rotations, double* root_position, double* positions) {
  auto target = [ghost](int g) { return Eigen::Vector3d(ghost[3 * g], ghost[3 * g + 1], ghost[3 * g + 2]); };
  for (int j = 0; j < n_; ++j) {
    const size_t js = static_cast<size_t>(j);
    const int p = parents_[js];
    const Eigen::Matrix3d base = p < 0 ? Eigen::Matrix3d::Identity() : global_[static_cast<size_t>(p)];
    if (p < 0) {
      // The root stands on its ghost joint; without one, at its rest position.
      position_[js] = ghost_of_[js] >= 0 ? target(ghost_of_[js]) : offsets_[js];
    } else {
      position_[js] = position_[static_cast<size_t>(p)] + base * offsets_[js];
    }
    const std::vector<Aim>& aims = aims_[js];
    Eigen::Matrix3d g = base;
    if (aims.size() == 1) {
      const Eigen::Vector3d a = base * aims[0].rest, b = target(aims[0].ghost) - position_[js];
      if (a.norm() > 0.0 && b.norm() > 0.0) g = Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix() * base;
    } else if (aims.size() > 1) {
      // Kabsch: the proper rotation R minimising sum |R a_i - b_i|^2.
      Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
      for (const Aim& aim : aims) h += (base * aim.rest) * (target(aim.ghost) - position_[js]).transpose();
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
      fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
      g = svd.matrixV() * fix * svd.matrixU().transpose() * base;
    }
    global_[js] = g;
    Eigen::Quaterniond q(Eigen::Matrix3d(base.transpose() * g));
    q.normalize();
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // one of the two equal quaternions: w >= 0
    rotations[4 * js + 0] = q.x();
    rotations[4 * js + 1] = q.y();
    rotations[4 * js + 2] = q.z();
    rotations[4 * js + 3] = q.w();
    if (positions)
      for (int k = 0; k < 3; ++k) positions[3 * js + static_cast<size_t>(k)] = position_[js][k];
  }
  for (int k = 0; k < 3; ++k) root_position[k] = position_[0][k];
  residual_ = 0.0;
  for (size_t i = 0; i < ghost_source_.size(); ++i) {
    const int s = ghost_source_[i];
    if (s >= 0)
      residual_ = std::max(residual_, (position_[static_cast<size_t>(s)] - target(static_cast<int>(i))).norm());
  }
}

}  // namespace kata::retarget
