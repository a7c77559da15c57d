// Scoring a pose stream against a teacher (spec gpd-v1.md section 6; issue 3): a per-stream
// Scorer turns each student feature vector into a distance, a 0-100 score, a per-part breakdown
// and, for a clip, the matched teacher frame. Its parts live in their own headers, included here:
// the compiled model (metric.hpp: Metric, score_from_distance), the teacher (reference.hpp:
// Reference) and the clip alignment (align.hpp: Aligner, AlignmentOptions).
//
// Threads: Metric and Reference are immutable after construction and may be shared by any
// number of threads and streams. A Scorer belongs to one stream, used by one thread at a time.
#pragma once

#include <cstdint>
#include <memory>

#include "metric/align.hpp"
#include "metric/metric.hpp"
#include "metric/reference.hpp"

namespace kata::metric {

// One scored frame.
struct ScoreRecord {
  double time = 0.0;          // timestamp of the scored frame, seconds (stream clock)
  int64_t frame = -1;         // count of frames scored before this one by this Scorer
  float distance = 0.0f;      // d = |W^T (x'' - y'')|, dimensionless
  float score = 0.0f;         // score_from_distance(d, delta*), 0..100
  float parts[kParts] = {};   // split of d^2 (sums to d^2), in Part order
  int32_t matched = 0;        // matched reference frame (0 for a pose reference)
};

// Scores one stream's frames against a reference, following a clip reference with an Aligner
// (align.hpp). Allocates at construction only. [one thread at a time].
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

  std::shared_ptr<const Reference> reference_;
  Aligner aligner_;
  Metric::Workspace ws_;
  AlignedFloats p_;                 // kProjectionRows x stride: this frame's projections
  AlignedFloats u_;                 // stride: u = W^T (x'' - y'')
  int64_t count_ = 0;
  ScoreRecord record_;
};

}  // namespace kata::metric
