// A shipped clip played as a live stream: its frames by index (wrapping round the clip), the
// skeleton definition a source sends for it, and the teacher the runtime tests score against.
// What the runtime, ingest and transport tests share instead of each declaring its own copy.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "metric/metric.hpp"
#include "pipeline/pipeline.hpp"
#include "transport/wire.hpp"

namespace kata::test {

class LiveClip {
 public:
  // data/cmu/<name>.bvh from clip frame `first` on (1 skips the CMU clips' T-pose).
  explicit LiveClip(const std::string& name, int first = 1);

  const BvhClip& clip() const { return *clip_; }
  const std::vector<float>& positions() const { return *positions_; }
  int joints() const { return clip_->skeleton.joint_count(); }
  int rows() const { return rows_; }                 // frames from `first` on
  double frame_time() const { return clip_->frame_time; }
  // Row i % rows(): joints() x 3 floats, world positions.
  const float* frame(int64_t i) const {
    return positions_->data() + static_cast<size_t>(i % rows_) * 3 * static_cast<size_t>(joints());
  }
  // The definition a source sends for stream `id` of this clip (layout "cmu").
  transport::SkeletonDefinition definition(uint64_t id, uint32_t revision = 1) const;

 private:
  const BvhClip* clip_;
  const std::vector<float>* positions_;
  int rows_;
};

// The shipped default model (models/default.kata), loaded once per process.
std::shared_ptr<const metric::Metric> default_metric();
// A teacher of the clip's frames from `first` on, scored with `metric` (cmu layout), as kata
// serve builds one from a clip.
std::shared_ptr<const pipeline::Teacher> clip_teacher(const std::shared_ptr<const metric::Metric>& metric,
                                                      const std::string& name, int first = 1);

}  // namespace kata::test
