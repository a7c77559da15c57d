// The calibrated score, per-part scores, the part to fix with its hysteresis and the feedback
// states, through the C++ Scorer (the C ABI: tests/api/test_feedback_capi.cpp). Values are checked against the
// documented map 100 / (1 + (d / d50)^slope) evaluated here from the record's own distances.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstddef>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "common/error.hpp"
#include "fixtures.hpp"
#include "metric/pose_error.hpp"
#include "io/model_file.hpp"
#include "metric/model.hpp"
#include "metric/parts.hpp"
#include "metric/scorer.hpp"

namespace kata {
namespace {

using metric::kParts;

double documented_map(double d, double d50, double slope) { return 100.0 / (1.0 + std::pow(d / d50, slope)); }

metric::ScoreCalibration a_calibration() {
  metric::ScoreCalibration c;
  c.d50 = 0.05;
  c.slope = 3.5;
  c.part_d50 = {0.011, 0.022, 0.021, 0.016, 0.015};
  c.part_slope = {2.5, 3.0, 4.0, 5.0, 6.0};
  c.good_score = 70.0;
  c.method = "test";
  return c;
}

TEST(Calibration, RoundTripAndDocumentedDefault) {
  metric::Model with = test::test_model();
  with.calibration = a_calibration();
  const std::vector<uint8_t> buf = metric::serialize_model(with);
  const metric::Model back = metric::parse_model(buf.data(), buf.size());
  ASSERT_TRUE(back.calibration.has_value());
  EXPECT_EQ(back.calibration->d50, 0.05);
  EXPECT_EQ(back.calibration->slope, 3.5);
  EXPECT_EQ(back.calibration->part_d50, with.calibration->part_d50);
  EXPECT_EQ(back.calibration->part_slope, with.calibration->part_slope);
  EXPECT_EQ(back.calibration->good_score, 70.0);
  EXPECT_EQ(back.calibration->method, "test");
  EXPECT_EQ(metric::Metric(back).calibration().d50, 0.05);

  // A file written without a calibration (every model made before calibrations) loads with the default:
  // d50 = delta*, slope 2 for the total and every part, good score 75.
  const metric::Model& without = test::test_model();
  ASSERT_FALSE(without.calibration.has_value());
  const std::vector<uint8_t> old = metric::serialize_model(without);
  const metric::Metric m(metric::parse_model(old.data(), old.size()));
  EXPECT_EQ(m.calibration().d50, without.delta_star);
  EXPECT_EQ(m.calibration().slope, 2.0);
  for (int q = 0; q < kParts; ++q) {
    EXPECT_EQ(m.calibration().part_d50[q], without.delta_star);
    EXPECT_EQ(m.calibration().part_slope[q], 2.0);
  }
  EXPECT_EQ(m.calibration().good_score, 75.0);
  // The checksum covers the calibration: a changed d50 in the stored bytes is refused.
  std::vector<uint8_t> flipped = buf;
  const double d50 = 0.05;
  bool changed = false;
  for (size_t i = 0; i + sizeof d50 <= flipped.size() && !changed; ++i)
    if (std::memcmp(flipped.data() + i, &d50, sizeof d50) == 0) {
      const double other = 0.07;
      std::memcpy(flipped.data() + i, &other, sizeof other);
      changed = true;
    }
  ASSERT_TRUE(changed);
  EXPECT_THROW((void)metric::parse_model(flipped.data(), flipped.size()), Error);
}

TEST(Calibration, BadValuesAreRefused) {
  metric::Model m = test::test_model();
  for (int field = 0; field < 4; ++field) {
    metric::ScoreCalibration c = a_calibration();
    if (field == 0) c.d50 = 0.0;
    if (field == 1) c.slope = std::nan("");
    if (field == 2) c.part_d50[3] = -1.0;
    if (field == 3) c.good_score = 101.0;
    m.calibration = c;
    EXPECT_THROW((void)metric::serialize_model(m), Error) << field;
  }
}

TEST(Calibration, ScoresFollowTheMapAndAnOverride) {
  metric::Model model = test::test_model();
  model.calibration = a_calibration();
  const auto m = std::make_shared<const metric::Metric>(model);
  metric::Scorer scorer(std::make_shared<const metric::Reference>(m, test::clip_row("02_01.bvh", 40)));
  const float* x = test::clip_row("02_01.bvh", 160);
  metric::ScoreRecord r = scorer.score(x, 0.0);
  EXPECT_NEAR(r.model_score, documented_map(r.distance, 0.05, 3.5), 1e-3);
  // The part scores are the joint-angle map (pose_error.hpp), the same for every part and every
  // calibration; the stored part maps are no longer read.
  for (int q = 0; q < kParts; ++q) {
    EXPECT_GT(r.part_distance[q], 0.0f);
    EXPECT_NEAR(r.part_scores[q], documented_map(r.part_degrees[q], metric::kAngle50, metric::kAngleSlope), 1e-3);
  }
  // A teacher's own calibration: twice the d50 raises the score as the map says.
  metric::ScoreCalibration mine = a_calibration();
  mine.d50 = 0.1;
  mine.part_d50 = {0.2, 0.2, 0.2, 0.2, 0.2};
  scorer.set_calibration(mine);
  const metric::ScoreRecord r2 = scorer.score(x, 1.0);
  EXPECT_EQ(r2.distance, r.distance);
  EXPECT_NEAR(r2.model_score, documented_map(r.distance, 0.1, 3.5), 1e-3);
  EXPECT_GT(r2.model_score, r.model_score);
  for (int q = 0; q < kParts; ++q) EXPECT_EQ(r2.part_scores[q], r.part_scores[q]);
  mine.slope = 0.0;
  EXPECT_THROW(scorer.set_calibration(mine), Error);
}

TEST(Calibration, MapIsMonotoneAndBounded) {
  double prev = 101.0;
  for (double d = 0.0; d < 10.0; d += 0.001) {
    const double s = metric::calibrated_score(d, 0.05, 6.0);
    EXPECT_LE(s, prev);
    EXPECT_GE(s, 0.0);
    prev = s;
  }
  EXPECT_EQ(metric::calibrated_score(0.0, 0.05, 6.0), 100.0);
  EXPECT_DOUBLE_EQ(metric::calibrated_score(0.05, 0.05, 6.0), 50.0);
  EXPECT_EQ(metric::calibrated_score(1e300, 1e-300, 6.0), 0.0);  // overflow: 0, never NaN
}

TEST(Feedback, IdenticalPoseScoresHundredOnEveryPartAndNamesNoPart) {
  const auto m = test::test_metric();
  const float* x = test::clip_row("05_02.bvh", 300);
  metric::Scorer scorer(std::make_shared<const metric::Reference>(m, x));
  for (int f = 0; f < 240; ++f) {
    const metric::ScoreRecord& r = scorer.score(x, f / 120.0);
    EXPECT_EQ(r.score, 100.0f);
    for (int q = 0; q < kParts; ++q) EXPECT_EQ(r.part_scores[q], 100.0f);
    EXPECT_EQ(r.part_to_fix, -1);
  }
}

// The ranking of the part to fix (scorer.cpp update_part_to_fix), from averaged part scores and
// offsets: the lowest averaged part (equal ones by the larger offset), unless a part below
// kBandScore whose averaged score is within kOffsetBand points of it has a larger averaged offset
// (the torso's weighed kTorsoOffsetWeight times while its averaged score is below `good`).
int ranked_part(const std::vector<double>& average, const std::vector<double>& offset, double good) {
  int lowest = 0;
  for (int q = 1; q < kParts; ++q)
    if (average[q] < average[lowest] || (average[q] == average[lowest] && offset[q] > offset[lowest])) lowest = q;
  const int torso = static_cast<int>(metric::Part::kTorsoHead);
  const auto weighed = [&](int q) {
    return q == torso && average[q] < good ? metric::kTorsoOffsetWeight * offset[q] : offset[q];
  };
  int best = lowest;
  for (int q = 0; q < kParts; ++q)
    if (q != lowest && average[q] < metric::kBandScore && average[q] <= average[lowest] + metric::kOffsetBand &&
        weighed(q) > weighed(best))
      best = q;
  return best;
}

// Another subject's walk against a teacher pose, with good_score 100 so a part is always
// proposed: the part shown changes only to a part that has been the lowest of the averaged part
// scores for hold_time, and follows a part that stays lowest that long. The average is recomputed
// here from the records' own part scores (the documented exponential average, time constant
// smoothing_time); with smoothing_time 0 it is the frame's own lowest part.
void check_part_to_fix_holds(double smoothing_time) {
  metric::Model model = test::test_model();
  metric::ScoreCalibration c = metric::default_calibration(model.delta_star);
  c.good_score = 100.0;
  model.calibration = c;
  const auto m = std::make_shared<const metric::Metric>(model);
  metric::FeedbackOptions fb;
  fb.hold_time = 0.1;
  fb.calibrating_time = 0.0;
  fb.smoothing_time = smoothing_time;
  metric::Scorer scorer(std::make_shared<const metric::Reference>(m, test::clip_row("02_01.bvh", 100)), {}, fb);
  const double dt = 1.0 / 120;
  std::vector<int> lowest;
  std::vector<double> average(kParts, 0.0), offset(kParts, 0.0);
  int shown = -1, changes = 0, lowest_changes = 0;
  double weight = 0.0;
  for (int f = 0; f < test::clip_frames("07_01.bvh"); ++f) {
    const metric::ScoreRecord& r = scorer.score(test::clip_row("07_01.bvh", f), f * dt);
    // The documented average: exponential, normalised by the weights summed since the start.
    const double keep = f == 0 || smoothing_time == 0.0 ? 0.0 : std::exp(-dt / smoothing_time);
    weight = 1.0 + keep * weight;
    for (int q = 0; q < kParts; ++q) {
      average[q] += (r.part_scores[q] - average[q]) / weight;
      offset[q] += (r.part_offset[q] - offset[q]) / weight;
    }
    const int low = ranked_part(average, offset, c.good_score);
    lowest_changes += !lowest.empty() && lowest.back() != low;
    lowest.push_back(low);
    const int hold_frames = static_cast<int>(std::ceil(fb.hold_time / dt - 1e-9));
    if (r.part_to_fix != shown && shown < 0) {
      // Nothing shown: a candidate is named at once (scorer.cpp update_part_to_fix).
      ++changes;
      shown = r.part_to_fix;
    } else if (r.part_to_fix != shown) {
      ++changes;
      ASSERT_GE(f, hold_frames) << "changed before any candidate could hold";
      for (int g = f - hold_frames; g <= f; ++g) ASSERT_EQ(lowest[g], r.part_to_fix) << "frame " << f;
      shown = r.part_to_fix;
    }
    if (f >= hold_frames) {
      bool stable = true;
      for (int g = f - hold_frames; g <= f; ++g) stable = stable && lowest[g] == low;
      if (stable) {
        EXPECT_EQ(r.part_to_fix, low) << "frame " << f;
      }
    }
  }
  EXPECT_GE(changes, 1);
  std::printf("smoothing %.2f s: the lowest averaged part changed %d times, the cue %d times\n", smoothing_time,
              lowest_changes, changes);
}

TEST(Feedback, PartToFixChangesOnlyAfterTheHoldTime) { check_part_to_fix_holds(0.0); }
TEST(Feedback, PartToFixFollowsTheAveragedPartScores) { check_part_to_fix_holds(0.5); }

// The gate: the lowest averaged part is named while it, or the total averaged the same way, is
// below good_score. The candidate of each frame is recomputed here from the records' own scores;
// wherever it has held for hold_time the cue must name it. Run at several good_scores so that
// frames gated by the part alone, by the total alone, and by neither all occur; with two models:
// the shipped one (its calibration gives each part its own map: on this pair the parts score
// below the total) and the test model (one map for all: the total below the parts).
TEST(Feedback, APartIsNamedWhileItOrTheTotalIsBelowGood) {
  int by_part_only = 0, by_total_only = 0, by_neither = 0;
  for (bool shipped : {true, false}) {
    metric::Model model =
        shipped ? metric::load_model(std::string(KATA_SOURCE_DIR) +
                                     "/models/default.kata")
                : test::test_model();
    metric::ScoreCalibration c =
        model.calibration ? *model.calibration
                          : metric::default_calibration(model.delta_star);
    const float *reference_row = test::clip_row("02_01.bvh", 100);
    metric::FeedbackOptions fb;
    fb.calibrating_time = 0.0;
    const double dt = 1.0 / 120;
    const int frames = test::clip_frames("07_01.bvh");
    const int hold_frames =
        static_cast<int>(std::ceil(fb.hold_time / dt - 1e-9));
    for (double good : {0.0, 10.0, 20.0, 30.0, 50.0, 75.0}) {
      c.good_score = good;
      model.calibration = c;
      metric::Scorer scorer(
          std::make_shared<const metric::Reference>(
              std::make_shared<const metric::Metric>(model), reference_row),
          {}, fb);
      std::vector<double> average(kParts + 1, 0.0); // the parts, then the total
      std::vector<double> offset(kParts, 0.0);       // the parts' offsets (equal scores' ranking)
      std::vector<int> candidate;
      double weight = 0.0;
      for (int f = 0; f < frames; ++f) {
        const metric::ScoreRecord &r =
            scorer.score(test::clip_row("07_01.bvh", f), f * dt);
        // Exponential, normalised by the weights summed since the start (scorer.hpp).
        const double keep = f == 0 ? 0.0 : std::exp(-dt / fb.smoothing_time);
        weight = 1.0 + keep * weight;
        for (int q = 0; q <= kParts; ++q)
          average[q] += ((q < kParts ? r.part_scores[q] : r.score) - average[q]) / weight;
        for (int q = 0; q < kParts; ++q)
          offset[q] += (r.part_offset[q] - offset[q]) / weight;
        int lowest = 0;  // the gate reads the lowest averaged part
        for (int q = 1; q < kParts; ++q)
          if (average[q] < average[lowest]) lowest = q;
        const bool part_poor = average[lowest] < good,
                   total_poor = average[kParts] < good;
        const int low = ranked_part(average, offset, good);
        by_part_only += part_poor && !total_poor;
        by_total_only += total_poor && !part_poor;
        by_neither += !part_poor && !total_poor;
        candidate.push_back(part_poor || total_poor ? low : -1);
        bool held = f >= hold_frames;
        for (int g = f - hold_frames; held && g <= f; ++g)
          held = candidate[static_cast<size_t>(g)] == candidate.back();
        if (held) {
          EXPECT_EQ(r.part_to_fix, candidate.back())
              << "frame " << f << ", good_score " << good;
        }
        if (good == 0.0) {
          EXPECT_EQ(r.part_to_fix, -1) << "frame " << f;
        }
      }
    }
  }
  std::printf("frames gated by the part alone %d, by the total alone %d, by "
              "neither %d\n",
              by_part_only, by_total_only, by_neither);
  // The total is at most the worst part (scorer.hpp), so its average is at most the lowest part's
  // average: a part below good always has the total below good too.
  EXPECT_EQ(by_part_only, 0);
  EXPECT_GT(by_total_only, 0);
  EXPECT_GT(by_neither, 0);
}

// The hold never keeps a part that scores at or above good in a frame while the candidate scores
// far below good there (kOffsetBand under it; a student read "fix the right leg" beside a right
// leg at 100 and arms at 2 for 0.2 s): the candidate, recomputed here from the records as above,
// is named at once then. Whole
// clips followed by the alignment with the shipped model; the frames where the hold would have
// kept such a part are counted, so the case is known to occur.
TEST(Feedback, TheHoldNeverKeepsAPartAboveGoodWhileTheCandidateIsBelow) {
  const metric::Model model = metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata");
  const double good = model.calibration->good_score;
  const auto m = std::make_shared<const metric::Metric>(model);
  metric::FeedbackOptions fb;
  fb.calibrating_time = 0.0;
  const double dt = 1.0 / 120;
  const int hold_frames = static_cast<int>(std::ceil(fb.hold_time / dt - 1e-9));
  int released = 0, checked = 0;
  for (const auto& [teacher, student] : {std::pair{"02_01.bvh", "07_01.bvh"}, std::pair{"07_01.bvh", "02_01.bvh"},
                                         std::pair{"05_02.bvh", "09_01.bvh"}, std::pair{"09_01.bvh", "05_02.bvh"}}) {
    metric::Scorer scorer(std::make_shared<const metric::Reference>(m, test::clip_rows(teacher).data(),
                                                                    test::clip_frames(teacher), dt),
                          {}, fb);
    std::vector<double> average(kParts + 1, 0.0), offset(kParts, 0.0);
    std::vector<int> candidate;
    double weight = 0.0;
    int shown = -1;
    for (int f = 0; f < test::clip_frames(student); ++f) {
      const metric::ScoreRecord& r = scorer.score(test::clip_row(student, f), f * dt);
      if (r.state != metric::ScoreState::kScoring) break;
      const double keep = f == 0 ? 0.0 : std::exp(-dt / fb.smoothing_time);
      weight = 1.0 + keep * weight;
      for (int q = 0; q <= kParts; ++q) average[q] += ((q < kParts ? r.part_scores[q] : r.score) - average[q]) / weight;
      for (int q = 0; q < kParts; ++q) offset[q] += (r.part_offset[q] - offset[q]) / weight;
      int lowest = 0;
      for (int q = 1; q < kParts; ++q)
        if (average[q] < average[lowest]) lowest = q;
      const int c = average[lowest] < good || average[kParts] < good ? ranked_part(average, offset, good) : -1;
      candidate.push_back(c);
      const int p = r.part_to_fix;
      ++checked;
      EXPECT_FALSE(p >= 0 && c >= 0 && c != p && r.part_scores[p] >= good &&
                   r.part_scores[c] < good - metric::kOffsetBand)
          << student << " vs " << teacher << " frame " << f << ": " << metric::part_name(p) << " at "
          << r.part_scores[p] << " named while the candidate " << metric::part_name(c) << " scores "
          << r.part_scores[c];
      // Changed to a candidate that had not held for hold_time: the release above.
      if (shown >= 0 && p != shown && p == c) {
        bool held = f >= hold_frames;
        for (int g = f - hold_frames; held && g <= f; ++g) held = candidate[static_cast<size_t>(g)] == c;
        released += !held;
      }
      shown = p;
    }
  }
  std::printf("%d scoring frames checked, the hold released early on %d\n", checked, released);
  EXPECT_GT(checked, 500);
  EXPECT_GT(released, 0) << "no frame where the hold kept a part above good: the test cannot fail";
}

TEST(Feedback, CalibratingThenScoringThenTeacherFinished) {
  const auto m = test::test_metric();
  const std::string name = "07_01.bvh";
  const int frames = test::clip_frames(name);
  const auto ref = std::make_shared<const metric::Reference>(m, test::clip_row(name, 0), frames, 1.0 / 120);
  metric::Scorer scorer(ref);  // defaults: calibrating 0.25 s, finished 0.25 s after the end
  const int extra = 120;       // the student keeps holding the last pose for one more second
  int calibrating = 0, scoring = 0, finished = 0;
  for (int f = 0; f < frames + extra; ++f) {
    const double t = f / 120.0;
    const metric::ScoreRecord& r = scorer.score(test::clip_row(name, std::min(f, frames - 1)), t);
    if (t < 0.25 - 1e-9) {
      EXPECT_EQ(r.state, metric::ScoreState::kCalibrating) << f;
      ++calibrating;
    } else if (f < frames - 1) {
      EXPECT_EQ(r.state, metric::ScoreState::kScoring) << f;
      ++scoring;
    } else if (f >= frames - 1 + 30) {
      EXPECT_EQ(r.state, metric::ScoreState::kTeacherFinished) << f;
      EXPECT_EQ(r.part_to_fix, -1);
      ++finished;
    }
  }
  EXPECT_EQ(calibrating, 30);
  EXPECT_GT(scoring, 200);
  EXPECT_EQ(finished, extra - 30 + 1);
  scorer.reset();
  EXPECT_EQ(scorer.score(test::clip_row(name, 0), 100.0).state, metric::ScoreState::kCalibrating);
}

TEST(Feedback, TrackingLostNeedsThirteenJoints) {
  std::vector<float> joints(3 * gpd::kJoints);
  for (size_t i = 0; i < joints.size(); ++i) joints[i] = 0.1f + static_cast<float>(i);
  EXPECT_FALSE(metric::tracking_lost(joints.data()));
  for (int j = 0; j < 3; ++j) joints[3 * j] = joints[3 * j + 1] = joints[3 * j + 2] = 0.0f;
  EXPECT_FALSE(metric::tracking_lost(joints.data()));  // 13 tracked
  joints[3 * 5 + 1] = std::nanf("");
  EXPECT_TRUE(metric::tracking_lost(joints.data()));  // 12 tracked
}

}  // namespace
}  // namespace kata
