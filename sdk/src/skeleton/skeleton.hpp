// Skeletons: any tree of named joints with rest offsets, and the map from an input skeleton
// onto the 16 joints of GPD v1 (spec gpd-v1.md section 1).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace kata {

// An immutable joint tree. Joints are stored in topological order: parents[i] < i, the root
// (parents[0] == -1) first. Offsets are rest-pose offsets from the parent, in the units of the
// source (a BVH file's units); the root's offset is its rest position.
struct Skeleton {
  std::vector<std::string> names;
  std::vector<int> parents;
  std::vector<Eigen::Vector3d> offsets;
  // True when offsets describe a real rest pose (a BVH HIERARCHY, a rig). A bare live stream
  // that only knows joint names and parents has none; its body height is then estimated.
  bool has_rest_pose = false;

  int joint_count() const { return static_cast<int>(names.size()); }
  // Index of the joint with this exact name, or -1.
  int find(const std::string& name) const;
  // Throws kata::Error(kInvalidArgument) unless sizes agree, names are unique and non-empty,
  // parents[0] == -1 and 0 <= parents[i] < i for i > 0.
  void validate() const;
};

// World positions of the rest pose (every rotation zero, root at its offset): n x 3, row i = joint i.
Eigen::MatrixX3d rest_positions(const Skeleton& skeleton);

// The 16 GPD v1 joints, in spec order.
constexpr int kGpdJoints = 16;
extern const std::array<const char*, kGpdJoints> kGpdJointNames;  // "Hip", "Chest", ...
extern const std::array<int, kGpdJoints> kGpdParents;             // -1, 0, 1, 2, 2, 4, ...

// For each GPD joint, the index of the input-skeleton joint it reads.
struct GpdMap {
  std::array<int, kGpdJoints> source{};
};

// The input-joint names of a preset, in GPD joint order. Known presets: "cmu" (the CMU
// Motionbuilder-friendly BVH conversion), "cmu-3dsmax" and "daz" (the cgspeed 3dsMax- and
// Daz-friendly CMU conversions), "bandai" (Bandai Namco Research Motion Dataset), "kinect2"
// (Kinect v2 JointType names), "h36m" (Human3.6M 17 joints). MediaPipe Pose is not a preset:
// it has no pelvis, chest or neck landmark, so it is no pure name map. Throws
// kata::Error(kNotFound) for an unknown name; the message lists the known presets.
std::array<std::string, kGpdJoints> preset_joint_names(const std::string& preset);
// Names of every built-in preset.
std::vector<std::string> preset_names();

// User name maps (JSON or "Gpd = source" text) are parsed by io/name_map.hpp: the runtime
// receives the 16 names, never a file.

// Resolves names against a skeleton. Throws kata::Error(kNotFound) naming the missing joint.
GpdMap make_gpd_map(const Skeleton& skeleton, const std::array<std::string, kGpdJoints>& names);

// The spec's body height H (section 2, step 4) from 16 mapped joint positions (16 x 3, any
// consistent units): |Head-Neck| + |Neck-Chest| + |Chest-Hip| + mean over sides of
// (|Hip_s-Knee_s| + |Knee_s-Foot_s|).
double body_height(const Eigen::Matrix<double, kGpdJoints, 3>& joints);
// H of a skeleton's rest pose under a map. Requires skeleton.has_rest_pose.
double rest_body_height(const Skeleton& skeleton, const GpdMap& map);

}  // namespace kata
