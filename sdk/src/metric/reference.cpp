#include "metric/reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "metric/align_pass.hpp"

namespace kata::metric {

using detail::dist2;

Reference::Reference(std::shared_ptr<const Metric> metric, const float* features)
    : metric_(std::move(metric)), kind_(ReferenceKind::kPose), frames_(1) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  begin();
  add(features, 0, 1);
  finish();
}

Reference::Reference(std::shared_ptr<const Metric> metric, const float* features, int frames, double frame_time)
    : metric_(std::move(metric)), kind_(ReferenceKind::kClip), frames_(frames), frame_time_(frame_time) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  check_clip(frames, frame_time);
  begin();
  add(features, 0, frames);
  finish();
}

Reference::Reference(std::shared_ptr<const Metric> metric, const FeatureChunks& features, int frames,
                     double frame_time)
    : metric_(std::move(metric)), kind_(ReferenceKind::kClip), frames_(frames), frame_time_(frame_time) {
  if (!metric_ || !features) throw Error(ErrorKind::kInvalidArgument, "reference: null model or features");
  check_clip(frames, frame_time);
  begin();
  int done = 0;
  features([&](const float* chunk, int count) {
    if (!chunk || count < 0 || count > frames_ - done)
      throw Error(ErrorKind::kInvalidArgument, "reference clip: more feature frames than the " +
                                                   std::to_string(frames_) + " announced");
    add(chunk, done, count);
    done += count;
  });
  if (done != frames_)
    throw Error(ErrorKind::kInvalidArgument, "reference clip: " + std::to_string(done) + " feature frames of the " +
                                                 std::to_string(frames_) + " announced");
  finish();
}

void Reference::check_clip(int frames, double frame_time) const {
  if (frames < 1) throw Error(ErrorKind::kInvalidArgument, "reference clip: no frames");
  if (!(frame_time > 0.0) || !std::isfinite(frame_time))
    throw Error(ErrorKind::kInvalidArgument, "reference clip: frame time must be > 0 seconds");
}

void Reference::begin() {
  stride_ = metric_->stride();
  rows_ = AlignedFloats(static_cast<size_t>(frames_) * kProjectionRows * stride_);
  poses_.resize(static_cast<size_t>(frames_) * kPoseFloats);
}

void Reference::add(const float* features, int first, int count) {
  for (size_t i = 0; i < static_cast<size_t>(count) * gpd::kDims; ++i)
    if (!std::isfinite(features[i]))
      throw Error(ErrorKind::kInvalidArgument, "reference: NaN/Inf in the features of frame " +
                                                   std::to_string(first + static_cast<int>(i / gpd::kDims)));
  Metric::Workspace ws = metric_->make_workspace();
  for (int j = 0; j < count; ++j)
    metric_->part_projections(features + static_cast<size_t>(j) * gpd::kDims, ws,
                              rows_.data() + static_cast<size_t>(first + j) * kProjectionRows * stride_);
  for (int j = 0; j < count; ++j)
    pose_frames(features + static_cast<size_t>(j) * gpd::kDims,
                poses_.data() + static_cast<size_t>(first + j) * kPoseFloats);
}

void Reference::finish() {
  float largest = 0.0f;
  for (int j = 0; j < frames_; ++j)
    for (int i = 0; i < stride_; ++i) largest = std::max(largest, std::fabs(alignment_projection(j)[i]));
  align_half_scale_ = 1.0f;
  while (largest / align_half_scale_ > 16384.0f) align_half_scale_ *= 2.0f;
  align_half_.resize(static_cast<size_t>(frames_) * stride_);
  for (int j = 0; j < frames_; ++j)
    for (int i = 0; i < stride_; ++i)
      align_half_[static_cast<size_t>(j) * stride_ + i] = detail::float_to_half(alignment_projection(j)[i] / align_half_scale_);
  if (kind_ == ReferenceKind::kClip && frames_ > kSearchFrames) {
    search_grid_ = (frames_ + kSearchFrames - 1) / kSearchFrames;
    const int rows = (frames_ - 1) / search_grid_ + 1;
    search_half_.resize(static_cast<size_t>(rows) * stride_);
    for (int i = 0; i < rows; ++i)
      std::copy(alignment_rows_half(i * search_grid_), alignment_rows_half(i * search_grid_) + stride_,
                search_half_.data() + static_cast<size_t>(i) * stride_);
  }
  if (frames_ > 1) {
    std::vector<double> steps(static_cast<size_t>(frames_ - 1));
    for (int j = 0; j + 1 < frames_; ++j)
      steps[static_cast<size_t>(j)] = std::sqrt(dist2(alignment_projection(j + 1), alignment_projection(j), stride_));
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
    step_cost_ = steps[steps.size() / 2];
    // Up to 4,096 pairs (a, b) with b a pseudo-random offset of at least a second (or a third of
    // the clip if shorter) after a, wrapping: the offsets vary, so a cyclic clip's period cannot
    // pair every frame with its own phase.
    const int gap = std::max(1, std::min(static_cast<int>(std::lround(1.0 / frame_time_)), frames_ / 3));
    const int pairs = std::min(frames_, 4096);
    std::vector<double> far(static_cast<size_t>(pairs));
    uint64_t state = 0x9e3779b97f4a7c15ull;
    for (int i = 0; i < pairs; ++i) {
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      const int a = static_cast<int>(static_cast<int64_t>(i) * frames_ / pairs);
      const int span = std::max(1, frames_ - 2 * gap + 1);
      const int b = (a + gap + static_cast<int>((state >> 33) % static_cast<uint64_t>(span))) % frames_;
      far[static_cast<size_t>(i)] = std::sqrt(dist2(alignment_projection(a), alignment_projection(b), stride_));
    }
    std::nth_element(far.begin(), far.begin() + static_cast<long>(far.size() / 2), far.end());
    spread_ = far[far.size() / 2];
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
