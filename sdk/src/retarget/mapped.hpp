// Retargeting across joint layouts: a teacher on one skeleton (a CMU BVH) onto a student on
// another (MediaPipe landmarks, Kinect, a user's name map), through the joints both share: the 16
// GPD joints every layout maps (skeleton.hpp). Each side's frames are read through its layout's
// GpdMap (synthesised joints included) and turned into Y-up; the distance-geometry solve
// (retargeter.hpp) runs on the GPD tree (kGpdParents) with the student's GPD bone lengths, from
// its rest pose or estimated from its live frames (Stream::bone_lengths). The ghost comes out as
// the 16 GPD joints in the student's axes and units. The teacher's units never matter: the
// method only reads its normalised distances. All buffers are sized at construction.
#pragma once

#include <array>
#include <vector>

#include "retarget/retargeter.hpp"
#include "skeleton/skeleton.hpp"

namespace kata::retarget {

// How one side's frames are read.
struct MappedSide {
  GpdMap map;                 // its layout's map onto the 16 GPD joints
  UpAxis axes = UpAxis::kY;   // its frames' axes
  int joints = 0;             // joints per frame
};

// The student's GPD bone lengths (entry g = |g - parent g| on the rest pose, entry 0 = 0) under a
// map. Requires skeleton.has_rest_pose; throws kata::Error(kInvalidArgument) otherwise or for a
// zero-length bone.
std::array<double, kGpdJoints> gpd_rest_lengths(const Skeleton& skeleton, const GpdMap& map);

class MappedRetargeter {
 public:
  // student_lengths: GPD bone lengths (> 0 for g >= 1), in the student's units.
  MappedRetargeter(const MappedSide& teacher, const MappedSide& student,
                   const std::array<double, kGpdJoints>& student_lengths, const RetargetOptions& options = {});
  // teacher: teacher.joints x 3 floats in the teacher's axes (finite on every joint the map
  // reads). ghost: 16 x 3 floats, GPD order, the student's axes and units, root (Hip) at the
  // origin, oriented like the teacher. No allocation.
  const RetargetReport& retarget(const float* teacher, float* ghost);
  // Puts a ghost from retarget() over the student's frame (student.joints x 3 floats, its axes):
  // Hip on the student's Hip, turned about the vertical to face like the student. No allocation.
  void place(const float* student, float* ghost);
  void reset() { solver_.reset(); }
  const Retargeter& solver() const { return solver_; }
  const MappedSide& student() const { return student_; }
  const MappedSide& teacher() const { return teacher_; }

 private:
  MappedSide teacher_, student_;
  Retargeter solver_;
  std::vector<double> teacher_gpd_, ghost_, student_gpd_;  // 16 x 3, Y-up
};

}  // namespace kata::retarget
