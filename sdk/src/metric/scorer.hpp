// Scoring a pose stream against a teacher (spec gpd-v1.md section 6; issue 3): a compiled model
// (Metric), a reference built once from a teacher pose or clip (Reference), and a per-stream
// Scorer that turns each student feature vector into a distance, a 0-100 score, a per-part
// breakdown and, for a clip, the matched teacher frame.
//
// Per frame:  x'' = unit((x - min) / (max - min))   (or the block-balanced variant, model.hpp)
//             e = x'' - y'',  u = W^T e = W^T x'' - W^T y''   (W^T y'' precomputed per reference)
//             d = |u|,  score = 100 / (1 + (d / delta*)^2)
//             part p = sum_i share_p(i) e_i (M e)_i,  M = W W^T,  (M e)_i = W_i . u  (parts.hpp)
// The breakdown is computed without M and without a second pass over W: dimensions are grouped
// by their part set (rows of W permuted so each group is contiguous), one pass over W yields the
// per-group products V_g = W_g^T x''_g, and part p = u . sum_g share_p(g) (V_g(x) - V_g(y)).
//
// Clip alignment compares only the static blocks (dims 0..1590, pose geometry): a student who is
// slower or faster than the teacher differs in the kinetics block by design, and that
// difference must not pull the match to the wrong teacher moment (it still counts in the score).
//
// Threads: Metric and Reference are immutable after construction and may be shared by any
// number of threads and streams. A Scorer belongs to one stream, used by one thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "gpd/gpd.hpp"
#include "metric/kernels.hpp"
#include "metric/model.hpp"
#include "metric/parts.hpp"

namespace kata::metric {

// Rows of a frame's projection: the five parts, then the static blocks (alignment).
constexpr int kProjectionRows = kParts + 1;

// The documented score map: 100 / (1 + (d / delta*)^2). Monotone decreasing in d >= 0;
// d = 0 -> 100, d = delta* -> 50, d = 2 delta* -> 20, d = 3 delta* -> 10; never below 0.
// Chosen over a Gaussian because it keeps telling poses apart far beyond delta* (coaching).
double score_from_distance(double distance, double delta_star);

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
  gpd::Stencil stencil() const { return stencil_; }
  Normalisation normalisation() const { return normalisation_; }
  // Floats per projection row (rank rounded up to 8). A frame's projection is kProjectionRows
  // rows: the kParts part projections, then the static-blocks projection used for alignment.
  int stride() const { return stride_; }
  // Number of dimension groups (distinct part sets) and the rows of W each holds.
  int groups() const { return static_cast<int>(group_mask_.size()); }

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
  // then row kParts = W^T x'' restricted to the static blocks: kProjectionRows x stride floats,
  // padding 0. Allocation-free.
  void part_projections(const float* x, Workspace& ws, float* p) const;
  // The same for n frames at once (any n; every W row is loaded once per kBatch frames): x[f],
  // ws[f], p[f] for f < n. Results equal part_projections' bit for bit.
  void part_projections_batch(const float* const* x, Workspace* const* ws, float* const* p, int n) const;

 private:
  void finish(const Workspace& ws, double sumsq, float* p) const;

  int rank_ = 0, stride_ = 0;
  double delta_star_ = 0.0;
  gpd::Stencil stencil_ = gpd::Stencil::kBackward;
  Normalisation normalisation_ = Normalisation::kMinMaxUnit;
  std::vector<int> perm_;          // row k of the blocked W multiplies feature perm_[k]
  AlignedFloats shift_, gain_;     // per feature: x' = (x - shift) * gain
  AlignedFloats w_;                // blocked W (kernels.hpp)
  std::vector<int> group_begin_;   // groups + 1
  std::vector<uint8_t> group_mask_;  // part bit set per group
  std::vector<uint8_t> group_static_;  // 1 when the group's dimensions are in blocks 1..8
  detail::BlockedW blocked_;
  // Output row r (part r, or the static row) = sum of share-weighted group products.
  std::vector<int> combine_begin_, combine_group_;
  std::vector<float> combine_weight_;
  detail::Combine combine_;
};

// What a reference is: one pose, or a clip to follow.
enum class ReferenceKind : int { kPose = 0, kClip = 1 };

// A teacher reference: the part projections of each reference frame, computed once.
// Immutable; [any thread].
class Reference {
 public:
  // A single pose: one feature vector (kDims floats, e.g. one frame of a teacher clip's features).
  Reference(std::shared_ptr<const Metric> metric, const float* features);
  // A clip: `frames` feature vectors (frames x kDims, row-major), `frame_time` seconds apart.
  Reference(std::shared_ptr<const Metric> metric, const float* features, int frames, double frame_time);
  // A pose given as the 16 GPD joints' world positions (16 x 3 floats, +Y up, any units) and the
  // body height in the same units: a static pose (kinetics zero). Throws kInvalidArgument.
  static Reference from_joints(std::shared_ptr<const Metric> metric, const float* joints, double body_height);

  ReferenceKind kind() const { return kind_; }
  int frames() const { return frames_; }
  double frame_time() const { return frame_time_; }  // seconds; 0 for a pose
  // Median distance between consecutive reference frames (clip only; 0 for a pose): the scale of
  // one frame of teacher motion, used by the alignment's step penalty.
  double step_cost() const { return step_cost_; }
  const Metric& metric() const { return *metric_; }
  // Projection of frame j: kProjectionRows x stride floats (Metric::part_projections).
  const float* part_projection(int j) const {
    return rows_.data() + static_cast<size_t>(j) * kProjectionRows * stride_;
  }
  // The static-blocks projection of frame j (stride floats): what the alignment compares.
  const float* alignment_projection(int j) const { return part_projection(j) + static_cast<size_t>(kParts) * stride_; }

 private:
  void build(const float* features);

  std::shared_ptr<const Metric> metric_;
  ReferenceKind kind_ = ReferenceKind::kPose;
  int frames_ = 0, stride_ = 0;
  double frame_time_ = 0.0;
  double step_cost_ = 0.0;
  AlignedFloats rows_;
};

// One scored frame.
struct ScoreRecord {
  double time = 0.0;          // timestamp of the scored frame, seconds (stream clock)
  int64_t frame = -1;         // count of frames scored before this one by this Scorer
  float distance = 0.0f;      // d = |W^T (x'' - y'')|, dimensionless
  float score = 0.0f;         // score_from_distance(d, delta*), 0..100
  float parts[kParts] = {};   // split of d^2 (sums to d^2), in Part order
  int32_t matched = 0;        // matched reference frame (0 for a pose reference)
};

// Online alignment of a student to a clip reference.
struct AlignmentOptions {
  // How far ahead of the last match a student frame may be matched, in teacher seconds.
  double window = 0.5;
  // The fastest the teacher may advance per student second (2 = the student may run twice as
  // fast); sets the largest step of the warping path.
  double max_rate = 2.0;
  // Cost of a warping step that advances further than expected (a = dt_student / frame_time
  // teacher frames), per extra teacher frame, in units of the clip's median frame-to-frame
  // distance: penalty(k) = step_penalty * step_cost * max(0, k - a). It keeps the match from
  // jumping ahead through stretches where the teacher barely moves; holding (k < a) is free,
  // since students pause and lag. 0.25 was the best of {0, 0.25, 0.5, 1} on the shipped clips
  // slowed by 10%, sped up by 15% and delayed by 0.3 s (tests/metric/test_align.cpp).
  double step_penalty = 0.25;
};

// Scores one stream's frames against a reference. Allocates at construction only.
// [one thread at a time].
//
// Clip alignment (an online, open-end DTW restricted to a band): with c(n, j) = |s_n - s_j| the
// distance of the static-blocks projections (see above) of student frame n and teacher frame j,
// the cost of matching student frame n to teacher frame j, the accumulated cost is
// D(n, j) = c(n, j) + min_{k = 0..K} [D(n-1, j-k) + penalty(k)], K = max(1, ceil(max_rate *
// dt_student / frame_time)), penalty as in AlignmentOptions::step_penalty. Only j in [m(n-1), m(n-1) + window] is evaluated (the band moves forward with the
// match), and the match is m(n) = argmin_j D(n, j) over the band: never backwards, and never
// more than K frames ahead of the band's previous end. The first frame matches within
// [0, window] of the clip's start.
class Scorer {
 public:
  explicit Scorer(std::shared_ptr<const Reference> reference, AlignmentOptions options = {});

  // Scores features x (kDims floats) of a frame at time t (seconds, increasing). Allocation-free.
  const ScoreRecord& score(const float* x, double t);
  // Scores one frame on each of n scorers at once, sharing each pass over W (the scorers must
  // use the same Metric and be distinct). Allocation-free; results equal score()'s.
  static void score_batch(Scorer* const* scorers, const float* const* x, const double* t, int n);

  const ScoreRecord& last() const { return record_; }
  const Reference& reference() const { return *reference_; }
  // Restarts the alignment (the next frame is matched from the clip's start) and the frame count.
  void reset();

 private:
  void finish(double t);
  int align(const float* s, double t);  // s: the frame's static-blocks projection

  std::shared_ptr<const Reference> reference_;
  AlignmentOptions options_;
  Metric::Workspace ws_;
  AlignedFloats p_;                 // kProjectionRows x stride: this frame's projections
  AlignedFloats u_;                 // stride: u = W^T (x'' - y'')
  std::vector<double> cost_prev_, cost_cur_;  // accumulated DTW cost over teacher frames
  int lo_ = 0, hi_ = -1, match_ = 0;
  double last_time_ = 0.0;
  int64_t count_ = 0;
  ScoreRecord record_;
};

}  // namespace kata::metric
