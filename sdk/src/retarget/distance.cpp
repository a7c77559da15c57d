// Pair tables, path weights and normalised distance matrices (see distance.hpp).
#include "retarget/distance.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/error.hpp"

namespace kata::retarget {

std::vector<bool> coincident_joints(const Skeleton& skeleton) {
  const int n = skeleton.joint_count();
  double longest = 0.0;
  for (int j = 1; j < n; ++j) longest = std::max(longest, skeleton.offsets[j].norm());
  std::vector<bool> drop(n, false);
  for (int j = 1; j < n; ++j) drop[j] = skeleton.offsets[j].norm() <= 1e-6 * longest;
  return drop;
}

ReducedSkeleton drop_joints(const Skeleton& skeleton, const std::vector<bool>& drop) {
  const int n = skeleton.joint_count();
  if (static_cast<int>(drop.size()) != n) {
    throw Error(ErrorKind::kInvalidArgument, "drop_joints: mask size differs from the joint count");
  }
  ReducedSkeleton out;
  out.kept_position.assign(n, -1);
  // Rest positions relative to the root, so offsets between kept joints are sums of offsets.
  std::vector<Eigen::Vector3d> rest(n);
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    rest[j] = p < 0 ? skeleton.offsets[j] : Eigen::Vector3d(rest[p] + skeleton.offsets[j]);
    if (j > 0 && drop[j]) {
      if (skeleton.offsets[j].norm() > 1e-6 * std::max(1.0, rest[j].norm())) {
        throw Error(ErrorKind::kInvalidArgument,
                    "drop_joints: joint '" + skeleton.names[j] + "' has a non-zero offset");
      }
      out.kept_position[j] = out.kept_position[p];
      continue;
    }
    const int k = static_cast<int>(out.source.size());
    out.kept_position[j] = k;
    out.source.push_back(j);
    out.skeleton.names.push_back(skeleton.names[j]);
    const int kp = p < 0 ? -1 : out.kept_position[p];
    out.skeleton.parents.push_back(kp);
    out.skeleton.offsets.push_back(kp < 0 ? rest[j] : Eigen::Vector3d(rest[j] - rest[out.source[kp]]));
  }
  out.skeleton.has_rest_pose = skeleton.has_rest_pose;
  return out;
}

std::vector<double> rest_bone_lengths(const Skeleton& skeleton) {
  std::vector<double> lengths(skeleton.joint_count(), 0.0);
  for (int j = 1; j < skeleton.joint_count(); ++j) lengths[j] = skeleton.offsets[j].norm();
  return lengths;
}

int pair_index(int joints, int a, int b) {
  const int u = std::min(a, b), v = std::max(a, b);
  // Rows u = 0 .. u-1 hold (n-1) + (n-2) + ... + (n-u) pairs.
  return u * (2 * joints - u - 1) / 2 + (v - u - 1);
}

PairTable build_pair_table(const std::vector<int>& parents) {
  const int n = static_cast<int>(parents.size());
  if (n < 2) throw Error(ErrorKind::kInvalidArgument, "retarget: a skeleton needs at least 2 joints");
  if (parents[0] != -1) throw Error(ErrorKind::kInvalidArgument, "retarget: joint 0 must be the root");
  for (int j = 1; j < n; ++j) {
    if (parents[j] < 0 || parents[j] >= j) {
      throw Error(ErrorKind::kInvalidArgument,
                  "retarget: parents must be topological (0 <= parent < joint), joint " + std::to_string(j));
    }
  }
  PairTable t;
  t.joints = n;
  t.pairs = n * (n - 1) / 2;
  t.parents = parents;
  std::vector<int> depth(n, 0);
  for (int j = 1; j < n; ++j) depth[j] = depth[parents[j]] + 1;
  t.u.reserve(t.pairs);
  t.v.reserve(t.pairs);
  t.lca.reserve(t.pairs);
  t.path_size.reserve(t.pairs);
  t.path_offset.reserve(t.pairs + 1);
  t.path_offset.push_back(0);
  t.is_bone.reserve(t.pairs);
  t.bone_pair.assign(n, -1);
  std::vector<int> down;  // the v-side half of a path, collected upwards then reversed
  for (int u = 0; u < n; ++u) {
    for (int v = u + 1; v < n; ++v) {
      // Climb from the deeper end until both meet: the joints passed are the path.
      int a = u, b = v;
      down.clear();
      const int start = static_cast<int>(t.path_joints.size());
      while (a != b) {
        if (depth[a] >= depth[b]) {
          t.path_joints.push_back(a);
          a = parents[a];
        } else {
          down.push_back(b);
          b = parents[b];
        }
      }
      t.path_joints.push_back(a);
      t.path_joints.insert(t.path_joints.end(), down.rbegin(), down.rend());
      const int size = static_cast<int>(t.path_joints.size()) - start;
      t.u.push_back(u);
      t.v.push_back(v);
      t.lca.push_back(a);
      t.path_size.push_back(size);
      t.path_offset.push_back(static_cast<int>(t.path_joints.size()));
      const bool bone = parents[v] == u;
      t.is_bone.push_back(bone ? 1 : 0);
      if (bone) t.bone_pair[v] = static_cast<int>(t.u.size()) - 1;
      t.max_path = std::max(t.max_path, size);
    }
  }
  t.priority.resize(t.pairs);
  for (int p = 0; p < t.pairs; ++p) {
    t.priority[p] = static_cast<double>(t.max_path - t.path_size[p] + 2) / t.max_path;
  }
  return t;
}

void bone_lengths(const PairTable& table, const double* x, double* out) {
  out[0] = 0.0;
  for (int j = 1; j < table.joints; ++j) {
    const int p = table.parents[j];
    const double dx = x[3 * j] - x[3 * p], dy = x[3 * j + 1] - x[3 * p + 1], dz = x[3 * j + 2] - x[3 * p + 2];
    out[j] = std::sqrt(dx * dx + dy * dy + dz * dz);
  }
}

void path_weights(const PairTable& table, const double* lengths, double* cumulative, double* tau) {
  cumulative[0] = 0.0;
  for (int j = 1; j < table.joints; ++j) cumulative[j] = cumulative[table.parents[j]] + lengths[j];
  const int* u = table.u.data();
  const int* v = table.v.data();
  const int* lca = table.lca.data();
  for (int p = 0; p < table.pairs; ++p) tau[p] = cumulative[u[p]] + cumulative[v[p]] - 2.0 * cumulative[lca[p]];
}

Eigen::MatrixXd normalised_distance_matrix(const PairTable& table, const Eigen::MatrixX3d& x,
                                           const std::vector<double>& lengths) {
  if (x.rows() != table.joints || static_cast<int>(lengths.size()) != table.joints) {
    throw Error(ErrorKind::kInvalidArgument, "normalised_distance_matrix: size mismatch");
  }
  std::vector<double> cumulative(table.joints), tau(table.pairs);
  path_weights(table, lengths.data(), cumulative.data(), tau.data());
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(table.joints, table.joints);
  for (int p = 0; p < table.pairs; ++p) {
    const double dist = (x.row(table.u[p]) - x.row(table.v[p])).norm();
    const double value = tau[p] > 0.0 ? dist / tau[p] : 0.0;
    d(table.u[p], table.v[p]) = value;
    d(table.v[p], table.u[p]) = value;
  }
  return d;
}

}  // namespace kata::retarget
