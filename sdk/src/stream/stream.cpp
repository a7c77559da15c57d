#include "stream/stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>

#include "common/error.hpp"

namespace kata {

namespace {

// The seven lengths H is made of (spec section 2, step 4), as GPD joint index pairs.
constexpr int kHeightBones[7][2] = {{3, 2}, {2, 1}, {1, 0}, {10, 11}, {11, 12}, {13, 14}, {14, 15}};

double height_from_lengths(const double* len) {
  return len[0] + len[1] + len[2] + 0.5 * ((len[3] + len[4]) + (len[5] + len[6]));
}

double distance3(const float* a, const float* b) {
  const double dx = double(a[0]) - b[0], dy = double(a[1]) - b[1], dz = double(a[2]) - b[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

}  // namespace

StreamConfig stream_config_for(const Skeleton& skeleton, const GpdMap& map, gpd::Stencil stencil) {
  StreamConfig config;
  config.map = map;
  config.input_joints = skeleton.joint_count();
  config.stencil = stencil;
  if (skeleton.has_rest_pose) config.body_height = rest_body_height(skeleton, map);
  return config;
}

Stream::Stream(const StreamConfig& config) : config_(config) {
  if (config_.input_joints <= 0) throw Error(ErrorKind::kInvalidArgument, "stream: input joint count must be > 0");
  for (int j = 0; j < gpd::kJoints; ++j) {
    if (config_.map.source[j] < 0 || config_.map.source[j] >= config_.input_joints)
      throw Error(ErrorKind::kInvalidArgument, "stream: GPD joint " + std::string(kGpdJointNames[j]) +
                                                   " maps to input joint " + std::to_string(config_.map.source[j]) +
                                                   ", outside 0.." + std::to_string(config_.input_joints - 1));
  }
  if (!(config_.max_gap > 0.0)) throw Error(ErrorKind::kInvalidArgument, "stream: max_gap must be > 0 seconds");
  if (!std::isfinite(config_.body_height))
    throw Error(ErrorKind::kInvalidArgument, "stream: body height must be finite");
  if (config_.body_height > 0.0) {
    height_ = config_.body_height;
  } else if (config_.calibration_frames < 1) {
    throw Error(ErrorKind::kInvalidArgument, "stream: calibration_frames must be >= 1 without a body height");
  }
  // Central kinetics read frames f-2..f+1; calibration holds its frames in the ring.
  const int needed = std::max(4, height_ > 0.0 ? 0 : config_.calibration_frames + 1);
  if (config_.history < needed)
    throw Error(ErrorKind::kInvalidArgument, "stream: history capacity " + std::to_string(config_.history) +
                                                 " is below the " + std::to_string(needed) + " frames this stream needs");
  const size_t h = static_cast<size_t>(config_.history);
  time_.assign(h, 0.0);
  segment_pos_.assign(h, 0);
  starts_segment_.assign(h, 0);
  joints_.assign(h * 3 * gpd::kJoints, 0.0f);
  vectors_.assign(h * gpd::kDims, 0.0f);
  if (height_ <= 0.0) calibration_.assign(7 * static_cast<size_t>(config_.calibration_frames), 0.0);
}

Status Stream::refuse(Status status, const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(error_, sizeof error_, fmt, args);
  va_end(args);
  return status;
}

const float* Stream::last_joints() const {
  return accepted_ ? joints_.data() + static_cast<size_t>(slot_at(accepted_ - 1)) * 3 * gpd::kJoints : nullptr;
}

Status Stream::push(double t, const float* xyz, int joint_count) {
  if (!xyz) return refuse(Status::kNullPointer, "push: positions pointer is null");
  if (joint_count != config_.input_joints)
    return refuse(Status::kWrongJointCount, "push: frame has %d joints, the stream's skeleton has %d", joint_count,
                  config_.input_joints);
  if (!std::isfinite(t)) return refuse(Status::kNonFinite, "push: timestamp is not finite");
  if (accepted_ > 0 && !(t > last_time_))
    return refuse(Status::kTimestampNotIncreasing, "push: timestamp %.9g s does not increase (previous %.9g s)", t,
                  last_time_);
  // Only the mapped joints matter, but a NaN anywhere means a broken frame: refuse it whole.
  for (int i = 0; i < 3 * joint_count; ++i) {
    if (!std::isfinite(xyz[i]))
      return refuse(Status::kNonFinite, "push: joint %d coordinate %d is not finite", i / 3, i % 3);
  }

  const int64_t frame = accepted_;
  const int slot = slot_at(frame);
  float* joints = joints_.data() + static_cast<size_t>(slot) * 3 * gpd::kJoints;
  for (int j = 0; j < gpd::kJoints; ++j) {
    const float* p = xyz + 3 * config_.map.source[j];
    joints[3 * j + 0] = p[0];
    if (config_.up_axis == UpAxis::kZ) {
      joints[3 * j + 1] = p[2];
      joints[3 * j + 2] = -p[1];
    } else {
      joints[3 * j + 1] = p[1];
      joints[3 * j + 2] = p[2];
    }
  }
  time_[slot] = t;
  starts_segment_[slot] = (new_segment_ || (frame > 0 && t - last_time_ > config_.max_gap)) ? 1 : 0;
  new_segment_ = false;
  last_time_ = t;
  accepted_ = frame + 1;

  if (height_ <= 0.0) {
    double* row = calibration_.data() + 7 * static_cast<size_t>(frame);
    for (int b = 0; b < 7; ++b)
      row[b] = distance3(joints + 3 * kHeightBones[b][0], joints + 3 * kHeightBones[b][1]);
    if (accepted_ < config_.calibration_frames) return Status::kOk;
    finish_calibration();
    return Status::kOk;
  }
  process(frame);
  return Status::kOk;
}

void Stream::finish_calibration() {
  const int n = static_cast<int>(std::min<int64_t>(accepted_, config_.calibration_frames));
  if (n == 0) return;
  double lengths[7];
  // Median of each length over the calibration frames (column b of the 7-wide rows).
  std::vector<double>& buf = calibration_;
  for (int b = 0; b < 7; ++b) {
    double column[64];
    double* col = n <= 64 ? column : nullptr;
    std::vector<double> big;
    if (!col) {
      big.resize(static_cast<size_t>(n));  // only with > 64 calibration frames, once per stream
      col = big.data();
    }
    for (int i = 0; i < n; ++i) col[i] = buf[7 * static_cast<size_t>(i) + b];
    std::nth_element(col, col + n / 2, col + n);
    double median = col[n / 2];
    if (n % 2 == 0) median = 0.5 * (median + *std::max_element(col, col + n / 2));
    lengths[b] = median;
  }
  height_ = height_from_lengths(lengths);
  // A collapsed body (every joint at one point) has no scale; keep features finite.
  if (!(height_ > 1e-12)) height_ = 1.0;
  for (int64_t f = processed_; f < accepted_; ++f) process(f);
}

void Stream::process(int64_t frame) {
  const int slot = slot_at(frame);
  const bool starts = starts_segment_[slot] != 0;
  segment_pos_[slot] = starts ? 0 : std::min(segment_pos_[slot_at(frame - 1)] + 1, 2);
  float local[3 * gpd::kJoints];
  float hip_height = 0.0f;
  gpd::to_local_frame(joints_.data() + static_cast<size_t>(slot) * 3 * gpd::kJoints, height_, geometry_, local,
                      &hip_height);
  gpd::static_features(local, hip_height, geometry_, vectors_.data() + static_cast<size_t>(slot) * gpd::kDims);
  processed_ = frame + 1;

  if (config_.stencil == gpd::Stencil::kBackward) {
    emit(frame, false);
    return;
  }
  // Central: this frame completes its predecessor's stencil, or closes the previous segment.
  if (pending_) emit(frame - 1, /*central=*/!starts);
  pending_ = true;
}

void Stream::emit(int64_t frame, bool central) {
  const int slot = slot_at(frame);
  float* kin = vectors_.data() + static_cast<size_t>(slot) * gpd::kDims + gpd::kOffsetJk;
  const int pos = segment_pos_[slot];
  auto jc = [&](int64_t f) { return vectors_.data() + static_cast<size_t>(slot_at(f)) * gpd::kDims; };
  if (pos == 0) {
    gpd::kinetics_zero(kin);
  } else if (central) {
    const double h1 = time_[slot] - time_[slot_at(frame - 1)];
    const double h2 = time_[slot_at(frame + 1)] - time_[slot];
    gpd::kinetics(jc(frame - 1), jc(frame), jc(frame + 1), gpd::central_weights(h1, h2), kin);
  } else if (pos == 1) {
    gpd::kinetics_two_point(jc(frame - 1), jc(frame), time_[slot] - time_[slot_at(frame - 1)], kin);
  } else {
    const double h1 = time_[slot_at(frame - 1)] - time_[slot_at(frame - 2)];
    const double h2 = time_[slot] - time_[slot_at(frame - 1)];
    gpd::kinetics(jc(frame - 2), jc(frame - 1), jc(frame), gpd::backward_weights(h1, h2), kin);
  }
  out_time_ = time_[slot];
  out_frame_ = frame;
  ++emitted_;
}

void Stream::flush() {
  if (height_ <= 0.0) finish_calibration();
  if (pending_) emit(processed_ - 1, false);
  pending_ = false;
  new_segment_ = true;
}

void Stream::reset() { new_segment_ = true; }

std::vector<float> features_of_frames(const StreamConfig& config, const float* positions, int frames,
                                      double frame_time) {
  if (frames < 0 || (frames > 0 && !positions))
    throw Error(ErrorKind::kInvalidArgument, "features_of_frames: no positions");
  if (!(frame_time > 0.0) || !std::isfinite(frame_time))
    throw Error(ErrorKind::kInvalidArgument, "features_of_frames: frame time must be > 0 seconds");
  Stream stream(config);
  std::vector<float> out(static_cast<size_t>(frames) * gpd::kDims);
  const size_t stride = 3 * static_cast<size_t>(config.input_joints);
  int64_t copied = 0;  // vectors copied out so far (they are frames 0, 1, ... in order)
  auto collect = [&] {
    for (; copied < stream.emitted_count(); ++copied) {
      const float* v = stream.vector_of(copied);
      std::copy(v, v + gpd::kDims, out.begin() + copied * gpd::kDims);
    }
  };
  for (int i = 0; i < frames; ++i) {
    const Status s = stream.push(i * frame_time, positions + static_cast<size_t>(i) * stride, config.input_joints);
    if (s != Status::kOk)
      throw Error(ErrorKind::kInvalidArgument, "frame " + std::to_string(i) + ": " + stream.last_error());
    collect();
  }
  stream.flush();
  collect();
  return out;
}

}  // namespace kata
