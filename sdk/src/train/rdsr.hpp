// RDSR (paper section 4): normalisation, the scatter matrices S_W (eq. 13), X S_L X^T (eq. 17-18,
// through the sparse codes, never an N x N dense S_L), X S_C X^T (eq. 23), A and B (eq. 26-27),
// the trace-ratio solve, and delta* (eq. 37) — from feature matrices; no file or clip handling.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "metric/model.hpp"
#include "train/sparse_coding.hpp"
#include "train/trace_ratio.hpp"

namespace kata::train {

// Per-dimension normalisation (the Model's), fitted on training poses.
struct Normaliser {
  metric::Normalisation kind = metric::Normalisation::kMinMaxUnit;
  std::vector<float> min, max;      // kDims (always)
  std::vector<float> shift, scale;  // kDims for block-balanced
  // x (kDims raw floats) -> out (kDims, unit length unless all zero).
  void apply(const float* x, double* out) const;
  Eigen::VectorXd operator()(const float* x) const;
};

// rows: pointers to raw feature vectors (gpd::kDims floats each).
Normaliser fit_normaliser(const std::vector<const float*>& rows, metric::Normalisation kind);

// Multiplies the normalised kinetics block (block 9) by `gain` before the unit-length step. A
// min/max normaliser becomes the per-dimension shift/scale kind (shift = min, scale = 1 / range,
// 0 for a constant dimension) with the same output at gain 1; a block-balanced one keeps its
// kind. Throws kInvalidArgument unless gain is finite and > 0.
void weigh_kinetics(Normaliser& n, double gain);

// A pair of poses (as columns of some matrix) with a 1/0 label.
struct IndexPair {
  int a = 0, b = 0;
  int label = 1;
};

// Eq. 37: the best proportion of correct decisions over all thresholds (d < delta => positive).
struct Precision {
  double precision = 0.0;
  double threshold = 0.0;  // a delta achieving it (midway between neighbouring distances)
  int correct = 0, total = 0;
};
Precision best_threshold(const std::vector<double>& distance, const std::vector<int>& label);

struct RdsrOptions {
  int rank = 50;
  double alpha = 1.0;            // weight of S_W ...
  bool alpha_relative = true;    // ... times Tr(X S_L X^T) / Tr(S_W) when true
  LassoOptions lasso;            // gamma, tolerance, threads
  int threads = 2;
  std::string solver = "newton";  // newton | bisection | both
  // > 0: restrict W to the span of the top `pca` principal directions of the unlabeled poses
  // (eigenvectors of X S_C X^T), W = P V, solving the trace ratio for V on P^T A P, P^T B P.
  // Not in the paper: the classic remedy (as PCA before LDA) for scatter matrices that are
  // near-singular in directions the training poses barely span. 0 = the paper's problem.
  int pca = 0;
  // > 0: add the negative pairs' scatter to the numerator, A = X S_C X^T + beta S_B with S_B the
  // eq. 13 scatter of the negative pairs' differences and beta = negative_weight x Tr(X S_C X^T) /
  // Tr(S_B) (so 1 gives both terms the same trace). Not in the paper: its A only spreads the
  // unlabeled poses; with it W also keeps apart what the proxy labels call dissimilar, which a
  // transition metric needs when every candidate pair is already close in pose. The PCA
  // restriction then takes the top directions of this A. 0 = the paper's A.
  double negative_weight = 0.0;
  // GPD blocks (1..9, in gpd.hpp's order; 1 = joint coordinates, 9 = kinetics) W may use: W's rows
  // outside them are zero, and the trace ratio (and the PCA restriction) is solved on the
  // scatter matrices' rows and columns of those dimensions only. The normalisation and the sparse
  // codes still see the whole vector. Not in the paper: a transition metric between poses already
  // matched by MJD must put its distance on where the bodies go (block 9), and the whole-vector
  // objective keeps choosing static directions (docs/model/transition.md). Empty = every block.
  std::vector<int> blocks;
  // Extra (alpha, rank) combinations solved on the same scatter matrices (sweeps; Newton only).
  std::vector<double> sweep_alphas;
  std::vector<int> sweep_ranks;
};

struct RdsrVariant {
  double alpha = 0.0, alpha_absolute = 0.0, eta = 0.0;
  int rank = 0;
  Eigen::MatrixXd w;
};

struct StageTime {
  std::string name;
  double seconds = 0.0;
};

struct RdsrResult {
  Eigen::MatrixXd w;  // kDims x rank
  double eta = 0.0, eta_bisection = 0.0;
  TraceRatioBounds bounds;
  int eigen_solves = 0;
  double alpha_absolute = 0.0;
  double trace_sl = 0.0, trace_sw = 0.0, trace_sc = 0.0;
  double trace_sb = 0.0, beta_absolute = 0.0;  // negative pairs' scatter (negative_weight > 0)
  SparseCodingStats coding;
  std::vector<StageTime> stages;
  std::vector<RdsrVariant> variants;  // one per sweep_alphas x sweep_ranks
};

using Log = std::function<void(const std::string&)>;

// x: d x N' normalised unlabeled poses (N' may be 0: eq. 46, W = the r smallest eigenvectors of
// S_W); pa, pb: d x P normalised ends of the positive pairs.
// na, nb: d x Q normalised ends of the negative pairs (used only when negative_weight > 0).
RdsrResult train_rdsr(const Eigen::MatrixXd& x, const Eigen::MatrixXd& pa, const Eigen::MatrixXd& pb,
                      const RdsrOptions& options, const Log& log = {}, const Eigen::MatrixXd& na = {},
                      const Eigen::MatrixXd& nb = {});

// S_W of eq. 13 from the pair ends.
Eigen::MatrixXd within_scatter(const Eigen::MatrixXd& pa, const Eigen::MatrixXd& pb, int threads);
// X S_L X^T = (X - X A)(X - X A)^T with the codes (row i = a_i).
Eigen::MatrixXd laplacian_scatter(const Eigen::MatrixXd& x, const CsrMatrix& codes, int threads);
// X S_C X^T = (X - mean)(X - mean)^T.
Eigen::MatrixXd centered_scatter(const Eigen::MatrixXd& x, int threads);

// The dimensions (sorted) of GPD blocks `blocks` (1..9); every dimension when empty. Throws
// kInvalidArgument for a block outside 1..9 or one named twice.
std::vector<int> block_dimensions(const std::vector<int>& blocks);

// Distance |W^T (x - y)| for normalised x, y.
double projected_distance(const Eigen::MatrixXd& w, const Eigen::VectorXd& x, const Eigen::VectorXd& y);

}  // namespace kata::train
