// Which joints of a source skeleton take part in retargeting, by preset:
//   "cmu": every joint that carries a bone (zero-offset joints sitting on their parent dropped;
//          the CMU BVH conversion: 31 -> 21 joints, 210 pairs). Works for any BVH skeleton.
//   "gpd": the 16 GPD v1 joints (spec section 1), read through the "cmu" GPD name preset, with
//          the GPD tree (kGpdParents) as the retargeting tree.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "skeleton/skeleton.hpp"

namespace kata::retarget {

// The retargeting tree and where each of its joints is read in the source skeleton.
struct JointSelection {
  std::string preset;              // "cmu" or "gpd"
  std::vector<std::string> names;  // per retarget joint (source joint names; GPD names for "gpd")
  std::vector<int> parents;        // the retargeting tree, topological
  std::vector<int> source;         // per retarget joint: index in the source skeleton
};

// Names of the retargeting presets, for help texts.
std::vector<std::string> retarget_preset_names();
// The selection of a preset for a teacher/student pair (they must share joint names and tree).
// Throws kata::Error(kNotFound) for an unknown preset or a missing joint, kInvalidArgument when
// the two skeletons differ.
JointSelection select_joints(const Skeleton& teacher, const Skeleton& student, const std::string& preset);
// Rest distances between each selected joint and its selected parent (entry 0 = 0), in the
// skeleton's units; and the unit rest directions (joints x 3 row-major), the fallback for a
// teacher bone of zero length.
std::vector<double> selected_rest_lengths(const Skeleton& skeleton, const JointSelection& selection);
std::vector<double> selected_rest_directions(const Skeleton& skeleton, const JointSelection& selection);
// Copies the selected rows of world positions (source joints x 3) into out (joints x 3 row-major).
void gather_positions(const Eigen::MatrixX3d& world, const JointSelection& selection, double* out);

}  // namespace kata::retarget
