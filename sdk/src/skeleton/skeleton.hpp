// Skeletons: any tree of named joints with rest offsets, and the map from an input skeleton
// onto the 16 joints of GPD v1 (spec gpd-v1.md section 1).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

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

// For each GPD joint, the input-skeleton joint it reads, or (layouts without that joint, e.g.
// MediaPipe's pelvis) a weighted sum of input joints.
constexpr int kMaxBlendTerms = 6;
struct GpdBlend {
  int count = 0;                                // 0: the GPD joint is input joint `source`
  std::array<int, kMaxBlendTerms> joint{};      // input joints
  std::array<float, kMaxBlendTerms> weight{};   // their weights (sum 1)
  // Optional offset out of the body's plane (0 = none): with lateral = P[a] - P[b] and
  // up = (P[c] + P[d]) / 2 - (P[a] + P[b]) / 2, adds offset x (lateral x up) / |lateral|
  // (a length |up| pointing forward or back), for a joint that sits in front of or behind the
  // landmarks it is made of (the pelvis behind the hip joints).
  float offset = 0.0f;
  std::array<int, 4> offset_joint{};            // a, b, c, d
  // The input joint whose rest position stands for this joint in rest_body_height (-1: the
  // blend's own): a teacher read through trunk_as_student keeps its own joints' body height.
  int rest_joint = -1;
};
struct GpdMap {
  std::array<int, kGpdJoints> source{};         // input joint, or -1 when synthesised (blend)
  std::array<GpdBlend, kGpdJoints> blend{};     // used where source is -1
  // A source without a floor (MediaPipe: origin at the hips) names its foot joints here: each
  // frame the floor (spec: Y = 0 under the Hip height) is the lowest of them, in Y-up.
  static constexpr int kMaxFloorJoints = 6;
  int floor_count = 0;
  std::array<int, kMaxFloorJoints> floor_joints{};
  bool synthesised(int g) const { return source[static_cast<size_t>(g)] < 0; }
};

// The axes frames arrive in. GPD works Y-up; the others are turned into it by a proper rotation
// (never a mirror): Z-up (x, y, z) -> (x, z, -y); Y-down with z away from the viewer, the camera
// frame of MediaPipe's world landmarks, (x, y, z) -> (x, -y, -z) (180 degrees about x).
enum class UpAxis : int { kY = 0, kZ = 1, kYDown = 2 };
// One point into Y-up, and back.
inline void to_y_up(UpAxis axes, const float* in, float* out) {
  const float x = in[0], y = in[1], z = in[2];
  out[0] = x;
  if (axes == UpAxis::kZ) { out[1] = z; out[2] = -y; }
  else if (axes == UpAxis::kYDown) { out[1] = -y; out[2] = -z; }
  else { out[1] = y; out[2] = z; }
}
inline void from_y_up(UpAxis axes, const float* in, float* out) {
  const float x = in[0], y = in[1], z = in[2];
  out[0] = x;
  if (axes == UpAxis::kZ) { out[1] = -z; out[2] = y; }
  else if (axes == UpAxis::kYDown) { out[1] = -y; out[2] = -z; }
  else { out[1] = y; out[2] = z; }
}
// The 16 GPD joints of one frame (input joints x 3 floats, interleaved) in Y-up: out = 48 floats.
// No allocation; every joint the map reads must be finite for a finite result.
void map_to_gpd(const GpdMap& map, UpAxis axes, const float* xyz, float* out);
// GPD joint g alone (3 floats).
void map_gpd_joint(const GpdMap& map, UpAxis axes, int g, const float* xyz, float* out);

// A joint layout: how an input skeleton's joints become the 16 GPD joints, and in which axes
// its frames come. Built-in layouts (layout_names()):
//   every name-map preset (preset_joint_names(); "gpd" is the identity map), Y-up unless the
//   stream says otherwise;
//   "mediapipe": MediaPipe Pose world landmarks (the 33 landmarks of kMediaPipeLandmarks, in
//   MediaPipe's order; metres, origin at the midpoint of the hips; axes as the Pose Landmarker
//   emits world landmarks: x to the image's right, y down, z away from the camera). Pelvis,
//   chest, neck and head are synthesised; with h = midpoint of the hips (23, 24), s = midpoint
//   of the shoulders (11, 12), e = midpoint of the ears (7, 8):
//     Hip = h + 0.264 (s - h) - 0.07 f, Chest = h + 0.868 (s - h), Neck = (Chest + e) / 2,
//     Head = e, where f = (l_hip - r_hip) x (s - h) / |l_hip - r_hip| (the pelvis sits behind
//     the hip joints; layouts.cpp says how the constants were fitted);
//   the fractions put the joints where the "cmu" preset's Hips, Spine1, Neck1 and Head sit on the
//   CMU rest skeleton, so a webcam student scores against a CMU teacher on the same joints.
//   The other GPD joints are landmarks (shoulders, elbows, wrists, hips, knees, ankles). World
//   landmarks have no floor: each frame the floor is the lowest of the ankles, heels and foot
//   indices (27..32), so the Hip height is measured from the lower foot (a jump is not seen).
struct Layout {
  GpdMap map;
  UpAxis axes = UpAxis::kY;   // the layout's own axes (kY for name maps: the stream's setting wins)
  bool fixed_axes = false;    // true when the layout defines its axes (MediaPipe)
  bool smooth = false;        // One-Euro smoothing on by default (landmark estimators jitter)
};
// A teacher's map read with a student layout's trunk. A layout with no pelvis, spine or neck
// point ("mediapipe") synthesises Hip, Chest and Neck from its hip, shoulder and head points; a
// teacher whose layout has those joints (a BVH through "cmu") would otherwise be compared on
// another trunk, and the difference (the synthesised chest sits 0.5-4 % of the body height from
// CMU's Spine1, by subject) adds to or dilutes the error at any one joint. Returns `teacher` with
// every GPD joint that `student` synthesises and `teacher` reads as a joint of its own remade by
// the student's rule from the teacher's joints: a term that is the student's source of a GPD
// joint becomes the teacher's source of it, a group of terms in the proportions of another
// synthesised joint's blend (the ears of MediaPipe's Head in its Neck) becomes the teacher's
// source of that joint, and the out-of-plane offset's points are read the same way. A joint whose
// rule cannot be read so (MediaPipe's Head: the ears) stays the teacher's own. A remade joint's
// rest_joint is the teacher's joint it replaces, so the teacher's rest body height is unchanged
// (measured: the synthesised trunk's H lowered same-motion pairs). When `student`
// synthesises nothing, or `teacher` synthesises the same joints, returns `teacher` unchanged (a
// student of the teacher's own layout is scored as before, bit for bit).
GpdMap trunk_as_student(const GpdMap& teacher, const GpdMap& student);
// Names of every built-in layout: the presets, then "mediapipe".
std::vector<std::string> layout_names();
// The layout `name` on a skeleton (its joints found by name). Throws kata::Error(kNotFound) for an
// unknown name (listing the known ones) or a joint the skeleton lacks.
Layout resolve_layout(const Skeleton& skeleton, const std::string& name);
// The skeleton a built-in layout streams when the source has none: "mediapipe" (33 landmarks,
// each hung from a landmark before it: the tree only orders them), "gpd" (the 16 GPD joints and
// kGpdParents), "azure-kinect" (32 joints, k4abt order), "xsens" (MVN's 23 segments), "cmu"
// (the CMU BVH's 31 joints), "vrm" (kVrmJoints: VRM humanoid bones). No rest pose. Throws kata::Error(kNotFound) otherwise.
Skeleton layout_skeleton(const std::string& name);
// MediaPipe Pose's 33 landmark names, in its documented order (index = landmark id).
constexpr int kMediaPipeLandmarkCount = 33;
extern const std::array<const char*, kMediaPipeLandmarkCount> kMediaPipeLandmarks;

// The "vrm" layout's skeleton: the VRM humanoid bones a VMC performer sends, named as Unity's
// HumanBodyBones (the VMC protocol's bone names), parents before children. Its GPD map is the
// "vrm" preset (Chest = UpperChest).
constexpr int kVrmJointCount = 22;
extern const std::array<const char*, kVrmJointCount> kVrmJoints;
extern const std::array<int, kVrmJointCount> kVrmParents;
// A VRM-proportioned T-pose (about 1.65 m tall): each bone's offset from its parent's joint (the
// Hips': its position above the root), metres, in Unity's frame (left-handed, +Y up, the avatar
// facing +Z, its left side at -X), as a VRM avatar normalised by UniVRM has it. A VMC receiver
// uses these for a bone whose local position its sender does not give.
extern const std::array<std::array<float, 3>, kVrmJointCount> kVrmRestOffsets;
// Bones a VRM avatar may lack (UpperChest, the shoulders, the toes): a receiver whose sender never
// names one collapses it onto its parent (offset 0, no rotation).
extern const std::array<bool, kVrmJointCount> kVrmOptional;

// The input-joint names of a preset, in GPD joint order. Known presets: "cmu" (the CMU
// Motionbuilder-friendly BVH conversion), "cmu-3dsmax" and "daz" (the cgspeed 3dsMax- and
// Daz-friendly CMU conversions), "bandai" (Bandai Namco Research Motion Dataset), "kinect2"
// (Kinect v2 JointType names), "h36m" (Human3.6M 17 joints), "gpd" (the identity: a source
// that already names the 16 GPD joints, kGpdJointNames), "azure-kinect" (Azure Kinect Body
// Tracking's 32 joints), "xsens" (Xsens MVN's 23 segments); presets.cpp cites the vendor
// documentation of each. No OptiTrack Motive or Vicon preset: no vendor list was found. MediaPipe Pose is not a preset: it
// has no pelvis, chest or neck landmark, so it is no pure name map (it is a layout, below). Throws
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
// H of a skeleton's rest pose under a map (a synthesised joint: its rest_joint's rest position,
// else its blend of the rest positions; a teacher read through trunk_as_student keeps the H of
// its own joints). Requires skeleton.has_rest_pose.
double rest_body_height(const Skeleton& skeleton, const GpdMap& map);

}  // namespace kata
