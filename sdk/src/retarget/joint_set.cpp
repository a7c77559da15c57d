// Retargeting joint presets (see joint_set.hpp).
#include "retarget/joint_set.hpp"

#include "common/error.hpp"
#include "common/text.hpp"
#include "retarget/distance.hpp"

namespace kata::retarget {

std::vector<std::string> retarget_preset_names() { return {"cmu", "gpd"}; }

JointSelection select_joints(const Skeleton& teacher, const Skeleton& student, const std::string& preset) {
  if (teacher.names != student.names || teacher.parents != student.parents) {
    throw Error(ErrorKind::kInvalidArgument,
                "retarget: teacher and student skeletons must have the same joints and tree");
  }
  JointSelection s;
  s.preset = preset;
  if (preset == "cmu") {
    // A joint coincident in either skeleton is dropped in both, so the trees stay equal.
    std::vector<bool> drop = coincident_joints(teacher);
    const std::vector<bool> drop_student = coincident_joints(student);
    for (size_t j = 0; j < drop.size(); ++j) drop[j] = drop[j] || drop_student[j];
    const ReducedSkeleton r = drop_joints(teacher, drop);
    s.names = r.skeleton.names;
    s.parents = r.skeleton.parents;
    s.source = r.source;
    return s;
  }
  if (preset == "gpd") {
    const GpdMap map = make_gpd_map(teacher, preset_joint_names("cmu"));
    for (int g = 0; g < kGpdJoints; ++g) {
      s.names.emplace_back(kGpdJointNames[static_cast<size_t>(g)]);
      s.parents.push_back(kGpdParents[static_cast<size_t>(g)]);
      s.source.push_back(map.source[static_cast<size_t>(g)]);
    }
    return s;
  }
  throw Error(ErrorKind::kNotFound, "retarget: unknown preset '" + bounded(preset) + "' (known: cmu, gpd)");
}

std::vector<double> selected_rest_lengths(const Skeleton& skeleton, const JointSelection& sel) {
  const Eigen::MatrixX3d rest = rest_positions(skeleton);
  std::vector<double> len(sel.parents.size(), 0.0);
  for (size_t k = 1; k < sel.parents.size(); ++k) {
    len[k] = (rest.row(sel.source[k]) - rest.row(sel.source[static_cast<size_t>(sel.parents[k])])).norm();
  }
  return len;
}

std::vector<double> selected_rest_directions(const Skeleton& skeleton, const JointSelection& sel) {
  const Eigen::MatrixX3d rest = rest_positions(skeleton);
  std::vector<double> dir(3 * sel.parents.size(), 0.0);
  dir[1] = 1.0;
  for (size_t k = 1; k < sel.parents.size(); ++k) {
    Eigen::RowVector3d d = rest.row(sel.source[k]) - rest.row(sel.source[static_cast<size_t>(sel.parents[k])]);
    const double n = d.norm();
    d = n > 0.0 ? Eigen::RowVector3d(d / n) : Eigen::RowVector3d(0.0, 1.0, 0.0);
    for (int c = 0; c < 3; ++c) dir[3 * k + static_cast<size_t>(c)] = d[c];
  }
  return dir;
}

void gather_positions(const Eigen::MatrixX3d& world, const JointSelection& sel, double* out) {
  for (size_t k = 0; k < sel.source.size(); ++k)
    for (int c = 0; c < 3; ++c) out[3 * k + static_cast<size_t>(c)] = world(sel.source[k], c);
}

}  // namespace kata::retarget
