// Retargeting across joint layouts through the 16 GPD joints (see mapped.hpp).
#include "retarget/mapped.hpp"

#include <cmath>

#include "common/error.hpp"

namespace kata::retarget {

namespace {
std::vector<int> gpd_parents() { return std::vector<int>(kGpdParents.begin(), kGpdParents.end()); }
std::vector<double> lengths_vector(const std::array<double, kGpdJoints>& a) { return {a.begin(), a.end()}; }
}  // namespace

std::array<double, kGpdJoints> gpd_rest_lengths(const Skeleton& skeleton, const GpdMap& map) {
  if (!skeleton.has_rest_pose)
    throw Error(ErrorKind::kInvalidArgument, "retarget: the student skeleton has no rest pose (estimate its bone "
                                             "lengths from a stream instead)");
  const Eigen::MatrixX3d rest = rest_positions(skeleton);
  Eigen::Matrix<double, kGpdJoints, 3> gpd;
  for (int g = 0; g < kGpdJoints; ++g) {
    const int src = map.source[static_cast<size_t>(g)];
    if (src >= 0) {
      gpd.row(g) = rest.row(src);
      continue;
    }
    const GpdBlend& b = map.blend[static_cast<size_t>(g)];
    gpd.row(g).setZero();
    for (int k = 0; k < b.count; ++k) gpd.row(g) += double(b.weight[static_cast<size_t>(k)]) * rest.row(b.joint[static_cast<size_t>(k)]);
  }
  std::array<double, kGpdJoints> out{};
  for (int g = 1; g < kGpdJoints; ++g) {
    out[static_cast<size_t>(g)] = (gpd.row(g) - gpd.row(kGpdParents[static_cast<size_t>(g)])).norm();
    if (!(out[static_cast<size_t>(g)] > 0.0))
      throw Error(ErrorKind::kInvalidArgument, std::string("retarget: the student's GPD bone to ") +
                                                   kGpdJointNames[static_cast<size_t>(g)] + " has zero rest length");
  }
  return out;
}

MappedRetargeter::MappedRetargeter(const MappedSide& teacher, const MappedSide& student,
                                   const std::array<double, kGpdJoints>& student_lengths,
                                   const RetargetOptions& options)
    : teacher_(teacher),
      student_(student),
      solver_(gpd_parents(), lengths_vector(student_lengths), options),
      teacher_gpd_(3 * kGpdJoints),
      ghost_(3 * kGpdJoints),
      student_gpd_(3 * kGpdJoints) {
  if (teacher.joints <= 0 || student.joints <= 0)
    throw Error(ErrorKind::kInvalidArgument, "retarget: teacher and student need joints");
}

const RetargetReport& MappedRetargeter::retarget(const float* teacher, float* ghost) {
  float gpd[3 * kGpdJoints];
  map_to_gpd(teacher_.map, teacher_.axes, teacher, gpd);
  for (int i = 0; i < 3 * kGpdJoints; ++i) teacher_gpd_[static_cast<size_t>(i)] = gpd[i];
  const RetargetReport& report = solver_.retarget(teacher_gpd_.data(), ghost_.data());
  // The solve put the root on the teacher's root, in the teacher's units: move it to the origin.
  for (int g = 0; g < kGpdJoints; ++g) {
    float y_up[3];
    for (int k = 0; k < 3; ++k) y_up[k] = static_cast<float>(ghost_[3 * g + k] - ghost_[k]);
    from_y_up(student_.axes, y_up, ghost + 3 * g);
  }
  return report;
}

void MappedRetargeter::place(const float* student, float* ghost) {
  float gpd[3 * kGpdJoints];
  map_to_gpd(student_.map, student_.axes, student, gpd);
  for (int g = 0; g < kGpdJoints; ++g) {
    float y_up[3];
    to_y_up(student_.axes, ghost + 3 * g, y_up);
    for (int k = 0; k < 3; ++k) {
      student_gpd_[3 * g + k] = gpd[3 * g + k];
      ghost_[3 * g + k] = y_up[k];
    }
  }
  place_over_student(kGpdJoints, student_gpd_.data(), ghost_.data());
  for (int g = 0; g < kGpdJoints; ++g) {
    const float y_up[3] = {static_cast<float>(ghost_[3 * g]), static_cast<float>(ghost_[3 * g + 1]),
                           static_cast<float>(ghost_[3 * g + 2])};
    from_y_up(student_.axes, y_up, ghost + 3 * g);
  }
}

}  // namespace kata::retarget
