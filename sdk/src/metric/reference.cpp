#include "metric/reference.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common/error.hpp"

namespace kata::metric {

using detail::dist2;

Reference::Reference(std::shared_ptr<const Metric> metric, const float* features)
    : metric_(std::move(metric)), kind_(ReferenceKind::kPose), frames_(1) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  build(features);
}

Reference::Reference(std::shared_ptr<const Metric> metric, const float* features, int frames, double frame_time)
    : metric_(std::move(metric)), kind_(ReferenceKind::kClip), frames_(frames), frame_time_(frame_time) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  if (frames < 1) throw Error(ErrorKind::kInvalidArgument, "reference clip: no frames");
  if (!(frame_time > 0.0) || !std::isfinite(frame_time))
    throw Error(ErrorKind::kInvalidArgument, "reference clip: frame time must be > 0 seconds");
  build(features);
}

void Reference::build(const float* features) {
  stride_ = metric_->stride();
  for (size_t i = 0; i < static_cast<size_t>(frames_) * gpd::kDims; ++i)
    if (!std::isfinite(features[i]))
      throw Error(ErrorKind::kInvalidArgument, "reference: NaN/Inf in the features of frame " +
                                                   std::to_string(i / gpd::kDims));
  rows_ = AlignedFloats(static_cast<size_t>(frames_) * kProjectionRows * stride_);
  Metric::Workspace ws = metric_->make_workspace();
  for (int j = 0; j < frames_; ++j)
    metric_->part_projections(features + static_cast<size_t>(j) * gpd::kDims, ws,
                              rows_.data() + static_cast<size_t>(j) * kProjectionRows * stride_);
  if (frames_ > 1) {
    std::vector<double> steps(static_cast<size_t>(frames_ - 1));
    for (int j = 0; j + 1 < frames_; ++j)
      steps[static_cast<size_t>(j)] = std::sqrt(dist2(alignment_projection(j + 1), alignment_projection(j), stride_));
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
    step_cost_ = steps[steps.size() / 2];
  }
}

Reference Reference::from_joints(std::shared_ptr<const Metric> metric, const float* joints, double body_height) {
  if (!joints) throw Error(ErrorKind::kInvalidArgument, "reference pose: null joints");
  if (!(body_height > 0.0) || !std::isfinite(body_height))
    throw Error(ErrorKind::kInvalidArgument, "reference pose: body height must be > 0");
  for (int i = 0; i < gpd::kJoints * 3; ++i)
    if (!std::isfinite(joints[i])) throw Error(ErrorKind::kInvalidArgument, "reference pose: NaN/Inf in the joints");
  std::vector<float> x(gpd::kDims), local(gpd::kJoints * 3);
  gpd::GeometryState state;
  float hip = 0.0f;
  gpd::to_local_frame(joints, body_height, state, local.data(), &hip);
  gpd::static_features(local.data(), hip, state, x.data());
  gpd::kinetics_zero(x.data() + gpd::kOffsetJk);  // a held pose: no motion
  return Reference(std::move(metric), x.data());
}

}  // namespace kata::metric
