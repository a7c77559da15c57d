// Skeleton-independent distance matrices (the DGP retargeting paper, section II): for every joint
// pair (u, v) of a tree, the tree path P_uv, its bone-length weight tau_uv, the normalised
// distance D_uv = |x_u - x_v| / tau_uv and the priority pi_uv = (|P_max| - |P_uv| + 2) / |P_max|.
// Everything that depends only on the tree is computed once, into flat arrays (one entry per
// pair, pairs u < v in lexicographic order), so a frame only walks contiguous data.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "skeleton/skeleton.hpp"

namespace kata::retarget {

// A skeleton without the joints that sit on their parent (zero rest offset), which carry no bone
// and would make tau_uv zero. CMU BVH: 31 joints -> 21 joints, 210 pairs.
struct ReducedSkeleton {
  Skeleton skeleton;               // the kept joints, topological; offsets from the kept parent (rest pose)
  std::vector<int> source;         // kept joint k -> index of that joint in the original skeleton
  std::vector<int> kept_position;  // original joint j -> kept joint whose position j shares (itself if kept)
};

// Joints whose rest offset is (numerically) zero, so they sit on their parent: |offset| <= 1e-6 x
// the longest offset of the skeleton. The root is never marked.
std::vector<bool> coincident_joints(const Skeleton& skeleton);
// The skeleton without the joints marked in `drop` (never the root). Children of a dropped joint
// hang from its nearest kept ancestor, with their rest offsets summed along the way. Requires
// every dropped joint to have a zero offset (positions are then shared, see kept_position);
// throws kata::Error(kInvalidArgument) otherwise.
ReducedSkeleton drop_joints(const Skeleton& skeleton, const std::vector<bool>& drop);
// Rest bone lengths: |offset| per joint (the root's entry is 0), in the skeleton's units.
std::vector<double> rest_bone_lengths(const Skeleton& skeleton);

// The frame-independent pair data of one tree. Teacher and student share the tree (same joints,
// same parents); only their bone lengths differ, and those enter through path_weights().
struct PairTable {
  int joints = 0;                       // n
  int pairs = 0;                        // n (n - 1) / 2
  int max_path = 0;                     // |P_max|: joints on the longest tree path (>= 2)
  std::vector<int> parents;             // per joint, -1 for the root; parents[i] < i
  std::vector<int> u, v;                // pair endpoints, u < v
  std::vector<int> lca;                 // lowest common ancestor of u and v
  std::vector<int> path_size;           // |P_uv|: joints on the path, both ends included (bones: 2)
  std::vector<int> path_offset;         // pairs + 1 entries: P_uv = path_joints[path_offset[p] ..)
  std::vector<int> path_joints;         // the joints of every path, from u to v
  std::vector<double> priority;         // pi_uv, in (0, 1]; exactly 1 for bones
  std::vector<unsigned char> is_bone;   // 1 when one endpoint is the other's parent
  std::vector<int> bone_pair;           // per joint j > 0: index of the pair (parent(j), j); -1 for the root
};

// Builds the pair table of a tree given by its parents (parents[0] == -1, parents[i] < i).
// Throws kata::Error(kInvalidArgument) for a malformed tree or fewer than 2 joints.
PairTable build_pair_table(const std::vector<int>& parents);
// Index of pair (a, b) in the table's order, for any a != b.
int pair_index(int joints, int a, int b);

// Bone lengths of a posture: out[j] = |x_j - x_parent(j)|, out[0] = 0. x is joints x 3, row-major.
void bone_lengths(const PairTable& table, const double* x, double* out);
// tau_uv for every pair from per-joint bone lengths, via cumulative lengths from the root:
// tau = c(u) + c(v) - 2 c(lca). `cumulative` is a scratch buffer of `joints` doubles.
void path_weights(const PairTable& table, const double* lengths, double* cumulative, double* tau);
// The full normalised distance matrix D (joints x joints, zero diagonal) of a posture x
// (joints x 3) under bone lengths `lengths`: for tests and reports, it allocates.
Eigen::MatrixXd normalised_distance_matrix(const PairTable& table, const Eigen::MatrixX3d& x,
                                           const std::vector<double>& lengths);

}  // namespace kata::retarget
