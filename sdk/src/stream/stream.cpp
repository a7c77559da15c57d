#include "stream/stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>

#include "common/error.hpp"

namespace kata {

namespace {

// The seven lengths H is made of (spec section 2, step 4), as GPD joint index pairs.
constexpr int kHeightBones[7][2] = {{3, 2}, {2, 1}, {1, 0}, {10, 11}, {11, 12}, {13, 14}, {14, 15}};

double height_from_lengths(const double* len) {
  return len[0] + len[1] + len[2] + 0.5 * ((len[3] + len[4]) + (len[5] + len[6]));
}

// The per-frame checks (finite input, mapped joints within range, a finite vector out) each run
// one branch-free pass (gpd::largest_magnitude_bits) and look for the offending value only when
// it fails.
using gpd::largest_magnitude_bits;

constexpr uint32_t kInfBits = 0x7f800000u;
// kMaxCoordinate as a float bit pattern (1e9 is exact in float).
const uint32_t kMaxCoordinateBits = [] {
  const float limit = static_cast<float>(kMaxCoordinate);
  uint32_t b;
  std::memcpy(&b, &limit, sizeof b);
  return b;
}();

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
    const GpdBlend& b = config_.map.blend[j];
    for (int k = 0; k < config_.map.floor_count; ++k)
      if (k >= GpdMap::kMaxFloorJoints || config_.map.floor_joints[static_cast<size_t>(k)] < 0 ||
          config_.map.floor_joints[static_cast<size_t>(k)] >= config_.input_joints)
        throw Error(ErrorKind::kInvalidArgument, "stream: a floor joint lies outside the skeleton");
    if (config_.map.source[j] < 0 && b.count > 0 && b.count <= kMaxBlendTerms) {
      for (int k = 0; k < b.count; ++k)
        if (b.joint[k] < 0 || b.joint[k] >= config_.input_joints || !std::isfinite(b.weight[k]))
          throw Error(ErrorKind::kInvalidArgument, "stream: GPD joint " + std::string(kGpdJointNames[j]) +
                                                       " blends a joint outside the skeleton");
      continue;
    }
    if (config_.map.source[j] < 0 || config_.map.source[j] >= config_.input_joints)
      throw Error(ErrorKind::kInvalidArgument, "stream: GPD joint " + std::string(kGpdJointNames[j]) +
                                                   " maps to input joint " + std::to_string(config_.map.source[j]) +
                                                   ", outside 0.." + std::to_string(config_.input_joints - 1));
  }
  if (!(config_.max_gap > 0.0)) throw Error(ErrorKind::kInvalidArgument, "stream: max_gap must be > 0 seconds");
  if (config_.stencil != gpd::Stencil::kBackward && config_.stencil != gpd::Stencil::kCentral)
    throw Error(ErrorKind::kInvalidArgument, "stream: unknown stencil");
  if (config_.up_axis != UpAxis::kY && config_.up_axis != UpAxis::kZ && config_.up_axis != UpAxis::kYDown)
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
  static_bits_.assign(h, 0u);
  direct_map_ = std::all_of(config_.map.source.begin(), config_.map.source.end(), [](int s) { return s >= 0; });
  if (height_ <= 0.0) calibration_.assign(7 * static_cast<size_t>(config_.calibration_frames), 0.0);
  if (!(config_.max_hold >= 0.0) || !(config_.max_missing_share >= 0.0) || !std::isfinite(config_.confidence_threshold))
    throw Error(ErrorKind::kInvalidArgument, "stream: max_hold, max_missing_share must be >= 0 and the threshold finite");
  if (config_.smoothing && !(config_.smoothing_min_cutoff > 0.0 && config_.smoothing_beta >= 0.0 &&
                             config_.smoothing_d_cutoff > 0.0 && std::isfinite(config_.smoothing_beta)))
    throw Error(ErrorKind::kInvalidArgument, "stream: smoothing cutoffs must be > 0 Hz and beta >= 0");
  if (config_.bone_window < 0 || config_.bone_window > 100000)
    throw Error(ErrorKind::kInvalidArgument, "stream: bone_window must be in 0..100000 frames");
  for (double& t : last_good_time_) t = -std::numeric_limits<double>::infinity();
  bone_samples_.assign(static_cast<size_t>(config_.bone_window) * 3 * gpd::kJoints, 0.0f);
  bone_scratch_.assign(static_cast<size_t>(config_.bone_window), 0.0f);
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

Status Stream::check_input(double t, const float* xyz, const float* confidence, int joint_count,
                           uint32_t* input_bits) {
  if (!xyz) return refuse(Status::kNullPointer, "push: positions pointer is null");
  if (joint_count != config_.input_joints)
    return refuse(Status::kWrongJointCount, "push: frame has %d joints, the stream's skeleton has %d", joint_count,
                  config_.input_joints);
  if (!std::isfinite(t)) return refuse(Status::kNonFinite, "push: timestamp is not finite");
  if (seen_time_ && !(t > last_time_))
    return refuse(Status::kTimestampNotIncreasing, "push: timestamp %.9g s does not increase (previous %.9g s)", t,
                  last_time_);
  // Closer frames would make the difference weights (1 / step^2) overflow the features. A step
  // of exactly kMinTimeStep computed by subtraction may round just below it: still accepted.
  if (seen_time_ && !(t - last_time_ >= kMinTimeStep * (1.0 - 1e-9)))
    return refuse(Status::kTimestampNotIncreasing,
                  "push: timestamp %.17g s is %.3g s after the previous one, below the minimum step %g s", t,
                  t - last_time_, kMinTimeStep);
  if (seen_time_ && !(t - last_time_ <= kMaxTimeStep))
    return refuse(Status::kInvalidArgument,
                  "push: timestamp %.17g s is %.3g s after the previous one, beyond the largest step %g s (a clock "
                  "in other units, or a source restarted without a reset)",
                  t, t - last_time_, kMaxTimeStep);
  *input_bits = kInfBits;  // the largest |input coordinate|, when every one is read
  if (!confidence) {
    *input_bits = largest_magnitude_bits(xyz, 3 * joint_count);
    if (*input_bits >= kInfBits) {
      // Only the mapped joints matter, but a NaN anywhere means a broken frame: refuse it whole.
      for (int i = 0; i < 3 * joint_count; ++i) {
        if (!std::isfinite(xyz[i]))
          return refuse(Status::kNonFinite, "push: joint %d coordinate %d is not finite", i / 3, i % 3);
      }
    }
  }
  return Status::kOk;
}

Status Stream::check_plausible(const float* mapped, uint32_t input_bits) {
  // A direct map copies coordinates (signs aside), so when the input scan found them all within
  // the range the mapped ones are too; otherwise they are scanned.
  uint32_t mapped_bits = input_bits;  // at least the largest |mapped coordinate|
  if (!direct_map_ || input_bits > kMaxCoordinateBits) mapped_bits = largest_magnitude_bits(mapped, 3 * gpd::kJoints);
  if (mapped_bits > kMaxCoordinateBits) {
    for (int j = 0; j < gpd::kJoints; ++j) {
      for (int k = 0; k < 3; ++k) {
        if (!(std::fabs(mapped[3 * j + k]) <= kMaxCoordinate))
          return refuse(Status::kInvalidArgument,
                        "push: joint %s (input joint %d) has a coordinate %g beyond the plausible +-%g input units",
                        kGpdJointNames[static_cast<size_t>(j)], config_.map.source[j], double(mapped[3 * j + k]),
                        kMaxCoordinate);
      }
    }
  }
  float coordinate_bound;  // every |mapped coordinate| is at most this (checked above: <= kMaxCoordinate)
  std::memcpy(&coordinate_bound, &mapped_bits, sizeof coordinate_bound);
  const double bound = coordinate_bound;
  // Two joints within +-bound on each axis are at most sqrt(12) bound apart, so when 12 bound^2
  // is within the squared reach (with a margin far above the rounding of the distances' double
  // evaluation) no joint can be refused and the 15 distances are not computed.
  if (height_ > 0.0 && !(12.0 * bound * bound * (1.0 + 1e-6) <= (kMaxReach * height_) * (kMaxReach * height_))) {
    // Squared distances against the squared reach: no square root unless a joint is refused.
    const double reach = kMaxReach * height_;
    const double reach2 = reach * reach;
    auto hip_distance2 = [&](int j) {
      const double dx = double(mapped[3 * j]) - mapped[0], dy = double(mapped[3 * j + 1]) - mapped[1],
                   dz = double(mapped[3 * j + 2]) - mapped[2];
      return dx * dx + dy * dy + dz * dz;
    };
    bool within = true;
    for (int j = 1; j < gpd::kJoints; ++j) within &= hip_distance2(j) <= reach2;
    if (!within) {
      for (int j = 1; j < gpd::kJoints; ++j)
        if (!(hip_distance2(j) <= reach2))
          return refuse(Status::kInvalidArgument,
                        "push: joint %s (input joint %d) is %g body heights from the hip, beyond the plausible %g",
                        kGpdJointNames[static_cast<size_t>(j)], config_.map.source[j],
                        std::sqrt(hip_distance2(j)) / height_, kMaxReach);
    }
  }
  return Status::kOk;
}

Status Stream::push(double t, const float* xyz, const float* confidence, int joint_count) {
  uint32_t input_bits = kInfBits;
  if (const Status st = check_input(t, xyz, confidence, joint_count, &input_bits); st != Status::kOk) return st;
  // The mapped joints (missing ones held), checked against the plausibility range before
  // anything changes.
  float mapped[3 * gpd::kJoints];
  bool good[gpd::kJoints];
  const int missing = gate(t, xyz, confidence, mapped, good);
  if (const Status st = check_plausible(mapped, input_bits); st != Status::kOk) return st;
  float floor = floor_;
  if (!find_floor(xyz, confidence, &floor))
    return refuse(Status::kInvalidArgument, "push: a foot joint's height %g is beyond the plausible +-%g input units",
                  double(floor), kMaxCoordinate);
  // Accepted: the gate's state moves on, the floor is applied.
  if (!confidence) {  // every joint good
    std::memcpy(last_good_, mapped, sizeof mapped);
    std::fill(std::begin(last_good_time_), std::end(last_good_time_), t);
  } else {
    for (int g = 0; g < gpd::kJoints; ++g) {
      if (!good[g]) continue;
      std::memcpy(last_good_ + 3 * g, mapped + 3 * g, 3 * sizeof(float));
      last_good_time_[g] = t;
    }
  }
  missing_joints_ = missing < 0 ? gpd::kJoints : missing;
  floor_ = floor;
  // Without floor joints floor_ stays 0 (find_floor leaves it), and y - 0 is y.
  if (config_.map.floor_count > 0)
    for (int g = 0; g < gpd::kJoints; ++g) mapped[3 * g + 1] -= floor_;
  const bool gap = seen_time_ && t - last_time_ > config_.max_gap;
  seen_time_ = true;
  last_time_ = t;
  if (missing < 0 || missing > config_.max_missing_share * gpd::kJoints) {
    ++lost_frames_;
    end_segment();
    const Status emitted = emitted_status();
    if (emitted != Status::kOk) return emitted;
    if (missing < 0) return refuse(Status::kTrackingLost, "push: tracking lost (a joint missing for more than %.3g s)",
                                   config_.max_hold);
    return refuse(Status::kTrackingLost, "push: tracking lost (%d of 16 GPD joints missing)", missing);
  }
  if (missing == 0 && bone_count_ < config_.bone_window) collect_bones(mapped);

  return store(t, gap, mapped);
}

Status Stream::store(double t, bool gap, float* mapped) {
  const int64_t frame = accepted_;
  const int slot = next_slot_;
  const bool starts = new_segment_ || gap;
  smooth(t, starts, mapped);
  float* joints = joints_.data() + static_cast<size_t>(slot) * 3 * gpd::kJoints;
  std::memcpy(joints, mapped, 3 * gpd::kJoints * sizeof(float));
  time_[slot] = t;
  starts_segment_[slot] = starts ? 1 : 0;
  new_segment_ = false;
  accepted_ = frame + 1;
  next_slot_ = slot_after(slot);

  if (height_ <= 0.0) {
    double* row = calibration_.data() + 7 * static_cast<size_t>(frame);
    for (int b = 0; b < 7; ++b)
      row[b] = distance3(joints + 3 * kHeightBones[b][0], joints + 3 * kHeightBones[b][1]);
    if (accepted_ < config_.calibration_frames) return Status::kOk;
    finish_calibration();
    return emitted_status();
  }
  process(frame, slot);
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

int Stream::gate(double t, const float* xyz, const float* confidence, float* mapped, bool* good) const {
  if (!confidence) {
    if (direct_map_) {  // map_gpd_joint's copy of input joint `source`, without a call per joint
      for (int g = 0; g < gpd::kJoints; ++g)
        to_y_up(config_.up_axis, xyz + 3 * config_.map.source[static_cast<size_t>(g)], mapped + 3 * g);
    } else {
      map_to_gpd(config_.map, config_.up_axis, xyz, mapped);
    }
    for (int g = 0; g < gpd::kJoints; ++g) good[g] = true;
    return 0;
  }
  const GpdMap& m = config_.map;
  auto usable = [&](int j) {
    const float* p = xyz + 3 * j;
    // NaN confidence fails the comparison: missing.
    return confidence[j] >= config_.confidence_threshold && std::isfinite(p[0]) && std::isfinite(p[1]) &&
           std::isfinite(p[2]);
  };
  int missing = 0;
  bool expired = false;
  for (int g = 0; g < gpd::kJoints; ++g) {
    const int src = m.source[g];
    bool ok = true;
    if (src >= 0) {
      ok = usable(src);
    } else {
      // A synthesised joint needs every landmark it reads, its offset's frame included.
      const GpdBlend& b = m.blend[g];
      for (int k = 0; k < b.count; ++k) ok = ok && usable(b.joint[k]);
      if (b.offset != 0.0f)
        for (int k = 0; k < 4; ++k) ok = ok && usable(b.offset_joint[k]);
    }
    good[g] = ok;
    if (ok) {
      map_gpd_joint(m, config_.up_axis, g, xyz, mapped + 3 * g);
    } else {
      ++missing;
      if (!(t - last_good_time_[g] <= config_.max_hold)) expired = true;  // never seen: -inf
      // Held in input axes without the floor (mapped is floored after the gate).
      std::memcpy(mapped + 3 * g, last_good_ + 3 * g, 3 * sizeof(float));
    }
  }
  return expired ? -1 : missing;
}

bool Stream::find_floor(const float* xyz, const float* confidence, float* floor) const {
  const GpdMap& m = config_.map;
  if (m.floor_count <= 0) return true;
  float lowest = std::numeric_limits<float>::infinity();
  for (int k = 0; k < m.floor_count && k < GpdMap::kMaxFloorJoints; ++k) {
    const int j = m.floor_joints[static_cast<size_t>(k)];
    const float* p = xyz + 3 * j;
    if (confidence && !(confidence[j] >= config_.confidence_threshold)) continue;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
    float up[3];
    to_y_up(config_.up_axis, p, up);
    lowest = std::min(lowest, up[1]);
  }
  if (!std::isfinite(lowest)) return true;  // no foot seen: the last floor holds
  *floor = lowest;
  return std::fabs(lowest) <= kMaxCoordinate;
}

void Stream::smooth(double t, bool restart, float* mapped) {
  if (!config_.smoothing) return;
  if (restart || !filter_ready_) {
    std::memcpy(filter_x_, mapped, sizeof filter_x_);
    std::fill(std::begin(filter_dx_), std::end(filter_dx_), 0.0f);
    filter_ready_ = true;
    filter_time_ = t;
    return;
  }
  const double dt = t - filter_time_;
  filter_time_ = t;
  // alpha = 1 / (1 + tau / dt), tau = 1 / (2 pi fc): the exponential smoothing factor of fc.
  auto alpha = [dt](double cutoff) { return 1.0 / (1.0 + 1.0 / (2.0 * 3.14159265358979323846 * cutoff * dt)); };
  const double a_d = alpha(config_.smoothing_d_cutoff);
  for (int i = 0; i < 3 * gpd::kJoints; ++i) {
    const double raw_dx = (double(mapped[i]) - filter_x_[i]) / dt;
    const double dx = a_d * raw_dx + (1.0 - a_d) * filter_dx_[i];
    const double a = alpha(config_.smoothing_min_cutoff + config_.smoothing_beta * std::fabs(dx));
    const double x = a * mapped[i] + (1.0 - a) * filter_x_[i];
    filter_dx_[i] = static_cast<float>(dx);
    filter_x_[i] = static_cast<float>(x);
    mapped[i] = filter_x_[i];
  }
}

void Stream::collect_bones(const float* mapped) {
  if (bone_count_ >= config_.bone_window) return;
  // Bone vectors (child - parent), 16 x 3 per frame (entry 0 unused).
  float* row = bone_samples_.data() + static_cast<size_t>(bone_count_) * 3 * gpd::kJoints;
  for (int g = 1; g < gpd::kJoints; ++g)
    for (int k = 0; k < 3; ++k) row[3 * g + k] = mapped[3 * g + k] - mapped[3 * kGpdParents[static_cast<size_t>(g)] + k];
  if (++bone_count_ < config_.bone_window) return;
  // Window complete, once per stream. Noise on the joints lengthens every measured bone: with
  // s^2 the noise variance of each coordinate of a bone vector d of length L, |d|^2 averages
  // L^2 + 3 s^2. s^2 comes from the bone vector's own second differences over consecutive frames
  // (white noise: 6 s^2 per coordinate; the motion's share is negligible beside it at 30..120 Hz;
  // the median of |second difference|^2 / (6 x 2.366), 2.366 the median of chi^2 with 3 degrees,
  // ignores the odd fast frame). So L = sqrt(mean|d|^2 - 3 s^2), the mean taken over the frames
  // whose |d| lies within 4 robust deviations (1.4826 x MAD) of the median (a mistracked frame
  // is dropped): for Gaussian noise it scatters 20% less than a median would.
  const int n = bone_count_;
  float* col = bone_scratch_.data();
  auto median = [col](int count) {
    std::nth_element(col, col + count / 2, col + count);
    double m = col[count / 2];
    if (count % 2 == 0) m = 0.5 * (m + *std::max_element(col, col + count / 2));
    return m;
  };
  auto vec = [&](int i, int g) { return bone_samples_.data() + static_cast<size_t>(i) * 3 * gpd::kJoints + 3 * g; };
  auto length = [&](int i, int g) {
    const float* d = vec(i, g);
    return std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
  };
  for (int g = 1; g < gpd::kJoints; ++g) {
    for (int i = 0; i < n; ++i) col[i] = static_cast<float>(length(i, g));
    const double m = median(n);
    for (int i = 0; i < n; ++i) col[i] = static_cast<float>(std::fabs(length(i, g) - m));
    const double spread = 1.4826 * median(n);
    bone_spread_[g] = spread;
    double sum = 0.0;
    int kept = 0;
    for (int i = 0; i < n; ++i) {
      const double l = length(i, g);
      if (std::fabs(l - m) > 4.0 * spread) continue;
      sum += l * l;
      ++kept;
    }
    const double mean_square = kept > 0 ? sum / kept : m * m;
    double noise = 0.0;  // s^2
    if (n >= 3) {
      for (int i = 1; i + 1 < n; ++i) {
        const float *a = vec(i - 1, g), *b = vec(i, g), *c = vec(i + 1, g);
        double s2 = 0.0;
        for (int k = 0; k < 3; ++k) {
          const double d2 = double(a[k]) - 2.0 * b[k] + c[k];
          s2 += d2 * d2;
        }
        col[i - 1] = static_cast<float>(s2);
      }
      noise = median(n - 2) / (6.0 * 2.366);
    }
    // The correction is capped at a quarter of the squared length: more would mean the "noise" is
    // motion.
    bone_length_[g] = std::sqrt(std::max(mean_square - 3.0 * noise, 0.75 * mean_square));
  }
}

bool Stream::bone_lengths(double* lengths, double* spread) const {
  if (config_.bone_window <= 0 || bone_count_ < config_.bone_window) return false;
  for (int g = 0; g < gpd::kJoints; ++g) {
    if (lengths) lengths[g] = bone_length_[g];
    if (spread) spread[g] = bone_spread_[g];
  }
  return true;
}

void Stream::set_confidence_gate(float threshold, double max_hold, double max_missing_share) {
  if (!std::isfinite(threshold) || !(max_hold >= 0.0) || !std::isfinite(max_hold) || !(max_missing_share >= 0.0))
    throw Error(ErrorKind::kInvalidArgument,
                "stream: confidence threshold must be finite, max_hold and max_missing_share >= 0");
  config_.confidence_threshold = threshold;
  config_.max_hold = max_hold;
  config_.max_missing_share = max_missing_share;
}

void Stream::set_smoothing(bool enabled, double min_cutoff, double beta, double d_cutoff) {
  if (enabled && !(min_cutoff > 0.0 && std::isfinite(min_cutoff) && beta >= 0.0 && std::isfinite(beta) &&
                   d_cutoff > 0.0 && std::isfinite(d_cutoff)))
    throw Error(ErrorKind::kInvalidArgument, "stream: smoothing cutoffs must be > 0 Hz and beta >= 0");
  if (enabled && !config_.smoothing) filter_ready_ = false;  // start from the next frame
  config_.smoothing = enabled;
  config_.smoothing_min_cutoff = min_cutoff;
  config_.smoothing_beta = beta;
  config_.smoothing_d_cutoff = d_cutoff;
}

void Stream::end_segment() {
  if (pending_) emit(processed_ - 1, slot_at(processed_ - 1), false);
  pending_ = false;
  new_segment_ = true;
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
  for (int64_t f = processed_; f < accepted_; ++f) process(f, slot_at(f));
}

void Stream::process(int64_t frame, int slot) {
  const bool starts = starts_segment_[slot] != 0;
  segment_pos_[slot] = starts ? 0 : std::min(segment_pos_[slot_before(slot)] + 1, 2);
  float local[3 * gpd::kJoints];
  float hip_height = 0.0f;
  gpd::to_local_frame(joints_.data() + static_cast<size_t>(slot) * 3 * gpd::kJoints, height_, geometry_, local,
                      &hip_height);
  static_bits_[static_cast<size_t>(slot)] =
      gpd::static_features(local, hip_height, geometry_, vectors_.data() + static_cast<size_t>(slot) * gpd::kDims);
  processed_ = frame + 1;

  if (config_.stencil == gpd::Stencil::kBackward) {
    emit(frame, slot, false);
    return;
  }
  // Central: this frame completes its predecessor's stencil, or closes the previous segment.
  if (pending_) emit(frame - 1, slot_before(slot), /*central=*/!starts);
  pending_ = true;
}

void Stream::emit(int64_t frame, int slot, bool central) {
  float* kin = vectors_.data() + static_cast<size_t>(slot) * gpd::kDims + gpd::kOffsetJk;
  const int pos = segment_pos_[slot];
  const int prev = slot_before(slot);
  auto jc = [&](int s) { return vectors_.data() + static_cast<size_t>(s) * gpd::kDims; };
  uint32_t kinetic_bits;
  if (pos == 0) {
    kinetic_bits = gpd::kinetics_zero(kin);
  } else if (central) {
    const int next = slot_after(slot);
    const double h1 = time_[slot] - time_[prev];
    const double h2 = time_[next] - time_[slot];
    kinetic_bits = gpd::kinetics(jc(prev), jc(slot), jc(next), gpd::central_weights(h1, h2), kin);
  } else if (pos == 1) {
    kinetic_bits = gpd::kinetics_two_point(jc(prev), jc(slot), time_[slot] - time_[prev], kin);
  } else {
    const int prev2 = slot_before(prev);
    const double h1 = time_[prev] - time_[prev2];
    const double h2 = time_[slot] - time_[prev];
    kinetic_bits = gpd::kinetics(jc(prev2), jc(prev), jc(slot), gpd::backward_weights(h1, h2), kin);
  }
  // Finite by construction inside the plausibility range; checked so a bug can never hand out a
  // NaN: a non-finite vector is withheld (the previous one stays the newest) and reported. The
  // kernels report the largest magnitude they wrote, so a finite vector is not read again.
  const int bad = first_non_finite_feature(vectors_.data() + static_cast<size_t>(slot) * gpd::kDims,
                                           std::max(static_bits_[static_cast<size_t>(slot)], kinetic_bits));
  if (bad >= 0) {
    withheld_dim_ = bad;
    withheld_frame_ = frame;
    return;
  }
  out_time_ = time_[slot];
  out_frame_ = frame;
  out_slot_ = slot;
  ++emitted_;
}

int first_non_finite_feature(const float* vector, uint32_t largest_bits) {
  if (largest_bits < kInfBits) return -1;
  for (int i = 0; i < gpd::kDims; ++i)
    if (!std::isfinite(vector[i])) return i;
  return -1;  // the report was wrong, the vector is finite: publish it
}

Status Stream::flush() {
  if (height_ <= 0.0) finish_calibration();
  end_segment();
  return emitted_status();
}

void Stream::reset() { new_segment_ = true; }

std::vector<float> features_of_frames(const StreamConfig& config, const float* positions, int frames,
                                      double frame_time) {
  if (frames < 0 || (frames > 0 && !positions))
    throw Error(ErrorKind::kInvalidArgument, "features_of_frames: no positions");
  std::vector<float> out(static_cast<size_t>(std::max(frames, 0)) * gpd::kDims);
  const size_t stride = 3 * static_cast<size_t>(config.input_joints);
  size_t filled = 0;
  features_in_chunks(
      config,
      [&](int i, float* xyz) {
        const float* p = positions + static_cast<size_t>(i) * stride;
        std::copy(p, p + stride, xyz);
      },
      frames, frame_time, 1024, [&](const float* v, int n) {  // a small chunk: no second copy of `out`
        std::copy(v, v + static_cast<size_t>(n) * gpd::kDims, out.begin() + static_cast<long>(filled));
        filled += static_cast<size_t>(n) * gpd::kDims;
      });
  return out;
}

void features_in_chunks(const StreamConfig& config, const FramePositions& positions, int frames, double frame_time,
                        int chunk_frames, const FeatureSink& sink) {
  if (frames < 0 || (frames > 0 && !positions))
    throw Error(ErrorKind::kInvalidArgument, "features_of_frames: no positions");
  if (!(frame_time > 0.0) || !std::isfinite(frame_time))
    throw Error(ErrorKind::kInvalidArgument, "features_of_frames: frame time must be > 0 seconds");
  if (chunk_frames < 1) throw Error(ErrorKind::kInvalidArgument, "features_in_chunks: chunk of no frames");
  Stream stream(config);
  std::vector<float> chunk(static_cast<size_t>(std::min(chunk_frames, std::max(frames, 1))) * gpd::kDims);
  const int chunk_cap = static_cast<int>(chunk.size() / gpd::kDims);
  std::vector<float> xyz(3 * static_cast<size_t>(std::max(config.input_joints, 0)));
  int held = 0;        // vectors in `chunk`
  int64_t copied = 0;  // vectors copied out so far (they are frames 0, 1, ... in order)
  auto collect = [&] {
    for (; copied < stream.emitted_count(); ++copied) {
      const float* v = stream.vector_of(copied);
      std::copy(v, v + gpd::kDims, chunk.begin() + static_cast<long>(held) * gpd::kDims);
      if (++held == chunk_cap) {
        sink(chunk.data(), held);
        held = 0;
      }
    }
  };
  for (int i = 0; i < frames; ++i) {
    positions(i, xyz.data());
    const Status s = stream.push(i * frame_time, xyz.data(), config.input_joints);
    if (s != Status::kOk)
      throw Error(ErrorKind::kInvalidArgument, "frame " + std::to_string(i) + ": " + stream.last_error());
    collect();
  }
  if (stream.flush() != Status::kOk)
    throw Error(ErrorKind::kInvalidArgument, std::string("end of frames: ") + stream.last_error());
  collect();
  if (held > 0) sink(chunk.data(), held);
}

}  // namespace kata
