// Shared inputs of the metric tests: real GPD v1 features of shipped CMU clips (through the live
// stream path) and stand-in models with a random orthonormal W.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "io/bvh.hpp"
#include "support/random_model.hpp"
#include "metric/scorer.hpp"
#include "skeleton/skeleton.hpp"
#include "io/clip_features.hpp"

namespace kata::test {

inline std::string cmu(const std::string& name) { return std::string(KATA_DATA_DIR) + "/cmu/" + name; }

// Features of every frame but the T-pose (frame 0) of a shipped clip, backward stencil; cached.
inline const std::vector<float>& clip_rows(const std::string& name) {
  static std::map<std::string, std::vector<float>> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    const BvhClip clip = load_bvh(cmu(name));
    const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
    it = cache.emplace(name, clip_features(clip, map, gpd::Stencil::kBackward, 1)).first;
  }
  return it->second;
}
inline int clip_frames(const std::string& name) { return static_cast<int>(clip_rows(name).size() / gpd::kDims); }
inline const float* clip_row(const std::string& name, int i) { return clip_rows(name).data() + static_cast<size_t>(i) * gpd::kDims; }

// A model whose min/max span 02_01 and 05_02 (walk + dance), random orthonormal W.
inline const metric::Model& test_model(int rank = 50, uint64_t seed = 7) {
  static std::map<std::pair<int, uint64_t>, metric::Model> cache;
  auto key = std::make_pair(rank, seed);
  auto it = cache.find(key);
  if (it == cache.end()) {
    std::vector<float> all = clip_rows("02_01.bvh");
    const auto& dance = clip_rows("05_02.bvh");
    all.insert(all.end(), dance.begin(), dance.end());
    it = cache.emplace(key, metric::make_random_model(rank, seed, all.data(), static_cast<int>(all.size() / gpd::kDims),
                                                      "02_01.bvh, 05_02.bvh")).first;
  }
  return it->second;
}

inline std::shared_ptr<const metric::Metric> test_metric(int rank = 50, uint64_t seed = 7) {
  return std::make_shared<const metric::Metric>(test_model(rank, seed));
}

// Independent x'' in double: the spec's min/max normalisation then unit length.
inline Eigen::VectorXd dense_normalised(const metric::Model& m, const float* x) {
  Eigen::VectorXd v(gpd::kDims);
  for (int i = 0; i < gpd::kDims; ++i) {
    const double range = double(m.max[i]) - m.min[i];
    v[i] = range > 0.0 ? (double(x[i]) - m.min[i]) / range : 0.0;
  }
  const double n = v.norm();
  return n > 0.0 ? Eigen::VectorXd(v / n) : v;
}

// The model's W (kDims x rank) in double.
inline Eigen::MatrixXd dense_w(const metric::Model& m) {
  return Eigen::Map<const Eigen::MatrixXf>(m.w.data(), gpd::kDims, m.rank).cast<double>();
}

}  // namespace kata::test
