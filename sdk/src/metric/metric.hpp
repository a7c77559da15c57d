// The compiled metric (spec gpd-v1.md section 6): a .kata model folded for scoring, its
// score map and the aligned float buffers the kernels work on.
//
// Per frame:  x'' = unit((x - min) / (max - min))   (or the block-balanced variant, model.hpp)
//             (W held as 16-bit integers with a scale per column: weights(), kernels.hpp)
//             e = x'' - y'',  u = W^T e = W^T x'' - W^T y''   (W^T y'' precomputed per reference)
//             d = |u|,  score = 100 / (1 + (d / delta*)^2)
//             part p = sum_i share_p(i) e_i (M e)_i,  M = W W^T,  (M e)_i = W_i . u  (parts.hpp)
//             part distance d_p = |W^T (jc_p o e)|  (jc_p: the joint coordinates of part p's joints)
// The breakdown is computed without M and without a second pass over W: dimensions are grouped
// by their part set (rows of W permuted so each group is contiguous), one pass over W yields the
// per-group products V_g = W_g^T x''_g, and part p = u . sum_g share_p(g) (V_g(x) - V_g(y)).
//
// Threads: a Metric is immutable after construction and may be shared by any number of threads
// and streams.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "gpd/gpd.hpp"
#include "metric/kernels.hpp"
#include "metric/model.hpp"
#include "metric/parts.hpp"

namespace kata::metric {

// Rows of a frame's projection: the five share-split parts (their sum is W^T x'', the split of
// d^2), the static blocks (alignment), then the five joint-position rows: W^T restricted to the
// joint coordinates (block Jc) of each part's joints, from which each part's distance is taken.
// Why the part distance has rows of its own: a dimension shared by two parts (a distance, an
// angle between them) moves when either part moves, so the share split credits a part with what
// another part did; a joint coordinate belongs to one joint (docs/model/scores.md).
constexpr int kStaticRow = kParts;
constexpr int kJointRows = kParts + 1;  // row kJointRows + p: part p's joint coordinates
constexpr int kProjectionRows = 2 * kParts + 1;

// The documented score map: 100 / (1 + (d / delta*)^2). Monotone decreasing in d >= 0;
// d = 0 -> 100, d = delta* -> 50, d = 2 delta* -> 20, d = 3 delta* -> 10; never below 0.
// Chosen over a Gaussian because it keeps telling poses apart far beyond delta* (coaching).
double score_from_distance(double distance, double delta_star);
// The calibrated map (model.hpp ScoreCalibration): 100 / (1 + (d / d50)^slope). Monotone
// decreasing in d >= 0; 100 at d = 0, 50 at d50; in [0, 100] for every d >= 0 (never NaN).
double calibrated_score(double distance, double d50, double slope);

// Float buffer aligned to 32 bytes (one AVX register), sized once.
class AlignedFloats {
 public:
  AlignedFloats() = default;
  explicit AlignedFloats(size_t n);
  float* data() { return p_.get(); }
  const float* data() const { return p_.get(); }
  size_t size() const { return n_; }

 private:
  struct Free {
    void operator()(float* p) const;
  };
  std::unique_ptr<float[], Free> p_;
  size_t n_ = 0;
};

// A model compiled for scoring: folded normalisation constants, W in the blocked, part-grouped
// layout (kernels.hpp) and the part shares of each group. Immutable; [any thread].
class Metric {
 public:
  // Checks the model (validate_model) and compiles it. Throws kata::Error(kModel).
  explicit Metric(const Model& model);

  int rank() const { return rank_; }
  double delta_star() const { return delta_star_; }
  // The model's score map, or default_calibration(delta*) for a model without one.
  const ScoreCalibration& calibration() const { return calibration_; }
  gpd::Stencil stencil() const { return stencil_; }
  Normalisation normalisation() const { return normalisation_; }
  // Floats per projection row (rank rounded up to 8). A frame's projection is kProjectionRows
  // rows: the kParts part projections, then the static-blocks projection used for alignment.
  int stride() const { return stride_; }
  // Number of dimension groups (distinct part sets) and the rows of W each holds.
  int groups() const { return static_cast<int>(group_mask_.size()); }

  // W as this CPU's kernels apply it: column-major kDims x rank floats, W[i, c] = q[i, c] *
  // weight_step(c) with q the stored 16-bit integers, or on a CPU running the AVX-512 kernels
  // the weights their pair-packed words decode to (kernels.hpp BlockedW); each within half a
  // step (plus 2^-9 step for the pairs) of the model's W. For tests and diagnostics (allocates).
  std::vector<float> weights() const;
  // The quantum of column c: max_i |W[i, c]| / 32767 of the model's W.
  float weight_step(int c) const { return column_scale_.data()[c]; }

  // Scratch of one projection, sized once (never reallocated by the calls below).
  struct Workspace {
    AlignedFloats xp;  // kDims: x' (normalised, before unit length), feature order
    AlignedFloats v;   // groups x stride: per-group partial products
  };
  Workspace make_workspace() const;

  // x'' (kDims floats, feature order) from raw features x (kDims floats): the model's
  // normalisation then unit length; all zeros if x' is zero. Allocation-free.
  void normalise(const float* x, float* out) const;
  // u = W^T x'' (rank floats, dimensionless) from raw features x. Allocation-free.
  void project(const float* x, Workspace& ws, float* u) const;
  // The per-part projections P_p = W^T (share_p o x'') (rows 0..kParts-1; their sum is W^T x''),
  // then row kStaticRow = W^T x'' restricted to the static blocks, then rows kJointRows + p =
  // W^T x'' restricted to part p's joint coordinates (block Jc; the hip height for the torso):
  // kProjectionRows x stride floats, padding 0. Allocation-free.
  void part_projections(const float* x, Workspace& ws, float* p) const;
  // The same for n frames at once (any n; every W row is loaded and converted once per pass of
  // up to 8 frames on AVX-512, 4 on the other ISAs): x[f], ws[f], p[f] for f < n. Results equal
  // part_projections' bit for bit.
  void part_projections_batch(const float* const* x, Workspace* const* ws, float* const* p, int n) const;

 private:
  void finish(const Workspace& ws, double sumsq, float* p) const;

  int rank_ = 0, stride_ = 0;
  double delta_star_ = 0.0;
  ScoreCalibration calibration_;
  gpd::Stencil stencil_ = gpd::Stencil::kBackward;
  Normalisation normalisation_ = Normalisation::kMinMaxUnit;
  std::vector<int> perm_;          // row k of the blocked W multiplies feature perm_[k]
  AlignedFloats shift_, gain_;     // per feature: x' = (x - shift) * gain
  std::vector<int16_t> w_;         // blocked W, 16-bit (kernels.hpp)
  std::vector<uint32_t> pairs_;    // the same W pair-packed for the AVX-512 kernels (empty without them)
  AlignedFloats column_scale_;     // rank: W[., c] = w_ * column_scale_[c]
  std::vector<int> group_begin_;   // groups + 1
  std::vector<uint8_t> group_mask_;  // part bit set per group
  std::vector<uint8_t> group_static_;  // 1 when the group's dimensions are in blocks 1..8
  std::vector<uint8_t> group_joint_;   // 1 when the group's dimensions are joint coordinates (Jc)
  detail::BlockedW blocked_;
  // Output row r (part r, the static row, or joint-position row r - kJointRows) = sum of
  // share-weighted group products.
  std::vector<int> combine_begin_, combine_group_;
  std::vector<float> combine_weight_;
  detail::Combine combine_;
};

namespace detail {
// a . b, |a - b|^2 (double accumulation) and |a - b|^2 in float over n floats (n a multiple of 8:
// projection rows are padded with zeros), in eight independent lanes: one serial chain would cost
// n x the add latency.
double dot(const float* a, const float* b, int n);
double dist2(const float* a, const float* b, int n);
float dist2f(const float* a, const float* b, int n);
}  // namespace detail

}  // namespace kata::metric
