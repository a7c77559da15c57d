#include "metric/scorer.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"
#include "metric/pose_error.hpp"

namespace kata::metric {

namespace {
// Sum of the part rows (u = W^T e from the per-part e-projections).
void sum_parts(const float* p, int stride, float* u) {
  for (int c = 0; c < stride; ++c) {
    float s = 0.0f;
    for (int q = 0; q < kParts; ++q) s += p[static_cast<size_t>(q) * stride + c];
    u[c] = s;
  }
}
}  // namespace

void Scorer::Workspace::fit(const Metric& m) {
  const size_t v = static_cast<size_t>(m.groups()) * m.stride();
  const size_t p_floats = static_cast<size_t>(kProjectionRows) * m.stride();
  if (metric.xp.size() < static_cast<size_t>(gpd::kDims) || metric.v.size() < v || p.size() < p_floats ||
      u.size() < static_cast<size_t>(m.stride())) {
    metric.xp = AlignedFloats(std::max(metric.xp.size(), static_cast<size_t>(gpd::kDims)));
    metric.v = AlignedFloats(std::max(metric.v.size(), v));
    p = AlignedFloats(std::max(p.size(), p_floats));
    u = AlignedFloats(std::max(u.size(), static_cast<size_t>(m.stride())));
  } else if (m.stride() != stride_ || m.groups() != groups_) {
    for (AlignedFloats* a : {&metric.xp, &metric.v, &p, &u}) std::fill_n(a->data(), a->size(), 0.0f);
  }
  stride_ = m.stride();
  groups_ = m.groups();
}

bool tracking_lost(const float* joints, int min_tracked) {
  int tracked = 0;
  for (int j = 0; j < gpd::kJoints; ++j) {
    const float* p = joints + 3 * j;
    const bool finite = std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
    if (finite && !(p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f)) ++tracked;
  }
  return tracked < min_tracked;
}

Scorer::Scorer(std::shared_ptr<const Reference> reference, AlignmentOptions options, FeedbackOptions feedback)
    : reference_(std::move(reference)), aligner_(reference_, options), feedback_(feedback) {
  if (!(feedback_.hold_time >= 0.0) || !(feedback_.calibrating_time >= 0.0) || !(feedback_.finished_time >= 0.0) ||
      !(feedback_.smoothing_time >= 0.0) || !std::isfinite(feedback_.smoothing_time))
    throw Error(ErrorKind::kInvalidArgument,
                "scorer: feedback hold, calibrating, finished and smoothing times must be >= 0 (smoothing finite)");
  const Metric& m = reference_->metric();
  calibration_ = m.calibration();
  own_.fit(m);
  if (reference_->kind() == ReferenceKind::kClip)
    rematch_frames_ = static_cast<int>(std::lround(options.rematch_time / reference_->frame_time()));
  rematch_rest_max_ = 12.0 * (2.0 - 2.0 * std::cos(kRematchAgreement * (3.14159265358979323846 / 180.0)));
}

int Scorer::rematch(int j) {
  const Reference& ref = *reference_;
  // The frames within reach, inside the section and, while the alignment moves on (not back: a
  // re-localisation or a restart), not before the last re-matched frame: the ghost never steps
  // back when the alignment does not.
  const int lo = std::max(aligner_.first(), std::max(j - rematch_frames_, j >= last_aligned_ ? last_rematched_ : -1));
  const int hi = std::min(aligner_.last(), j + rematch_frames_);
  int best = -1;
  double best_cost = 0.0, best_rest = 0.0;
  // Outward from j, so that of equal costs the nearest frame wins.
  for (int k = 0; k <= rematch_frames_; ++k)
    for (int side : {-1, 1}) {
      const int i = j + side * k;
      if (i < lo || i > hi || (k == 0 && side > 0)) continue;
      double rest = 0.0;
      const double cost = trimmed_pose_distance(bones_, ref.pose(i), &rest);
      if (best < 0 || cost < best_cost) best_cost = cost, best_rest = rest, best = i;
    }
  // Only where the rest of the body agrees (its 12 bones within kRematchAgreement degrees on
  // average, as 2 - 2 cos): elsewhere (another motion, another person's style) the frame that fits
  // best nearby is not known to be the right one, and the alignment's match stands (or the last
  // re-matched frame, if the match is behind it).
  const int out = best >= 0 && best_rest <= rematch_rest_max_ ? best : std::max(j, lo);
  last_aligned_ = j;
  last_rematched_ = out;
  return out;
}

void Scorer::reset() {
  aligner_.reset();
  count_ = 0;
  at_end_since_ = -1.0;
  candidate_ = shown_ = cue_candidate_ = cue_shown_ = -1;
  last_aligned_ = last_rematched_ = -1;
  smoothed_time_ = -1.0;
  record_ = ScoreRecord{};
}

void Scorer::set_section(int first, int last, bool loop) {
  AlignmentOptions o = aligner_.options();
  o.first_frame = first;
  o.last_frame = last;
  o.loop = loop;
  aligner_ = Aligner(reference_, o);  // throws before anything changes
  last_aligned_ = last_rematched_ = -1;
  at_end_since_ = -1.0;
}

void Scorer::set_calibration(const ScoreCalibration& calibration) {
  validate_calibration(calibration);
  calibration_ = calibration;
}

const ScoreRecord& Scorer::score_lost(double t) {
  if (count_ == 0) start_time_ = t;
  record_.time = t;
  record_.frame = count_++;
  record_.distance = 0.0f;
  record_.score = 0.0f;
  record_.model_score = 0.0f;
  for (int q = 0; q < kParts; ++q)
    record_.parts[q] = record_.part_distance[q] = record_.part_scores[q] = record_.part_degrees[q] =
        record_.part_offset[q] = 0.0f;
  record_.matched = aligned_ = aligner_.match();
  record_.matched_time = record_.matched * reference_->frame_time();
  record_.state = ScoreState::kTrackingLost;
  // The cue is withdrawn at once: nothing about the pose is known.
  record_.part_to_fix = shown_ = candidate_ = -1;
  clear_cue();
  smoothed_time_ = -1.0;
  return record_;
}

const ScoreRecord& Scorer::score(const float* x, double t) { return score(x, t, own_); }

const ScoreRecord& Scorer::score(const float* x, double t, Workspace& ws) {
  ws_ = &ws;
  reference_->metric().part_projections(x, ws.metric, ws.p.data());
  finish(x, t);
  return record_;
}

const ScoreRecord& Scorer::score_matched(const float* x, double t, int matched) {
  ws_ = &own_;
  reference_->metric().part_projections(x, own_.metric, own_.p.data());
  finish(x, t, std::clamp(matched, 0, reference_->frames() - 1));
  return record_;
}

void Scorer::score_batch(Scorer* const* scorers, const float* const* x, const double* t, int n) {
  score_batch(scorers, x, t, n, nullptr);
}

void Scorer::score_batch(Scorer* const* scorers, const float* const* x, const double* t, int n,
                         Workspace* const* workspaces) {
  // Small fixed-size pointer tables per kBatch group: no allocation.
  for (int f0 = 0; f0 < n; f0 += detail::kBatch) {
    const int m = std::min(detail::kBatch, n - f0);
    Metric::Workspace* ws[detail::kBatch];
    float* p[detail::kBatch];
    for (int f = 0; f < m; ++f) {
      Scorer& s = *scorers[f0 + f];
      s.ws_ = workspaces ? workspaces[f] : &s.own_;
      ws[f] = &s.ws_->metric;
      p[f] = s.ws_->p.data();
    }
    scorers[f0]->reference_->metric().part_projections_batch(x + f0, ws, p, m);
    // Stage by stage: every frame's alignment pass, then every frame's part split, angles and
    // feedback (each scorer's own state: the order across scorers changes nothing).
    for (int f = 0; f < m; ++f) scorers[f0 + f]->align_frame(t[f0 + f]);
    for (int f = 0; f < m; ++f) scorers[f0 + f]->finish_aligned(x[f0 + f], t[f0 + f], false);
  }
}

void Scorer::finish(const float* x, double t, int matched) {
  if (matched >= 0)
    aligned_ = matched;
  else
    align_frame(t);
  finish_aligned(x, t, matched >= 0);
}

void Scorer::align_frame(double t) {
  const int stride = reference_->metric().stride();
  aligned_ = aligner_.align(ws_->p.data() + static_cast<size_t>(kParts) * stride, t);
}

void Scorer::finish_aligned(const float* x, double t, bool given) {
  const Reference& ref = *reference_;
  const Metric& m = ref.metric();
  const int stride = m.stride();
  float* p = ws_->p.data();
  pose_frames(x, pose_);
  int j = aligned_;
  if (!given && rematch_frames_ > 0) {
    bone_directions(pose_, bones_);
    j = rematch(j);
  }
  // e-projections per part: D_p = P_p(x) - P_p(y_j); u = sum_p D_p; part p = u . D_p (the split
  // of d^2). The part's distance is its joint-position row's: J_p(x) - J_p(y_j), the part's own
  // joints only (metric.hpp kJointRows: a shared dimension would credit a part that did not move).
  // (The teacher's rows as the Reference keeps them: 16-bit, within 2^-16 of each row's largest;
  // a difference within that rounding is 0, reference.hpp subtract_projection.)
  ref.subtract_projection(j, p);
  const size_t joint_rows = static_cast<size_t>(kJointRows) * stride;
  float* u = ws_->u.data();
  sum_parts(p, stride, u);
  const double d2 = detail::dot(u, u, stride);
  const ScoreCalibration& c = calibration_;
  // The parts' joint angles against the matched teacher frame, and their scores (pose_error.hpp).
  part_error(pose_, ref.pose(j), error_);
  bone_cue(pose_, ref.pose(j), cue_);
  double worst = 100.0;
  for (int q = 0; q < kParts; ++q) {
    const float* pq = p + static_cast<size_t>(q) * stride;
    record_.parts[q] = static_cast<float>(detail::dot(u, pq, stride));
    const float* jq = p + joint_rows + static_cast<size_t>(q) * stride;
    record_.part_distance[q] = static_cast<float>(std::sqrt(detail::dot(jq, jq, stride)));
    record_.part_degrees[q] = error_.degrees[q];
    record_.part_joint[q] = error_.joint[q];
    record_.part_offset[q] = error_.offset[q];
    const double sq = angle_score(error_.degrees[q], tolerance_);
    record_.part_scores[q] = static_cast<float>(sq);
    worst = std::min(worst, sq);
  }
  const double d = std::sqrt(d2);
  if (count_ == 0) start_time_ = t;
  record_.time = t;
  record_.frame = count_++;
  record_.distance = static_cast<float>(d);
  const double model = calibrated_score(d, c.d50, c.slope);
  record_.model_score = static_cast<float>(model);
  // The total is never above the worst part (kata.h, docs/model/scores.md "The coaching total").
  record_.score = static_cast<float>(std::min(model, worst));
  record_.matched = j;
  record_.matched_time = j * ref.frame_time();
  feedback(t);
}

void Scorer::feedback(double t) {
  const Reference& ref = *reference_;
  ScoreState state = ScoreState::kScoring;
  if (ref.kind() == ReferenceKind::kClip && !aligner_.options().loop && aligned_ == aligner_.last()) {
    if (at_end_since_ < 0.0) at_end_since_ = t;
    if (t - at_end_since_ >= feedback_.finished_time && ref.frames() > 1) state = ScoreState::kTeacherFinished;
  } else {
    at_end_since_ = -1.0;
  }
  if (t - start_time_ < feedback_.calibrating_time) state = ScoreState::kCalibrating;
  record_.state = state;
  if (state != ScoreState::kScoring) {
    shown_ = candidate_ = -1;  // no cue outside scoring; the next one starts fresh
    clear_cue();
    smoothed_time_ = -1.0;
  } else {
    update_part_to_fix(t);
  }
  record_.part_to_fix = shown_;
}

void Scorer::update_part_to_fix(double t) {
  // The part scores averaged over smoothing_time: an exponential average over the frames' own time
  // steps (a lower frame rate weighs each frame more), normalised by the weights it has summed
  // since scoring (re)started, so that the first frames are the mean of the frames seen so far
  // and the first one does not stand in for the whole past (replayed on the 98 real pairs of
  // docs/model/part_fix_rules.py: the average started from the first frame agreed with geometry
  // on 71, the normalised one on 75; the pairs are 0.8-4.7 s, and the first 0.5 s weighed as
  // much as the rest). A single frame's lowest part changes every few frames (joints cross the
  // reference's path); a coach names what has been wrong for a while.
  const double keep = smoothed_time_ < 0.0 || feedback_.smoothing_time <= 0.0
                          ? 0.0
                          : std::exp(-(t - smoothed_time_) / feedback_.smoothing_time);
  smoothed_weight_ = 1.0 + keep * smoothed_weight_;
  const double take = 1.0 / smoothed_weight_;  // this frame's share of the normalised average
  for (int q = 0; q < kParts; ++q) {
    smoothed_parts_[q] += take * (record_.part_scores[q] - smoothed_parts_[q]);
    smoothed_offset_[q] += take * (record_.part_offset[q] - smoothed_offset_[q]);
  }
  for (int c = 1; c < gpd::kJoints; ++c) {
    smoothed_cue_[c] += take * (cue_.degrees[c] - smoothed_cue_[c]);
    smoothed_change_[c] += take * (cue_.change[c] - smoothed_change_[c]);
  }
  smoothed_total_ += take * (record_.score - smoothed_total_);
  smoothed_time_ = t;
  // The candidate, while the lowest averaged part score or the averaged total is below good (none
  // otherwise): among the part with the lowest averaged score and the parts below kBandScore whose
  // averaged score is within kOffsetBand points of it, the part whose joints are farthest from the
  // teacher's (the largest averaged offset, the local-frame mean joint distance that is geometry's
  // measure on real pairs; the torso's weighed kTorsoOffsetWeight times while it is below good).
  // Why both (docs/model/scores.md "The part to fix", replayed by docs/model/part_fix_rules.py on
  // the real pairs and on the turned copies of docs/model/part_fix_turned.py): the lowest score alone agreed
  // with geometry on 66 of 98 real pairs, since two people's parts differ by close scores and the
  // angle does not weigh a bone's length; the offset alone on 78, but blamed a chest bent 30 deg on
  // an arm (the arms ride on the chest, in the local frame they move farther than the torso's
  // joints). An arm the bend does not turn scores 100, above the band; the torso's weight keeps the
  // legs and arms that the online match puts a little off (scoring 93-98) from outranking a bent
  // chest. With only the total below good (the model's gate) the lowest part is named unless a part
  // within the band is farther off (the demo's left arm at 95-97 beside a torso at 56 is not).
  int32_t lowest = 0;
  for (int q = 1; q < kParts; ++q)
    if (smoothed_parts_[q] < smoothed_parts_[lowest] ||
        (smoothed_parts_[q] == smoothed_parts_[lowest] && smoothed_offset_[q] > smoothed_offset_[lowest]))
      lowest = q;
  const auto weighed = [this](int q) {
    const bool bent_torso = q == static_cast<int>(Part::kTorsoHead) && smoothed_parts_[q] < calibration_.good_score;
    return bent_torso ? kTorsoOffsetWeight * smoothed_offset_[q] : smoothed_offset_[q];
  };
  int32_t candidate = lowest;
  for (int q = 0; q < kParts; ++q)
    if (q != lowest && smoothed_parts_[q] < kBandScore && smoothed_parts_[q] <= smoothed_parts_[lowest] + kOffsetBand &&
        weighed(q) > weighed(candidate))
      candidate = q;
  if (!(smoothed_parts_[lowest] < calibration_.good_score || smoothed_total_ < calibration_.good_score))
    candidate = -1;
  if (candidate != candidate_) {
    candidate_ = candidate;
    candidate_since_ = t;
  }
  // Hysteresis only between two answers a student has seen: with nothing shown, a part below good
  // is named at once (before 2026-12-03 it had to hold for hold_time too, and a lowest part that
  // changed faster than the hold was never named: 02_01 <- 07_01 named nothing on 317 frames while
  // a part was below 50 on 116). A named part gives way to another part, or to "none", only once
  // that has been the candidate for hold_time. 1 ns of slack: a hold of exactly k frame times
  // (frame index / rate) must not lose a frame to the rounding of t - since.
  // The hold never keeps a part that scores at or above good in this frame while the candidate
  // scores far below it (kOffsetBand under good): the student would read "fix the right leg"
  // beside a right leg at 100 and arms at 2 (the candidate is named at once). Far below: with any
  // candidate below good, parts near good traded places early and the part named most often
  // left geometry's top 2 on a shipped pair (test_part_fix.cpp).
  const double good = calibration_.good_score;
  const bool shown_fine = shown_ >= 0 && candidate_ >= 0 && candidate_ != shown_ &&
                          record_.part_scores[shown_] >= good && record_.part_scores[candidate_] < good - kOffsetBand;
  if ((shown_ < 0 && candidate_ >= 0) || shown_fine)
    shown_ = candidate_;
  else if (candidate_ != shown_ && t - candidate_since_ >= feedback_.hold_time - 1e-9)
    shown_ = candidate_;
  update_cue(t);
}

void Scorer::clear_cue() {
  cue_shown_ = cue_candidate_ = -1;
  record_.cue_joint = -1;
  record_.cue_degrees = 0.0f;
  record_.cue_action = -1;
}

void Scorer::update_cue(double t) {
  if (shown_ < 0) {
    clear_cue();
    return;
  }
  // The candidate: the joint of the shown part's bone with the largest averaged angle at its
  // joint (cue.hpp). The same averages and the same hysteresis as the part: named at once when
  // the part changes (a new part, a new cue), and within a part another joint replaces the shown
  // one only after it has been the candidate for hold_time. Why a hold and not a margin: in a
  // part two joints are often wrong together (a turned hip also sets the knee's offset), and a
  // margin would have to be chosen per joint; the hold is the time a student needs to read a cue,
  // the reason the part holds too.
  int best = -1;
  for (int c = 1; c < gpd::kJoints; ++c)
    if (joint_part(c) == shown_ && (best < 0 || smoothed_cue_[c] > smoothed_cue_[best])) best = c;
  const int32_t candidate = cue_joint(best);
  if (candidate != cue_candidate_) {
    cue_candidate_ = candidate;
    cue_candidate_since_ = t;
  }
  if (cue_shown_ < 0 || joint_part(cue_shown_) != shown_)
    cue_shown_ = candidate;
  else if (candidate != cue_shown_ && t - cue_candidate_since_ >= feedback_.hold_time - 1e-9)
    cue_shown_ = candidate;
  // The degrees and action: the shown joint's bone with the largest averaged angle (the shoulder
  // and hip each move two bones), averaged like the part scores.
  int bone = -1;
  for (int c = 1; c < gpd::kJoints; ++c)
    if (cue_joint(c) == cue_shown_ && (bone < 0 || smoothed_cue_[c] > smoothed_cue_[bone])) bone = c;
  if (bone < 0) {  // not reached: every part has bones, every cue joint a bone
    clear_cue();
    return;
  }
  record_.cue_joint = cue_shown_;
  record_.cue_degrees = static_cast<float>(smoothed_cue_[bone]);
  record_.cue_action = static_cast<int32_t>(cue_action(bone, smoothed_cue_[bone], smoothed_change_[bone]));
}

}  // namespace kata::metric
