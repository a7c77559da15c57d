// A teacher reference (spec gpd-v1.md section 6): one pose or a clip, projected once by a Metric.
//
// Clip alignment compares only the static blocks (dims 0..1590, pose geometry): a student who is
// slower or faster than the teacher differs in the kinetics block by design, and that
// difference must not pull the match to the wrong teacher moment (it still counts in the score).
//
// Threads: a Reference is immutable after construction and may be shared by any number of
// threads and streams.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "metric/loading.hpp"
#include "metric/metric.hpp"
#include "metric/pose_error.hpp"

namespace kata::metric {

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
  // The same clip with its features streamed: `features(sink)` calls sink(chunk, n) with the
  // clip's frames in order, n x kDims floats a call, `frames` in all (e.g. features_in_chunks).
  // Each chunk is projected and let go, so loading a long teacher never holds its 6.7 KB a frame
  // of features (a long teacher's need not be held whole); the result is bit for bit the one-shot constructor's. Throws
  // kInvalidArgument as that does, and when the chunks do not add up to `frames`.
  using FeatureChunks = std::function<void(const std::function<void(const float* features, int count)>& sink)>;
  Reference(std::shared_ptr<const Metric> metric, const FeatureChunks& features, int frames, double frame_time);
  // A pose given as the 16 GPD joints' world positions (16 x 3 floats, +Y up, any units) and the
  // body height in the same units: a static pose (kinetics zero). Throws kInvalidArgument.
  static Reference from_joints(std::shared_ptr<const Metric> metric, const float* joints, double body_height);

  ReferenceKind kind() const { return kind_; }
  int frames() const { return frames_; }
  double frame_time() const { return frame_time_; }  // seconds; 0 for a pose
  // Median distance between consecutive reference frames (clip only; 0 for a pose): the scale of
  // one frame of teacher motion, used by the alignment's step penalty.
  double step_cost() const { return step_cost_; }
  // Median distance between two unrelated frames of the clip (pairs at least a second apart when
  // the clip is long enough; 0 for a pose): the cost of being at the wrong place, which sets the
  // alignment's re-localisation margin (align.hpp).
  double spread() const { return spread_; }
  const Metric& metric() const { return *metric_; }
  // What a frame's projection keeps (<= 2 KB a teacher frame; docs/model/alignment.md,
  // "Two kilobytes a teacher frame"). The scorer reads the kParts part rows and the kParts joint
  // rows (kScoreRows): each is kept as rank 16-bit integers with one float step (the row's largest
  // |value| / 32767), so a value is within half a step, 2^-16 of its row's largest, of the
  // projection's float; the same scheme as W's (kernels.hpp), and the error is absolute, which
  // is what the differences the scorer takes care about (half precision would be 2^-12 of each
  // value: 16x coarser on a row's large values). The static row (kStaticRow) is kept in float (the
  // offline DTW and the build read it) and as the aligner's half rows below.
  static constexpr int kScoreRows = 2 * kParts;
  // p (kProjectionRows x stride floats: a student frame's Metric::part_projections) minus frame
  // j's part and joint-position rows, as decoded, each difference within 0.51 steps taken as 0
  // (the teacher's own pose is at distance 0); row kStaticRow and the padding are left as they
  // are. What the scorer does every frame: allocation-free.
  void subtract_projection(int j, float* p) const;
  // Frame j's projection as kept, decoded (kProjectionRows x stride floats, padding 0). For tests
  // and diagnostics.
  void projection(int j, float* out) const;
  // The static-blocks projection of frame j (stride floats, row kStaticRow of its projection, in
  // float): what `--align dtw` compares (align_dtw.hpp) and the build's statistics (step cost,
  // spread, the half scale). Kept whole although the live aligner streams the half rows below:
  // the offline DTW's path turns on near ties (a held pose), and from the half rows it moved the
  // default lesson's matches on 8 % of its frames; 224 B a frame (rank 50) keeps it exact.
  const float* alignment_projection(int j) const { return static_rows_.data() + static_cast<size_t>(j) * stride_; }
  // The static-blocks rows in IEEE half precision, each value divided by alignment_half_scale()
  // (a power of two keeping every value within +-16384, so none overflows): what the live aligner
  // streams every frame (align_pass.hpp). Relative rounding 2^-11.
  const uint16_t* alignment_rows_half(int j) const { return align_half_.data() + static_cast<size_t>(j) * stride_; }
  float alignment_half_scale() const { return align_half_scale_; }
  // The re-localisation grid: a clip longer than kSearchFrames is searched on every
  // M-th frame only, M = ceil(frames / kSearchFrames) (1 otherwise), so the aligner's search over
  // a 20-minute teacher reads what it reads over a 30-second one (align.hpp, "Long teachers").
  // search_rows_half(i) is the half row of frame i * M, contiguous (frames / M rows): built once
  // here, shared by every aligner following this reference.
  static constexpr int kSearchFrames = 3584;
  int search_grid() const { return search_grid_; }
  int search_rows() const { return search_grid_ > 1 ? static_cast<int>(search_half_.size() / static_cast<size_t>(stride_)) : frames_; }
  const uint16_t* search_rows_half(int i) const {
    return search_grid_ > 1 ? search_half_.data() + static_cast<size_t>(i) * stride_ : alignment_rows_half(i);
  }
  // Bytes this Reference holds (its arrays' capacity; the budget is 2 KB a teacher frame).
  size_t memory_bytes() const;
  // Frame j's joints in the body's frames (pose_error.hpp pose_frames: kPoseFloats floats), from
  // which the scorer takes each part's angle and offset to the student's.
  const float* pose(int j) const { return poses_.data() + static_cast<size_t>(j) * kPoseFloats; }

 private:
  void check_clip(int frames, double frame_time) const;
  void begin();
  // Frames [first, first + count): their projections (kept as above) and poses. Calls for
  // disjoint frames may run on different threads at once.
  void add(const float* features, int first, int count);
  // What needs the whole clip, from the float static rows (the features are gone by then).
  void finish();

  std::shared_ptr<const Metric> metric_;
  ReferenceKind kind_ = ReferenceKind::kPose;
  int frames_ = 0, stride_ = 0;
  double frame_time_ = 0.0;
  double step_cost_ = 0.0;
  double spread_ = 0.0;
  int rank_ = 0;
  // Filled by add() (possibly on another thread: the first touch of their pages, loading.hpp).
  LargeArray<int16_t> score_rows_;  // frames x kScoreRows x rank: the part, then the joint rows
  LargeArray<float> score_scale_;   // frames x kScoreRows: each row's step
  LargeArray<float> static_rows_;   // frames x stride: the static rows in float
  LargeArray<float> poses_;         // frames x kPoseFloats
  LargeArray<uint16_t> align_half_;  // frames x stride
  float align_half_scale_ = 1.0f;
  int search_grid_ = 1;
  std::vector<uint16_t> search_half_;  // every search_grid_-th half row (search_grid_ > 1 only)
};

}  // namespace kata::metric
