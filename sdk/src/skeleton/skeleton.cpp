// Skeleton validation, rest pose, GPD joint maps and the body height H (spec gpd-v1.md 1-2).
#include "skeleton/skeleton.hpp"

#include <unordered_set>

#include "common/error.hpp"
#include "common/text.hpp"

namespace kata {

const std::array<const char*, kGpdJoints> kGpdJointNames = {
    "Hip",       "Chest",  "Neck",  "Head", "LShoulder", "LElbow", "LHand", "RShoulder",
    "RElbow",    "RHand",  "LHip",  "LKnee", "LFoot",    "RHip",   "RKnee", "RFoot"};

// Spec section 1, column "parent".
const std::array<int, kGpdJoints> kGpdParents = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};

int Skeleton::find(const std::string& name) const {
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

void Skeleton::validate() const {
  // Joint names are caller text of any length: the message is cut.
  auto fail = [](const std::string& what) {
    throw Error(ErrorKind::kInvalidArgument, "skeleton: " + bounded(what, 4 * kMaxQuotedBytes));
  };
  if (names.empty()) fail("no joints");
  if (parents.size() != names.size() || offsets.size() != names.size()) {
    fail("names, parents and offsets differ in size (" + std::to_string(names.size()) + ", " +
         std::to_string(parents.size()) + ", " + std::to_string(offsets.size()) + ")");
  }
  if (parents[0] != -1) fail("joint 0 ('" + names[0] + "') must be the root (parent -1)");
  std::unordered_set<std::string> seen;
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i].empty()) fail("joint " + std::to_string(i) + " has an empty name");
    if (!seen.insert(names[i]).second) fail("duplicate joint name '" + names[i] + "'");
    if (i > 0 && (parents[i] < 0 || parents[i] >= static_cast<int>(i))) {
      fail("joint " + std::to_string(i) + " ('" + names[i] + "') has parent " + std::to_string(parents[i]) +
           "; parents must precede their children");
    }
    if (!offsets[i].allFinite()) fail("joint '" + names[i] + "' has a non-finite offset");
  }
}

Eigen::MatrixX3d rest_positions(const Skeleton& skeleton) {
  const int n = skeleton.joint_count();
  Eigen::MatrixX3d out(n, 3);
  for (int i = 0; i < n; ++i) {
    const int p = skeleton.parents[static_cast<size_t>(i)];
    // With every rotation zero, a joint sits at its parent plus its offset (topological order).
    if (p < 0) {
      out.row(i) = skeleton.offsets[static_cast<size_t>(i)].transpose();
    } else {
      out.row(i) = out.row(p) + skeleton.offsets[static_cast<size_t>(i)].transpose();
    }
  }
  return out;
}

GpdMap make_gpd_map(const Skeleton& skeleton, const std::array<std::string, kGpdJoints>& names) {
  GpdMap map;
  std::string missing;
  for (int g = 0; g < kGpdJoints; ++g) {
    const int idx = skeleton.find(names[static_cast<size_t>(g)]);
    if (idx < 0) {
      if (!missing.empty()) missing += ", ";
      missing += "'" + names[static_cast<size_t>(g)] + "' (GPD " + kGpdJointNames[static_cast<size_t>(g)] + ")";
      const std::string hint = closest_name(names[static_cast<size_t>(g)], skeleton.names);
      if (!hint.empty()) missing += " - did you mean '" + hint + "'?";
    }
    map.source[static_cast<size_t>(g)] = idx;
  }
  if (!missing.empty()) {
    // The joints it does have, so that a name map or another preset can be written from the message.
    std::string has;
    for (const std::string& n : skeleton.names) has += (has.empty() ? "" : ", ") + n;
    throw Error(ErrorKind::kNotFound, "skeleton has no joint " + bounded(missing, 4 * kMaxQuotedBytes) + "; its " +
                                          std::to_string(skeleton.names.size()) + " joints are: " +
                                          bounded(has, 8 * kMaxQuotedBytes));
  }
  return map;
}

double body_height(const Eigen::Matrix<double, kGpdJoints, 3>& joints) {
  auto dist = [&](int a, int b) { return (joints.row(a) - joints.row(b)).norm(); };
  // Indices are the spec's GPD order: 0 Hip, 1 Chest, 2 Neck, 3 Head, 10..12 left leg, 13..15 right leg.
  const double trunk = dist(3, 2) + dist(2, 1) + dist(1, 0);
  const double left_leg = dist(10, 11) + dist(11, 12);
  const double right_leg = dist(13, 14) + dist(14, 15);
  return trunk + 0.5 * (left_leg + right_leg);
}

namespace {

// True when GPD joint g is a blend whose every point lies on a skeleton of n joints.
bool synthesised_from(const GpdMap& map, int g, int n) {
  const GpdBlend& b = map.blend[static_cast<size_t>(g)];
  if (b.count < 1 || b.count > kMaxBlendTerms) return false;
  for (int k = 0; k < b.count; ++k)
    if (b.joint[static_cast<size_t>(k)] < 0 || b.joint[static_cast<size_t>(k)] >= n) return false;
  if (b.offset != 0.0f)
    for (const int j : b.offset_joint)
      if (j < 0 || j >= n) return false;
  return true;
}

// A blend of rest positions (map_gpd_joint's sum and offset; lengths need no axes turn).
Eigen::RowVector3d blend_of(const GpdBlend& b, const Eigen::MatrixX3d& rest) {
  Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
  for (int k = 0; k < b.count; ++k)
    p += static_cast<double>(b.weight[static_cast<size_t>(k)]) * rest.row(b.joint[static_cast<size_t>(k)]);
  if (b.offset != 0.0f) {
    const Eigen::Vector3d a = rest.row(b.offset_joint[0]), c = rest.row(b.offset_joint[1]);
    const Eigen::Vector3d lateral = a - c;
    const Eigen::Vector3d up = 0.5 * (rest.row(b.offset_joint[2]) + rest.row(b.offset_joint[3])).transpose() - 0.5 * (a + c);
    const double n = lateral.norm();
    if (n > 0.0) p += (static_cast<double>(b.offset) / n * lateral.cross(up)).transpose();
  }
  return p;
}

}  // namespace

double rest_body_height(const Skeleton& skeleton, const GpdMap& map) {
  if (!skeleton.has_rest_pose) {
    throw Error(ErrorKind::kInvalidArgument,
                "rest_body_height: the skeleton has no rest pose (estimate H from the stream instead)");
  }
  const Eigen::MatrixX3d rest = rest_positions(skeleton);
  Eigen::Matrix<double, kGpdJoints, 3> joints;
  for (int g = 0; g < kGpdJoints; ++g) {
    const int src = map.source[static_cast<size_t>(g)];
    const int rj = map.blend[static_cast<size_t>(g)].rest_joint;
    if (src < 0 && rj >= 0 && rj < skeleton.joint_count()) {
      joints.row(g) = rest.row(rj);
      continue;
    }
    if (src < 0 && synthesised_from(map, g, skeleton.joint_count())) {
      joints.row(g) = blend_of(map.blend[static_cast<size_t>(g)], rest);
      continue;
    }
    if (src < 0 || src >= skeleton.joint_count()) {
      throw Error(ErrorKind::kInvalidArgument, std::string("rest_body_height: GPD joint ") +
                                                   kGpdJointNames[static_cast<size_t>(g)] +
                                                   " maps to no joint of the skeleton");
    }
    joints.row(g) = rest.row(src);
  }
  return body_height(joints);
}

}  // namespace kata
