// Ghost BVH motion rows (see ghost_bvh.hpp).
#include "io/ghost_bvh.hpp"

#include <cmath>
#include <string>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "common/error.hpp"

namespace kata::retarget {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool is_rotation(Channel c) { return c == Channel::kXrot || c == Channel::kYrot || c == Channel::kZrot; }
int axis_of(Channel c) {
  switch (c) {
    case Channel::kXrot: case Channel::kXpos: return 0;
    case Channel::kYrot: case Channel::kYpos: return 1;
    default: return 2;
  }
}

// The local rotation of a joint from its channels in one motion row (BVH: the product of the
// rotation channels in the listed order, degrees).
Eigen::Matrix3d local_rotation(const std::vector<Channel>& ch, const double* values) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  for (size_t i = 0; i < ch.size(); ++i) {
    if (!is_rotation(ch[i])) continue;
    r = r * Eigen::AngleAxisd(values[i] * kPi / 180.0, Eigen::Vector3d::Unit(axis_of(ch[i]))).toRotationMatrix();
  }
  return r;
}

// The smallest rotation taking unit direction a onto unit direction b.
Eigen::Matrix3d swing(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix();
}

// Wraps x into (ref - 180, ref + 180] degrees.
double unwrap(double x, double ref) { return x - 360.0 * std::round((x - ref) / 360.0); }

}  // namespace

GhostBvh::GhostBvh(const BvhClip& teacher, const BvhClip& student, const JointSelection& sel)
    : n_(student.skeleton.joint_count()),
      selected_of_(n_, -1),
      movers_(n_),
      offsets_(student.skeleton.offsets),
      channels_(student.channels),
      channel_offset_(student.channel_offset),
      teacher_global_(n_),
      global_(n_),
      position_(n_),
      previous_(static_cast<size_t>(student.channel_count), 0.0) {
  if (teacher.skeleton.names != student.skeleton.names || teacher.skeleton.parents != student.skeleton.parents ||
      teacher.channels != student.channels) {
    throw Error(ErrorKind::kInvalidArgument, "ghost BVH: teacher and student must share hierarchy and channels");
  }
  if (sel.preset != "cmu") {
    throw Error(ErrorKind::kInvalidArgument, "ghost BVH: only the 'cmu' preset keeps every bone of the hierarchy");
  }
  const Skeleton& sk = student.skeleton;
  for (size_t k = 0; k < sel.source.size(); ++k) selected_of_[sel.source[k]] = static_cast<int>(k);
  double longest = 0.0;
  for (int j = 1; j < n_; ++j) longest = std::max(longest, sk.offsets[j].norm());
  for (int j = 0; j < n_; ++j) {
    int rot = 0;
    for (Channel c : channels_[j]) rot += is_rotation(c) ? 1 : 0;
    if (rot != 3) {
      throw Error(ErrorKind::kInvalidArgument, "ghost BVH: joint '" + sk.names[j] + "' needs 3 rotation channels");
    }
    if (selected_of_[j] < 0) {
      if (j == 0 || sk.offsets[j].norm() > 1e-6 * longest) {
        throw Error(ErrorKind::kInvalidArgument, "ghost BVH: joint '" + sk.names[j] + "' is not retargeted but has a bone");
      }
      selected_of_[j] = selected_of_[sk.parents[j]];  // it sits on its parent
    }
    if (j > 0 && sk.offsets[j].norm() > 1e-6 * longest) movers_[sk.parents[j]].push_back(j);
  }
}

void GhostBvh::motion_row(const BvhClip& teacher, int frame, const double* ghost, double* row) {
  const double* trow = teacher.frame(frame);
  const std::vector<int>& parents = teacher.skeleton.parents;
  for (int j = 0; j < n_; ++j) {
    const double* g = ghost + 3 * selected_of_[j];
    position_[j] = Eigen::Vector3d(g[0], g[1], g[2]);
    const Eigen::Matrix3d local = local_rotation(channels_[j], trow + channel_offset_[j]);
    teacher_global_[j] = parents[j] < 0 ? local : Eigen::Matrix3d(teacher_global_[parents[j]] * local);
  }
  for (int j = 0; j < n_; ++j) {
    const int p = parents[j];
    const std::vector<int>& kids = movers_[j];
    if (kids.empty()) {
      // Nothing hangs from this joint's rotation: keep the teacher's local rotation.
      const Eigen::Matrix3d local = p < 0 ? teacher_global_[j] : Eigen::Matrix3d(teacher_global_[p].transpose() * teacher_global_[j]);
      global_[j] = p < 0 ? local : Eigen::Matrix3d(global_[p] * local);
    } else if (kids.size() == 1) {
      const Eigen::Vector3d a = (teacher_global_[j] * offsets_[kids[0]]).normalized();
      const Eigen::Vector3d d = position_[kids[0]] - position_[j];
      global_[j] = d.norm() > 0.0 ? Eigen::Matrix3d(swing(a, d.normalized()) * teacher_global_[j]) : teacher_global_[j];
    } else {
      // Several bones: the proper rotation best turning the teacher-rotated offsets onto the
      // ghost's bones (Kabsch), applied on top of the teacher's rotation.
      Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
      for (int c : kids) h += (teacher_global_[j] * offsets_[c]) * (position_[c] - position_[j]).transpose();
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
      fix(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
      global_[j] = svd.matrixV() * fix * svd.matrixU().transpose() * teacher_global_[j];
    }
  }
  // Local rotations -> Euler angles in each joint's channel order; positions.
  for (int j = 0; j < n_; ++j) {
    const int p = parents[j];
    const Eigen::Matrix3d local = p < 0 ? global_[j] : Eigen::Matrix3d(global_[p].transpose() * global_[j]);
    int axes[3], slots[3], r = 0;
    for (size_t i = 0; i < channels_[j].size(); ++i) {
      const Channel c = channels_[j][i];
      double* out = row + channel_offset_[j] + static_cast<int>(i);
      if (is_rotation(c)) {
        axes[r] = axis_of(c);
        slots[r++] = channel_offset_[j] + static_cast<int>(i);
      } else {
        // Position channels replace the offset (io/bvh.hpp): the root carries the ghost's root.
        *out = p < 0 ? position_[j][axis_of(c)] : offsets_[j][axis_of(c)];
      }
    }
    const Eigen::Vector3d e = local.eulerAngles(axes[0], axes[1], axes[2]) * (180.0 / kPi);
    double cand[2][3] = {{e[0], e[1], e[2]}, {e[0] + 180.0, 180.0 - e[1], e[2] + 180.0}};
    if (axes[0] == axes[2]) {  // proper Euler angles (e.g. Z-Y-Z): the other branch negates the middle
      cand[1][1] = -e[1];
    }
    // Pick the branch (and the +-360 wrap) closest to the previous row: no jumps in the curves.
    int best = 0;
    double best_cost = 0.0;
    for (int b = 0; b < 2; ++b) {
      double cost = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double ref = has_previous_ ? previous_[static_cast<size_t>(slots[k])] : 0.0;
        cand[b][k] = unwrap(cand[b][k], ref);
        cost += (cand[b][k] - ref) * (cand[b][k] - ref);
      }
      if (b == 0 || cost < best_cost) {
        best = b;
        best_cost = cost;
      }
    }
    for (int k = 0; k < 3; ++k) row[slots[k]] = cand[best][k];
  }
  for (size_t i = 0; i < previous_.size(); ++i) previous_[i] = row[i];
  has_previous_ = true;
}

}  // namespace kata::retarget
