#include "metric/reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <future>
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
  // Each chunk is projected on a second thread while the caller's producer (a Stream: sequential,
  // it carries state from frame to frame) makes the next one: loading a long teacher takes the
  // longer of the two instead of their sum. Two buffers: chunk k is copied into
  // buffer k % 2 once chunk k - 1's projection (which read the other one) has been waited for, so
  // chunk k - 2's, the last reader of this buffer, is done too. add() writes frames of its own
  // chunk only, so the result does not depend on the threads' timing: bit for bit the one-shot
  // constructor's.
  std::vector<float> buffer[2];
  std::future<void> pending;
  int done = 0, chunk = 0;
  auto wait = [&] {
    if (pending.valid()) pending.get();  // rethrows add()'s error (a NaN in the chunk's features)
  };
  try {
    features([&](const float* data, int count) {
      if (!data || count < 0 || count > frames_ - done)
        throw Error(ErrorKind::kInvalidArgument, "reference clip: more feature frames than the " +
                                                     std::to_string(frames_) + " announced");
      wait();
      std::vector<float>& copy = buffer[chunk++ % 2];
      copy.assign(data, data + static_cast<size_t>(count) * gpd::kDims);
      const int first = done;
      pending = start_beside([this, &copy, first, count] { add(copy.data(), first, count); });
      done += count;
    });
  } catch (...) {
    // An earlier chunk's error comes first, as it did when the chunks were projected in turn;
    // either way no projection is left running on the buffers.
    wait();
    throw;
  }
  wait();
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
  rank_ = metric_->rank();
  score_rows_ = LargeArray<int16_t>(static_cast<size_t>(frames_) * kScoreRows * rank_);
  score_scale_ = LargeArray<float>(static_cast<size_t>(frames_) * kScoreRows);
  static_rows_ = LargeArray<float>(static_cast<size_t>(frames_) * stride_);
  poses_ = LargeArray<float>(static_cast<size_t>(frames_) * kPoseFloats);
  align_half_ = LargeArray<uint16_t>(static_cast<size_t>(frames_) * stride_);
}

namespace {
// Row r of the kept score rows is row score_row(r) of a frame's projection: the part rows, then
// (past the static row) the joint-position rows.
constexpr int score_row(int r) { return r < kParts ? r : r + 1; }
static_assert(score_row(kParts) == kJointRows && score_row(Reference::kScoreRows - 1) == kProjectionRows - 1);
}  // namespace

void Reference::add(const float* features, int first, int count) {
  for (size_t i = 0; i < static_cast<size_t>(count) * gpd::kDims; ++i)
    if (!std::isfinite(features[i]))
      throw Error(ErrorKind::kInvalidArgument, "reference: NaN/Inf in the features of frame " +
                                                   std::to_string(first + static_cast<int>(i / gpd::kDims)));
  // kBatch frames a pass over W (metric.hpp: equal to part_projections bit for bit, each W row
  // loaded once for all of them): the projections were a fifth of a long teacher's load.
  constexpr int kBatch = detail::kBatch;
  const size_t frame_floats = static_cast<size_t>(kProjectionRows) * stride_;
  Metric::Workspace ws[kBatch];
  Metric::Workspace* wsp[kBatch];
  for (int f = 0; f < kBatch; ++f) ws[f] = metric_->make_workspace(), wsp[f] = &ws[f];
  AlignedFloats proj(frame_floats * kBatch);
  for (int f0 = 0; f0 < count; f0 += kBatch) {
    const int m = std::min(kBatch, count - f0);
    const float* x[kBatch];
    float* p[kBatch];
    for (int f = 0; f < m; ++f) {
      x[f] = features + static_cast<size_t>(f0 + f) * gpd::kDims;
      p[f] = proj.data() + static_cast<size_t>(f) * frame_floats;
    }
    metric_->part_projections_batch(x, wsp, p, m);
    for (int f = 0; f < m; ++f) {
      const size_t j = static_cast<size_t>(first + f0 + f);
      for (int r = 0; r < kScoreRows; ++r) {
        const float* v = p[f] + static_cast<size_t>(score_row(r)) * stride_;
        float largest = 0.0f;
        for (int c = 0; c < rank_; ++c) largest = std::max(largest, std::fabs(v[c]));
        const float step = largest / 32767.0f;
        score_scale_[j * kScoreRows + r] = step;
        int16_t* q = score_rows_.data() + (j * kScoreRows + r) * rank_;
        for (int c = 0; c < rank_; ++c)
          q[c] = step > 0.0f ? static_cast<int16_t>(std::clamp(std::nearbyint(static_cast<double>(v[c]) / step),
                                                               -32767.0, 32767.0))
                             : int16_t{0};
      }
      const float* st = p[f] + static_cast<size_t>(kStaticRow) * stride_;
      std::copy(st, st + stride_, static_rows_.data() + j * stride_);
      // At scale 1 (v / 1 is v): finish() redoes them if the whole clip needs another.
      for (int i = 0; i < stride_; ++i) align_half_[j * stride_ + i] = detail::float_to_half(st[i]);
    }
  }
  for (int j = 0; j < count; ++j)
    pose_frames(features + static_cast<size_t>(j) * gpd::kDims,
                poses_.data() + static_cast<size_t>(first + j) * kPoseFloats);
}

void Reference::subtract_projection(int j, float* p) const {
  const int16_t* q = score_rows_.data() + static_cast<size_t>(j) * kScoreRows * rank_;
  const float* step = score_scale_.data() + static_cast<size_t>(j) * kScoreRows;
  for (int r = 0; r < kScoreRows; ++r) {
    float* row = p + static_cast<size_t>(score_row(r)) * stride_;
    const int16_t* qr = q + static_cast<size_t>(r) * rank_;
    // A difference within the rows' rounding (half a step, plus 2^-23 of the row's largest for the
    // float roundings of decoding and subtracting: 0.51 steps) is taken as none, so a student in
    // the teacher's very pose is at distance 0 and scores 100 exactly, as with float rows; a
    // difference's error is then at most 1.02 steps (test_scorer.cpp HeldRows).
    detail::subtract_rows16(row, qr, step[r], rank_);
  }
}

void Reference::projection(int j, float* out) const {
  std::fill(out, out + static_cast<size_t>(kProjectionRows) * stride_, 0.0f);
  const int16_t* q = score_rows_.data() + static_cast<size_t>(j) * kScoreRows * rank_;
  const float* step = score_scale_.data() + static_cast<size_t>(j) * kScoreRows;
  for (int r = 0; r < kScoreRows; ++r)
    for (int c = 0; c < rank_; ++c)
      out[static_cast<size_t>(score_row(r)) * stride_ + c] = step[r] * static_cast<float>(q[static_cast<size_t>(r) * rank_ + c]);
  std::copy(alignment_projection(j), alignment_projection(j) + stride_, out + static_cast<size_t>(kStaticRow) * stride_);
}

size_t Reference::memory_bytes() const {
  return score_rows_.size() * sizeof(int16_t) + score_scale_.size() * sizeof(float) +
         static_rows_.size() * sizeof(float) + align_half_.size() * sizeof(uint16_t) + poses_.size() * sizeof(float) +
         search_half_.capacity() * sizeof(uint16_t);
}

void Reference::finish() {
  auto row = [&](int j) { return alignment_projection(j); };
  float largest = 0.0f;
  for (int j = 0; j < frames_; ++j)
    for (int i = 0; i < stride_; ++i) largest = std::max(largest, std::fabs(row(j)[i]));
  align_half_scale_ = 1.0f;
  while (largest / align_half_scale_ > 16384.0f) align_half_scale_ *= 2.0f;
  // add() made the half rows at scale 1 (the models' projections stay far below 16384): made
  // again only when the clip needs a larger scale.
  if (align_half_scale_ != 1.0f)
    for (int j = 0; j < frames_; ++j)
      for (int i = 0; i < stride_; ++i)
        align_half_[static_cast<size_t>(j) * stride_ + i] = detail::float_to_half(row(j)[i] / align_half_scale_);
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
      steps[static_cast<size_t>(j)] = std::sqrt(dist2(row(j + 1), row(j), stride_));
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
      far[static_cast<size_t>(i)] = std::sqrt(dist2(row(a), row(b), stride_));
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
