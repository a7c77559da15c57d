#include "people/tracker.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/error.hpp"

namespace kata::people {
namespace {

constexpr double kMaxCoordinate = 1e9;   // KATA_MAX_COORDINATE
constexpr double kVelocitySmoothing = 0.4;  // weight of the newest velocity in the smoothed one
constexpr double kSizeSmoothing = 0.2;      // ... and of the newest size
constexpr double kMaxSpeed = 20.0;          // body sizes per second: a faster prediction is cut

void require(bool ok, const std::string& what) {
  if (!ok) throw Error(ErrorKind::kInvalidArgument, "people tracker: " + what);
}

bool positive_finite(double x) { return std::isfinite(x) && x > 0.0; }

}  // namespace

Tracker::Tracker(const TrackerConfig& config)
    : config_(config), hungarian_(std::max(1, config.max_people + config.max_poses)) {
  require(config.joints >= 1 && config.joints <= 4096, "joints must be 1..4096");
  require(config.max_people >= 1 && config.max_people <= kMaxPeople, "max_people must be 1..64");
  require(config.max_poses >= 1 && config.max_poses <= kMaxPeople, "max_poses must be 1..64");
  require(positive_finite(config.forget_seconds) && config.forget_seconds <= 3600.0,
          "forget_seconds must be above 0 and at most 3600");
  require(std::isfinite(config.coast_seconds) && config.coast_seconds >= 0.0 && config.coast_seconds <= 60.0,
          "coast_seconds must be 0..60");
  require(positive_finite(config.gate) && config.gate <= 1000.0, "gate must be above 0 and at most 1000");
  require(std::isfinite(config.gate_growth) && config.gate_growth >= 0.0 && config.gate_growth <= 1000.0,
          "gate_growth must be 0..1000");
  require(std::isfinite(config.size_gate) && config.size_gate >= 1.0 && config.size_gate <= 1000.0,
          "size_gate must be 1..1000");
  require(std::isfinite(config.shape_weight) && config.shape_weight >= 0.0 && config.shape_weight <= 1000.0,
          "shape_weight must be 0..1000");
  require(std::isfinite(config.min_confidence) && config.min_confidence >= 0.0 && config.min_confidence <= 1.0,
          "min_confidence must be 0..1");
  const size_t people = static_cast<size_t>(config.max_people), joints = static_cast<size_t>(config.joints);
  const size_t n = people + static_cast<size_t>(config.max_poses);
  tracks_.resize(people);
  shape_.assign(people * joints * 3, 0.0f);
  shape_weight_.assign(people * joints, 0.0f);
  poses_.resize(static_cast<size_t>(config.max_poses));
  slot_of_row_.resize(people);
  matrix_.resize(n * n);
  assignment_.resize(n);
  opened_.resize(static_cast<size_t>(config.max_poses));
  closed_.resize(people);
}

bool Tracker::summarise(const float* xyz, const float* confidence, int i, Pose* out) {
  const int joints = config_.joints;
  const float* p = xyz + static_cast<size_t>(i) * static_cast<size_t>(joints) * 3;
  const float* w = confidence ? confidence + static_cast<size_t>(i) * static_cast<size_t>(joints) : nullptr;
  int used = 0;
  double sum[3] = {0, 0, 0}, total_confidence = 0.0;
  for (int j = 0; j < joints; ++j) {
    if (w) {
      if (!std::isfinite(w[j])) return ++counters_.refused_non_finite, false;
      if (w[j] < config_.min_confidence) continue;
      total_confidence += std::min(1.0, static_cast<double>(w[j]));
    } else {
      total_confidence += 1.0;
    }
    for (int k = 0; k < 3; ++k) {
      const double x = p[3 * j + k];
      if (!std::isfinite(x)) return ++counters_.refused_non_finite, false;
      if (std::fabs(x) > kMaxCoordinate) return ++counters_.refused_out_of_range, false;
      sum[k] += x;
    }
    ++used;
  }
  if (used < kMinJoints) return ++counters_.refused_few_joints, false;
  double c[3], extent = 0.0;
  for (int k = 0; k < 3; ++k) c[k] = sum[k] / used;
  double spread = 0.0;
  for (int j = 0; j < joints; ++j) {
    if (w && w[j] < config_.min_confidence) continue;
    for (int k = 0; k < 3; ++k) {
      const double d = p[3 * j + k] - c[k];
      spread += d * d;
      extent = std::max(extent, std::fabs(c[k]));
    }
  }
  const double size = std::sqrt(spread / used);
  // No extent: every confident joint on one point (relative to float precision at that place).
  if (!(size > 1e-6 * std::max(1.0, extent))) return ++counters_.refused_few_joints, false;
  out->index = i;
  for (int k = 0; k < 3; ++k) out->c[k] = c[k];
  out->size = size;
  out->confidence = total_confidence / joints;
  return true;
}

void Tracker::predict(const Track& t, double time, double* out) const {
  const double ahead = std::min(std::max(time - t.last_seen, 0.0), config_.coast_seconds);
  for (int k = 0; k < 3; ++k) out[k] = t.c[k] + t.v[k] * ahead;
}

double Tracker::cost(const Track& t, int slot, const Pose& p, const float* xyz, const float* confidence,
                     double now, bool* gated_in) const {
  double pc[3];
  predict(t, now, pc);
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) d2 += (p.c[k] - pc[k]) * (p.c[k] - pc[k]);
  const double distance = std::sqrt(d2) / t.size;
  const double ratio = p.size / t.size;
  const double radius = config_.gate + config_.gate_growth * (now - t.last_seen);
  *gated_in = distance <= radius && ratio <= config_.size_gate && ratio * config_.size_gate >= 1.0;
  if (!*gated_in) return 0.0;
  const int joints = config_.joints;
  const float* x = xyz + static_cast<size_t>(p.index) * static_cast<size_t>(joints) * 3;
  const float* w = confidence ? confidence + static_cast<size_t>(p.index) * static_cast<size_t>(joints) : nullptr;
  const float* s = shape_.data() + static_cast<size_t>(slot) * static_cast<size_t>(joints) * 3;
  const float* sw = shape_weight_.data() + static_cast<size_t>(slot) * static_cast<size_t>(joints);
  double shape = 0.0;
  int common = 0;
  for (int j = 0; j < joints; ++j) {
    if (sw[j] == 0.0f || (w && w[j] < config_.min_confidence)) continue;
    double e2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double e = (x[3 * j + k] - p.c[k]) - s[3 * j + k];
      e2 += e * e;
    }
    shape += std::sqrt(e2);
    ++common;
  }
  if (common > 0) shape /= common * t.size;
  return distance + config_.shape_weight * shape;
}

void Tracker::take(Track& t, int slot, const Pose& p, const float* xyz, const float* confidence, double now) {
  if (t.frames_seen > 0) {
    const double dt = now - t.last_seen;
    double v_new[3], speed2 = 0.0;
    const double a = t.frames_seen == 1 ? 1.0 : kVelocitySmoothing;
    for (int k = 0; k < 3; ++k) {
      v_new[k] = t.v[k] + a * ((p.c[k] - t.c[k]) / dt - t.v[k]);
      speed2 += v_new[k] * v_new[k];
    }
    const double limit = kMaxSpeed * t.size, speed = std::sqrt(speed2);
    const double cut = speed > limit ? limit / speed : 1.0;
    for (int k = 0; k < 3; ++k) t.v[k] = v_new[k] * cut;
    t.size += kSizeSmoothing * (p.size - t.size);
  } else {
    for (int k = 0; k < 3; ++k) t.v[k] = 0.0;
    t.size = p.size;
  }
  for (int k = 0; k < 3; ++k) t.c[k] = p.c[k];
  t.last_seen = now;
  ++t.frames_seen;
  const int joints = config_.joints;
  const float* x = xyz + static_cast<size_t>(p.index) * static_cast<size_t>(joints) * 3;
  const float* w = confidence ? confidence + static_cast<size_t>(p.index) * static_cast<size_t>(joints) : nullptr;
  float* s = shape_.data() + static_cast<size_t>(slot) * static_cast<size_t>(joints) * 3;
  float* sw = shape_weight_.data() + static_cast<size_t>(slot) * static_cast<size_t>(joints);
  for (int j = 0; j < joints; ++j) {
    if (w && w[j] < config_.min_confidence) continue;  // keeps the joint's last confident place
    for (int k = 0; k < 3; ++k) s[3 * j + k] = static_cast<float>(x[3 * j + k] - p.c[k]);
    sw[j] = 1.0f;
  }
}

Frame Tracker::track(double time, const float* xyz, const float* confidence, int pose_count, uint32_t* ids) {
  if (!std::isfinite(time) || (has_time_ && !(time > last_time_))) {
    ++counters_.refused_frames;
    return std::isfinite(time) ? Frame::kTimeNotIncreasing : Frame::kTimeNotFinite;
  }
  has_time_ = true;
  last_time_ = time;
  ++counters_.frames;
  counters_.poses += static_cast<uint64_t>(std::max(pose_count, 0));
  if (pose_count <= 0) ++counters_.empty_frames;
  opened_count_ = closed_count_ = 0;
  for (int i = 0; i < pose_count; ++i) ids[i] = 0;

  // Streams unseen for too long close first: their person, should they return, is new.
  for (Track& t : tracks_) {
    if (t.id != 0 && time - t.last_seen > config_.forget_seconds) {
      closed_[static_cast<size_t>(closed_count_++)] = t.id;
      ++counters_.closed;
      t = Track{};
    }
  }

  // The valid poses, the most confident max_poses of them (kept sorted, most confident first).
  int taken = 0;
  const int max_poses = config_.max_poses;
  for (int i = 0; i < pose_count; ++i) {
    Pose p;
    if (!summarise(xyz, confidence, i, &p)) continue;
    if (taken == max_poses) {
      ++counters_.refused_too_many_poses;
      if (!(p.confidence > poses_[static_cast<size_t>(taken - 1)].confidence)) continue;
      --taken;  // the least confident gives way
    }
    int at = taken++;
    while (at > 0 && poses_[static_cast<size_t>(at - 1)].confidence < p.confidence) {
      poses_[static_cast<size_t>(at)] = poses_[static_cast<size_t>(at - 1)];
      --at;
    }
    poses_[static_cast<size_t>(at)] = p;
  }

  // The cost matrix over the open streams and the taken poses (see tracker.hpp, step 5).
  int rows = 0;
  for (int s = 0; s < config_.max_people; ++s)
    if (tracks_[static_cast<size_t>(s)].id != 0) slot_of_row_[static_cast<size_t>(rows++)] = s;
  const int n = rows + taken;
  if (rows > 0 && taken > 0) {
    double* m = matrix_.data();
    const auto at = [&](int r, int c) -> double& { return m[static_cast<size_t>(r) * static_cast<size_t>(n) + static_cast<size_t>(c)]; };
    double worst = 0.0;
    for (int r = 0; r < rows; ++r) {
      const int slot = slot_of_row_[static_cast<size_t>(r)];
      for (int c = 0; c < taken; ++c) {
        bool in = false;
        const double v = cost(tracks_[static_cast<size_t>(slot)], slot, poses_[static_cast<size_t>(c)], xyz, confidence, time, &in);
        at(r, c) = in ? v : -1.0;  // -1: outside the gate (filled below)
        if (in) worst = std::max(worst, v);
      }
    }
    const double miss = worst + 1.0;  // 2 miss above any gated cost
    const double forbidden = (n + 1) * 2.0 * miss;  // above the all-miss assignment's total
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        if (r < rows && c < taken) {
          if (at(r, c) < 0.0) at(r, c) = forbidden;
        } else if (r < rows) {
          at(r, c) = (c - taken == r) ? miss : forbidden;  // stream r unmatched
        } else if (c < taken) {
          at(r, c) = (r - rows == c) ? miss : forbidden;  // pose c opens a stream
        } else {
          at(r, c) = 0.0;
        }
      }
    }
    hungarian_.solve(m, n, assignment_.data());
    for (int r = 0; r < rows; ++r) {
      const int c = assignment_[static_cast<size_t>(r)];
      if (c >= taken || at(r, c) >= forbidden) continue;
      const int slot = slot_of_row_[static_cast<size_t>(r)];
      Track& t = tracks_[static_cast<size_t>(slot)];
      Pose& p = poses_[static_cast<size_t>(c)];
      take(t, slot, p, xyz, confidence, time);
      ids[p.index] = t.id;
      ++counters_.assigned;
    }
  }

  // Poses no stream took: new people, while there is room.
  for (int c = 0; c < taken; ++c) {
    const Pose& p = poses_[static_cast<size_t>(c)];
    if (ids[p.index] != 0) continue;
    int slot = -1;
    for (int s = 0; s < config_.max_people && slot < 0; ++s)
      if (tracks_[static_cast<size_t>(s)].id == 0) slot = s;
    if (slot < 0) {
      ++counters_.refused_table_full;
      continue;
    }
    Track& t = tracks_[static_cast<size_t>(slot)];
    t = Track{};
    t.id = next_id_;
    next_id_ = next_id_ == UINT32_MAX ? 1 : next_id_ + 1;
    float* sw = shape_weight_.data() + static_cast<size_t>(slot) * static_cast<size_t>(config_.joints);
    std::fill(sw, sw + config_.joints, 0.0f);
    take(t, slot, p, xyz, confidence, time);
    ids[p.index] = t.id;
    opened_[static_cast<size_t>(opened_count_++)] = t.id;
    ++counters_.opened;
    ++counters_.assigned;
  }
  return Frame::kTaken;
}

int Tracker::open_streams(uint32_t* out, int capacity) const {
  int count = 0;
  for (const Track& t : tracks_) {
    if (t.id == 0) continue;
    if (out && count < capacity) out[count] = t.id;
    ++count;
  }
  return count;
}

bool Tracker::predicted(uint32_t id, double time, double* centroid) const {
  if (id == 0) return false;
  for (const Track& t : tracks_) {
    if (t.id != id) continue;
    predict(t, time, centroid);
    return true;
  }
  return false;
}

}  // namespace kata::people
