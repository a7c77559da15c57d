// The VRM humanoid rig of any layout (kata/humanoid.h "The rig" states the contract): a layout's
// joints read as points, the VRM bones placed on them, a T-pose rest with the student's bone
// lengths, and per frame each placed bone's local rotation relative to that T-pose.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "humanoid/bones.hpp"
#include "skeleton/skeleton.hpp"

namespace kata::humanoid {

// The points of an input frame the rig reads (Y-up metres): the 16 GPD joints (GPD order), then
// what some layouts have beyond them.
enum PointId : int {
  kPointSpineMid = kGpdJoints,  // a spine joint between the hips and GPD Chest (CMU's Spine)
  kPointLeftToe,
  kPointRightToe,
  kPointLeftHandTip,            // where the hand points (CMU's LeftHandIndex1, MediaPipe's finger bases)
  kPointRightHandTip,
  kPointLeftHandA,              // the hand's turn: A - B points to the hand's thumb side (+Z at rest)
  kPointLeftHandB,
  kPointRightHandA,
  kPointRightHandB,
  kPointNose,                   // the head's turn: the ears' line and the nose
  kPointLeftEar,
  kPointRightEar,
  kPointCount
};
constexpr int kExtraPoints = kPointCount - kGpdJoints;

// How an input frame becomes points: the layout's GPD map, extras (a weighted sum of at most two
// input joints each), the input's axes and units.
struct Mapping {
  GpdMap gpd;
  struct Extra {
    int count = 0;  // 0: the layout has no such point
    std::array<int, 2> joint{};
    std::array<float, 2> weight{};
  };
  std::array<Extra, kExtraPoints> extra{};
  UpAxis axes = UpAxis::kY;
  double metres_per_unit = 1.0;
  int input_joints = 0;
  std::vector<std::string> joint_names;  // for messages
  bool has(int point) const {
    return point < kGpdJoints || extra[static_cast<size_t>(point - kGpdJoints)].count > 0;
  }
};

// The mapping of a layout on a skeleton: `layout` is the built-in layout's name ("" for a name
// map: no extras), `gpd` its resolved GPD map. Extras come from the joints the skeleton has
// (by name, per layout: rig.cpp lists them).
Mapping make_mapping(const Skeleton& skeleton, const GpdMap& gpd, const std::string& layout, UpAxis axes,
                     double metres_per_unit);
// The default metres per unit of a layout (kata/humanoid.h, kata_humanoid_desc).
double default_metres_per_unit(const std::string& layout);

// One frame's points.
struct Points {
  std::array<Eigen::Vector3d, kPointCount> p;
};

// A pose as the rig computes it (kata_humanoid_pose in the rig's frame, double).
struct Pose {
  uint32_t placed = 0, degenerate = 0;
  Eigen::Vector3d hips = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector4d, kBoneCount> rotation{};  // x y z w
  std::array<Eigen::Vector3d, kBoneCount> offset{};
};

class Rig {
 public:
  explicit Rig(Mapping mapping);

  const Mapping& mapping() const { return mapping_; }
  uint32_t placed() const { return placed_; }
  // The input joint bone b's joint reads directly, or -1.
  int bone_source(int bone) const;

  // The input joints a frame must have finite and in range (every joint the points read).
  const std::vector<int>& read_joints() const { return read_joints_; }
  // A frame's points (input joints x 3 floats). The read joints must be finite. No allocation.
  void points(const float* xyz, Points& out) const;

  // The rest from frames of points: each bone's length and the pelvis's shape, medians over the
  // frames. Allocates only for more frames than any measure before (one frame: never).
  void measure(const Points* frames, int n);
  // True when every placed bone with a child has a length in `pts` (a frame to measure the rest on).
  bool complete(const Points& pts) const;
  bool measured() const { return rest_ready_; }

  // A frame's pose (requires measured()). No allocation.
  void pose(const Points& pts, Pose& out) const;
  // The rest T-pose: identity rotations, rest offsets.
  void rest_pose(Pose& out) const;

 private:
  struct BoneDef {
    int joint = -1;       // point of the bone's joint
    int child = -1;       // point the bone points at, or -1
    int parent = -1;      // placed ancestor (the VRM parent, or its own placed parent)
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();  // the bone's rest direction
    int twist = 0;        // TwistKind (rig.cpp)
    Eigen::Vector3d secondary = Eigen::Vector3d::Zero();  // the rest direction the twist aligns
  };
  Eigen::Matrix3d hips_frame(const Points& pts, uint32_t& degenerate) const;

  Mapping mapping_;
  std::array<BoneDef, kBoneCount> def_{};
  uint32_t placed_ = 0;
  std::vector<int> read_joints_;

  bool rest_ready_ = false;
  bool triangle_ = false;  // the hips' frame from the pelvis triangle (else from the spine)
  Eigen::Matrix3d tilt_ = Eigen::Matrix3d::Identity();  // triangle frame -> canonical, at rest
  std::array<double, kBoneCount> length_{};
  std::array<Eigen::Vector3d, kBoneCount> rest_offset_{};

  // measure()'s per-frame samples, kept so that measuring one frame does not allocate.
  std::array<std::vector<double>, kBoneCount> sample_lengths_;
  std::vector<double> sample_share_, sample_tilt_;
  std::array<std::array<std::vector<double>, 3>, 2> sample_leg_spine_, sample_leg_triangle_;
};

}  // namespace kata::humanoid
