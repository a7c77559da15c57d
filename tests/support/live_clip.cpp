#include "support/live_clip.hpp"

#include <mutex>

#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "support/clips.hpp"

namespace kata::test {

LiveClip::LiveClip(const std::string& name, int first)
    : clip_(&test::clip(name)),
      positions_(&test::clip_positions(name, first)),
      rows_(clip_->frame_count() - first) {}

transport::SkeletonDefinition LiveClip::definition(uint64_t id, uint32_t revision) const {
  transport::SkeletonDefinition d;
  d.stream_id = id;
  d.revision = revision;
  d.skeleton = clip_->skeleton;
  d.layout = "cmu";
  return d;
}

std::shared_ptr<const metric::Metric> default_metric() {
  static const std::shared_ptr<const metric::Metric> metric =
      std::make_shared<const metric::Metric>(metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  return metric;
}

std::shared_ptr<const pipeline::Teacher> clip_teacher(const std::shared_ptr<const metric::Metric>& metric,
                                                      const std::string& name, int first) {
  const BvhClip& c = test::clip(name);
  const std::vector<float>& positions = test::clip_positions(name, first);
  const GpdMap map = make_gpd_map(c.skeleton, preset_joint_names("cmu"));
  return pipeline::Teacher::from_positions(metric, c.skeleton, stream_config_for(c.skeleton, map, metric->stencil()),
                                           positions.data(), c.frame_count() - first, c.frame_time);
}

}  // namespace kata::test
