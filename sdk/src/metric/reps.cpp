#include "metric/reps.hpp"

#include <algorithm>
#include <cmath>

namespace kata::metric {

namespace {

constexpr const char* kRomNames[kRomJoints] = {"left_knee",  "right_knee",  "left_hip",      "right_hip",
                                               "left_elbow", "right_elbow", "left_shoulder", "right_shoulder"};
// GPD joints (spec gpd-v1.md section 1).
constexpr int kHip = 0, kNeck = 2, kLShoulder = 4, kLElbow = 5, kLHand = 6, kRShoulder = 7, kRElbow = 8, kRHand = 9,
              kLHip = 10, kLKnee = 11, kLFoot = 12, kRHip = 13, kRKnee = 14, kRFoot = 15;

// The angle between vectors u and v, degrees; 0 when either is degenerate.
float angle_between(const double* u, const double* v) {
  const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2], vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  if (!(uu > 1e-18) || !(vv > 1e-18) || !std::isfinite(uu) || !std::isfinite(vv)) return 0.0f;
  const double c = std::clamp((u[0] * v[0] + u[1] * v[1] + u[2] * v[2]) / std::sqrt(uu * vv), -1.0, 1.0);
  return static_cast<float>(std::acos(c) * (180.0 / 3.14159265358979323846));
}

}  // namespace

const char* rom_joint_name(int joint) { return joint >= 0 && joint < kRomJoints ? kRomNames[joint] : "?"; }

void rom_angles(const float* x, bool hip_at_origin, float* degrees) {
  const auto at = [&](int j, int c) -> double {
    if (hip_at_origin) return j == 0 ? 0.0 : static_cast<double>(x[3 * (j - 1) + c]);
    return static_cast<double>(x[3 * j + c]);
  };
  // The angle at joint b between the segments b -> a and b -> c (a, c joints), or between the
  // directions (a0 -> a1) and (b0 -> b1) when given as two segments.
  const auto at_joint = [&](int a, int b, int c) {
    double u[3], v[3];
    for (int k = 0; k < 3; ++k) u[k] = at(a, k) - at(b, k), v[k] = at(c, k) - at(b, k);
    return angle_between(u, v);
  };
  const auto between = [&](int a0, int a1, int b0, int b1) {
    double u[3], v[3];
    for (int k = 0; k < 3; ++k) u[k] = at(a1, k) - at(a0, k), v[k] = at(b1, k) - at(b0, k);
    return angle_between(u, v);
  };
  degrees[0] = at_joint(kLHip, kLKnee, kLFoot);
  degrees[1] = at_joint(kRHip, kRKnee, kRFoot);
  degrees[2] = between(kHip, kNeck, kLHip, kLKnee);
  degrees[3] = between(kHip, kNeck, kRHip, kRKnee);
  degrees[4] = at_joint(kLShoulder, kLElbow, kLHand);
  degrees[5] = at_joint(kRShoulder, kRElbow, kRHand);
  degrees[6] = between(kNeck, kHip, kLShoulder, kLElbow);
  degrees[7] = between(kNeck, kHip, kRShoulder, kRElbow);
}

void RepCounter::Range::add(const float* a) {
  for (int i = 0; i < kRomJoints; ++i) {
    lo[i] = any ? std::min(lo[i], a[i]) : a[i];
    hi[i] = any ? std::max(hi[i], a[i]) : a[i];
  }
  any = true;
}

void RepCounter::Range::add(const Range& r) {
  if (!r.any) return;
  for (int i = 0; i < kRomJoints; ++i) {
    lo[i] = any ? std::min(lo[i], r.lo[i]) : r.lo[i];
    hi[i] = any ? std::max(hi[i], r.hi[i]) : r.hi[i];
  }
  any = true;
}

RepCounter::RepCounter(std::shared_ptr<const Reference> reference) : reference_(std::move(reference)) {
  if (reference_ && reference_->kind() == ReferenceKind::kClip) set_section(0, reference_->frames() - 1, false);
}

void RepCounter::set_section(int first, int last, bool loop) {
  if (!reference_ || reference_->kind() != ReferenceKind::kClip) return;
  first_ = std::clamp(first, 0, reference_->frames() - 1);
  last_ = std::clamp(last < 0 ? reference_->frames() - 1 : last, first_, reference_->frames() - 1);
  loop_ = loop;
  const int n = last_ - first_ + 1;
  period_ = (loop_ ? n : std::max(1, n - 1)) * reference_->frame_time();
  Range teacher;
  float a[kRomJoints];
  for (int j = first_; j <= last_; ++j) {
    rom_angles(reference_->pose(j), false, a);
    teacher.add(a);
  }
  for (int i = 0; i < kRomJoints; ++i) teacher_range_[i] = teacher.hi[i] - teacher.lo[i];
  has_prev_ = false;
  progress_ = 0.0f;
}

void RepCounter::reset() {
  count_ = 0;
  has_prev_ = false;
  progress_ = 0.0f;
}

const Repetition& RepCounter::newest(int i) const {
  const int64_t k = ended_ - 1 - std::clamp<int64_t>(i, 0, kKept - 1);
  return kept_[static_cast<size_t>((k < 0 ? 0 : k) % kKept)];
}

void RepCounter::begin(double start_time, bool moving) {
  moving_ = moving;
  start_time_ = last_advance_ = start_time;
  std::fill(bins_, bins_ + kBins, false);
  range_.clear();
  pending_.clear();
  score_sum_ = 0.0;
  scored_ = frames_ = pending_frames_ = none_frames_ = 0;
  std::fill(part_frames_, part_frames_ + kParts, 0);
  for (auto& part : cue_frames_)
    for (auto& joint : part) std::fill(joint, joint + 5, 0);
  for (auto& part : cue_degrees_sum_)
    for (auto& joint : part) std::fill(joint, joint + 5, 0.0f);
}

void RepCounter::mark(int from, int to) {
  const int n = last_ - first_ + 1;
  int j = from;
  for (int guard = 0; guard <= n; ++guard) {
    bins_[std::min(kBins - 1, (j - first_) * kBins / n)] = true;
    if (j == to) break;
    j = j == last_ ? first_ : j + 1;
  }
}

double RepCounter::coverage() const {
  int covered = 0;
  for (bool b : bins_) covered += b ? 1 : 0;
  return static_cast<double>(covered) / kBins;
}

int RepCounter::close(double end_time, bool at_end) {
  const double covered = coverage();
  const bool complete = at_end && moving_ && covered >= kCompleteCoverage;
  if (!complete && covered < kPartialCoverage) return 0;  // noise: neither counted nor reported
  Repetition& r = kept_[static_cast<size_t>(ended_ % kKept)];
  r = Repetition{};
  r.index = count_ + 1;
  if (complete) ++count_;
  r.partial = !complete;
  r.start_time = start_time_;
  r.end_time = std::max(end_time, start_time_);
  r.tempo = period_ > 0.0 ? (r.end_time - r.start_time) / period_ : 0.0;
  r.score = scored_ > 0 ? static_cast<float>(score_sum_ / scored_) : 0.0f;
  // The part shown on most of its scoring frames, "none" counting as one (a part named on the
  // last third of a repetition, held over from the one before, is not its part to fix).
  int part = -1, most = none_frames_;
  for (int q = 0; q < kParts; ++q)
    if (part_frames_[q] > most) part = q, most = part_frames_[q];
  r.part_to_fix = part;
  if (part >= 0) {
    int best = 0, joint = -1, action = -1;
    for (int j = 0; j < gpd::kJoints; ++j)
      for (int a = 0; a < 5; ++a)
        if (cue_frames_[part][j][a] > best) best = cue_frames_[part][j][a], joint = j, action = a;
    if (joint >= 0) {
      r.cue_joint = joint;
      r.cue_action = action;
      r.cue_degrees = cue_degrees_sum_[part][joint][action] / static_cast<float>(best);
    }
  }
  r.coverage = static_cast<float>(covered);
  r.frames = frames_;
  for (int i = 0; i < kRomJoints; ++i) {
    r.range[i] = range_.any ? range_.hi[i] - range_.lo[i] : 0.0f;
    r.teacher_range[i] = teacher_range_[i];
  }
  ++ended_;
  return 1;
}

int RepCounter::finish(double t) {
  if (!has_prev_) return 0;
  (void)t;  // the repetition ends at its last forward step, not at the clip's end
  const int n = last_ - first_ + 1;
  const double p = static_cast<double>(prev_match_ - first_) / std::max(1, loop_ ? n : n - 1);
  const int ended = close(last_advance_, p >= kEndRegion);
  has_prev_ = false;
  return ended;
}

int RepCounter::update(const ScoreRecord& record, const float* features, const Aligner& aligner) {
  if (!reference_ || reference_->kind() != ReferenceKind::kClip) return 0;
  if (aligner.first() != first_ || aligner.last() != last_ || aligner.options().loop != loop_)
    set_section(aligner.first(), aligner.last(), aligner.options().loop);
  const double t = record.time;
  const bool lost = record.state == ScoreState::kTrackingLost || !features;
  float angles[kRomJoints] = {};
  if (!lost) rom_angles(features, true, angles);
  const int n = last_ - first_ + 1;
  const double span = loop_ ? n : std::max(1, n - 1);
  // A frame without a pose holds the match where it was (the alignment holds too).
  const int m = lost && has_prev_ ? prev_match_ : std::clamp(static_cast<int>(record.matched), first_, last_);
  const double p = (m - first_) / span;
  progress_ = static_cast<float>(std::clamp(p, 0.0, 1.0));
  int ended = 0;
  if (!has_prev_) {
    has_prev_ = true;
    prev_match_ = m;
    prev_time_ = moved_at_ = t;
    begin(t, false);
    if (!lost) pending_.add(angles);
    return 0;
  }
  const double dt = std::max(0.0, t - prev_time_);
  const double prev_p = (prev_match_ - first_) / span;
  int delta = m - prev_match_;
  bool wrapped = false;
  if (loop_) {
    if (delta > n / 2) delta -= n;
    if (delta < -n / 2) delta += n;
    wrapped = delta > 0 && m < prev_match_;
  }
  // A forward step: within the alignment's band (AlignmentOptions::window) while the match keeps
  // moving with the motion (moved_at_: the last frame it moved on scoring kMotionScore or more):
  // against another person's style the match often holds a few frames and then catches up
  // within its band, which still follows the motion. After a hold longer than kEndHold (the student
  // stopped) only what the alignment's fastest rate allows over this frame's interval (one frame
  // more for the rounding). A longer move is a jump (a re-localisation) and covers nothing; so does
  // a step taken on a frame that scores below kMotionScore on the model's scale (another motion:
  // the match wanders).
  const double ft = reference_->frame_time();
  const int rate_step = 1 + static_cast<int>(std::ceil(aligner.options().max_rate * dt / ft));
  const int band = static_cast<int>(std::ceil(aligner.options().window / ft));
  const int max_step = t - moved_at_ <= kEndHold ? std::max(rate_step, band) : rate_step;
  const bool motion = record.state != ScoreState::kScoring || record.model_score >= kMotionScore;
  const bool forward = delta > 0 && delta <= max_step && !lost;
  const bool covers = forward && motion;
  if (delta > 0 && !lost && motion) moved_at_ = t;  // the student moving through the motion
  if (forward && wrapped) {
    // The wrap: the step crosses the section's end at the fraction of it before the end frame's
    // successor (the section's first frame).
    const double before = std::clamp(static_cast<double>(last_ - prev_match_ + 1) / delta, 0.0, 1.0);
    const double crossing = prev_time_ + dt * before;
    const double end = moving_ && last_advance_ == prev_time_ ? crossing : last_advance_;
    ended += close(end, true);
    begin(crossing, true);
    if (covers) mark(first_, m);
    range_.add(angles);
    frames_ = 1;
    last_advance_ = t;
  } else if (!forward && delta != 0 && p <= kStartRegion && prev_p - p >= kStartRegion && !lost) {
    // A jump back into the start: a restart (or a non-looped teacher's re-localisation there).
    ended += close(last_advance_, prev_p >= kEndRegion);
    begin(t, false);
    pending_.add(angles);
  } else if (forward) {
    if (covers) mark(prev_match_, m);
    if (!moving_) {
      moving_ = true;
      range_ = pending_;  // the frame before the first step: the repetition's start
      frames_ = pending_.any ? 1 : 0;
    } else {
      range_.add(pending_);
      frames_ += pending_frames_;
    }
    pending_.clear();
    pending_frames_ = 0;
    range_.add(angles);
    ++frames_;
    last_advance_ = t;
  } else {
    // No step forward: a hold, a step back, a jump within the section, or no pose.
    if (!moving_) begin(t, false);  // not started yet: the repetition starts later
    if (!lost) {
      pending_.add(angles);
      ++pending_frames_;
    }
    if (moving_ && p >= kEndRegion && t - last_advance_ >= kEndHold && coverage() >= kCompleteCoverage) {
      ended += close(last_advance_, true);  // finished and stopped at the end
      begin(t, false);
    }
  }
  if (record.state == ScoreState::kScoring) {
    score_sum_ += record.score;
    ++scored_;
    const int part = record.part_to_fix;
    if (part < 0 || part >= kParts) ++none_frames_;
    if (part >= 0 && part < kParts) {
      ++part_frames_[part];
      const int joint = record.cue_joint, action = record.cue_action;
      if (joint >= 0 && joint < gpd::kJoints && action >= 0 && action < 5) {
        ++cue_frames_[part][joint][action];
        cue_degrees_sum_[part][joint][action] += record.cue_degrees;
      }
    }
  }
  prev_match_ = m;
  prev_time_ = t;
  return ended;
}

}  // namespace kata::metric
