// The whole `kata train` and `kata eval` work, file-level: clips + pair files in, a Model (or
// precision figures) out. The CLI only parses flags and prints.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "metric/model.hpp"
#include "train/clips.hpp"
#include "train/pairs.hpp"
#include "train/rdsr.hpp"

namespace kata::train {

// BVH files in `dir` (sorted). With subjects, only "NN_*.bvh" with NN among them (CMU naming).
std::vector<std::string> list_clips(const std::string& dir, const std::vector<int>& subjects);
// Deterministic clip split: every `every`-th clip of the sorted list (index % every == every - 1)
// is "val", the rest "train". every <= 1: no split (all "train").
std::vector<std::string> split_clips(const std::vector<std::string>& clips, int every, const std::string& part);

struct TrainConfig {
  int unlabeled = 5000;  // N' (0: eq. 46)
  uint64_t seed = 1;
  metric::Normalisation normalisation = metric::Normalisation::kMinMaxUnit;
  RdsrOptions rdsr;
  // Gain on the normalised kinetics block (block 9, dims 1591..1682) before the unit-length step;
  // 1 = the plain normalisation. Min/max normalisation squeezes the kinetics (their ranges are
  // set by rare fast frames), so they carry little of |x''|; a transition metric needs them.
  // With a gain != 1 the model stores its normalisation as per-dimension shift and scale
  // (Normalisation::kBlockBalanced's arrays, which any scorer applies): shift = min, scale =
  // gain / (max - min) for min/max.
  double kinetic_weight = 1.0;
  // When set: also write the benchmark set of the sparse-coding stage there (X.npy, d x N'
  // normalised poses, and problems.csv: 20 problems i with our objective, support and time) for
  // docs/model/lasso_vs_sklearn.py.
  std::string lasso_compare_dir;
  int lasso_compare_count = 20;
};

struct TrainOutput {
  metric::Model model;
  RdsrResult rdsr;
  Normaliser normaliser;
  Precision train_precision;  // delta* on the training pairs
  std::vector<StageTime> stages;  // including features and delta*
  // Sweep variants (RdsrOptions::sweep_*), each a complete model with its own delta*.
  std::vector<RdsrVariant> variants;
  std::vector<metric::Model> variant_models;
};

// clips: unlabeled pool (file names); pairs: the labeled pairs (positives feed S_W; all give
// delta*). `description` goes into the model's metadata (data, parameters).
TrainOutput train_model(ClipStore& store, const std::vector<std::string>& clips, const std::vector<PairRecord>& pairs,
                        const TrainConfig& config, const Log& log = {});

// Raw feature rows of pair ends.
struct PairRows {
  std::vector<const float*> a, b;
  std::vector<int> label;
};
PairRows pair_rows(ClipStore& store, const std::vector<PairRecord>& pairs);
Eigen::MatrixXd normalised_columns(const Normaliser& n, const std::vector<const float*>& rows);

// A model's normaliser (from its stored ranges) and W as double.
Normaliser model_normaliser(const metric::Model& model);
Eigen::MatrixXd model_w(const metric::Model& model);

}  // namespace kata::train
