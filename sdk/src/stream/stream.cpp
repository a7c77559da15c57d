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
  config.body_height = stream_body_height(0.0, skeleton, map);
  return config;
}

double stream_body_height(double given, const Skeleton& skeleton, const GpdMap& map) {
  if (given != 0.0) return given;  // NaN and negative values too: Stream refuses them by name
  if (!skeleton.has_rest_pose) return 0.0;
  const double rest = rest_body_height(skeleton, map);
  return rest >= kMinBodyHeight && rest <= kMaxCoordinate ? rest : 0.0;
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
  if (config_.stencil != gpd::Stencil::kBackward && config_.stencil != gpd::Stencil::kCentral)
    throw Error(ErrorKind::kInvalidArgument, "stream: unknown stencil");
  if (config_.up_axis != UpAxis::kY && config_.up_axis != UpAxis::kZ)
    throw Error(ErrorKind::kInvalidArgument, "stream: unknown up axis");
  char text[160];
  if (!std::isfinite(config_.body_height) || config_.body_height < 0.0 ||
      (config_.body_height > 0.0 && (config_.body_height < kMinBodyHeight || config_.body_height > kMaxCoordinate))) {
    std::snprintf(text, sizeof text, "stream: body height %g is not 0 (estimate it) or in %g..%g input units",
                  config_.body_height, kMinBodyHeight, kMaxCoordinate);
    throw Error(ErrorKind::kInvalidArgument, text);
  }
  if (config_.history < 4 || config_.history > kMaxHistory)
    throw Error(ErrorKind::kInvalidArgument, "stream: history capacity " + std::to_string(config_.history) +
                                                 " is not in 4.." + std::to_string(kMaxHistory) + " frames");
  if (config_.body_height > 0.0) {
    height_ = config_.body_height;
  } else if (config_.calibration_frames < 1 || config_.calibration_frames >= config_.history) {
    // Calibration holds its frames in the ring, with one slot to spare.
    throw Error(ErrorKind::kInvalidArgument, "stream: calibration_frames " + std::to_string(config_.calibration_frames) +
                                                 " is not in 1..history capacity - 1 = " +
                                                 std::to_string(config_.history - 1) + " (no body height given)");
  }
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
  // Closer frames would make the difference weights (1 / step^2) overflow the features. A step
  // of exactly kMinTimeStep computed by subtraction may round just below it: still accepted.
  if (accepted_ > 0 && !(t - last_time_ >= kMinTimeStep * (1.0 - 1e-9)))
    return refuse(Status::kTimestampNotIncreasing,
                  "push: timestamp %.17g s is %.3g s after the previous one, below the minimum step %g s", t,
                  t - last_time_, kMinTimeStep);
  // Only the mapped joints matter, but a NaN anywhere means a broken frame: refuse it whole.
  for (int i = 0; i < 3 * joint_count; ++i) {
    if (!std::isfinite(xyz[i]))
      return refuse(Status::kNonFinite, "push: joint %d coordinate %d is not finite", i / 3, i % 3);
  }

  // The mapped joints, checked against the plausibility range before anything changes.
  float mapped[3 * gpd::kJoints];
  for (int j = 0; j < gpd::kJoints; ++j) {
    const float* p = xyz + 3 * config_.map.source[j];
    mapped[3 * j + 0] = p[0];
    if (config_.up_axis == UpAxis::kZ) {
      mapped[3 * j + 1] = p[2];
      mapped[3 * j + 2] = -p[1];
    } else {
      mapped[3 * j + 1] = p[1];
      mapped[3 * j + 2] = p[2];
    }
    for (int k = 0; k < 3; ++k) {
      if (!(std::fabs(mapped[3 * j + k]) <= kMaxCoordinate))
        return refuse(Status::kInvalidArgument,
                      "push: joint %s (input joint %d) has a coordinate %g beyond the plausible +-%g input units",
                      kGpdJointNames[static_cast<size_t>(j)], config_.map.source[j], double(p[k]), kMaxCoordinate);
    }
  }
  if (height_ > 0.0) {
    const double reach = kMaxReach * height_;
    for (int j = 1; j < gpd::kJoints; ++j) {
      const double d = distance3(mapped + 3 * j, mapped);
      if (!(d <= reach))
        return refuse(Status::kInvalidArgument,
                      "push: joint %s (input joint %d) is %g body heights from the hip, beyond the plausible %g",
                      kGpdJointNames[static_cast<size_t>(j)], config_.map.source[j], d / height_, kMaxReach);
    }
  }

  const int64_t frame = accepted_;
  const int slot = slot_at(frame);
  float* joints = joints_.data() + static_cast<size_t>(slot) * 3 * gpd::kJoints;
  std::memcpy(joints, mapped, sizeof mapped);
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
    return emitted_status();
  }
  process(frame);
  return emitted_status();
}

Status Stream::emitted_status() {
  if (withheld_dim_ < 0) return Status::kOk;
  const int dim = withheld_dim_;
  withheld_dim_ = -1;
  return refuse(Status::kInternal,
                "internal error: feature %d of frame %lld is not finite; the vector was withheld (please report)",
                dim, static_cast<long long>(withheld_frame_));
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
  // A collapsed body (every joint at one point) has no scale; keep features finite with
  // H = 1 input unit (the plausibility range then applies in input units).
  if (!(height_ >= kMinBodyHeight)) height_ = 1.0;
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
  // Finite by construction inside the plausibility range; checked so a bug can never hand out a
  // NaN: a non-finite vector is withheld (the previous one stays the newest) and reported.
  const float* vector = vectors_.data() + static_cast<size_t>(slot) * gpd::kDims;
  for (int i = 0; i < gpd::kDims; ++i) {
    if (!std::isfinite(vector[i])) {
      withheld_dim_ = i;
      withheld_frame_ = frame;
      return;
    }
  }
  out_time_ = time_[slot];
  out_frame_ = frame;
  ++emitted_;
}

Status Stream::flush() {
  if (height_ <= 0.0) finish_calibration();
  if (pending_) emit(processed_ - 1, false);
  pending_ = false;
  new_segment_ = true;
  return emitted_status();
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
  if (stream.flush() != Status::kOk)
    throw Error(ErrorKind::kInvalidArgument, std::string("end of frames: ") + stream.last_error());
  collect();
  return out;
}

}  // namespace kata
