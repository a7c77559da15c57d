// The lesson's tolerance (metric/pose_error.hpp Tolerance, docs/model/tolerance.md): the levels and
// numbers a setting accepts, the part map each gives (checked against 100 / (1 + (a / a50)^slope)
// evaluated here from the record's own angles), the normal level's records unchanged, and what each
// level promises a coach on a real clip with one joint turned (each student frame matched to its
// own teacher frame): strict scores a 30-degree error at one joint <= 50, normal a 45-degree one,
// lenient lets a 45-degree one through (> 50).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "fixtures.hpp"
#include "io/model_file.hpp"
#include "metric/pose_error.hpp"
#include "metric/scorer.hpp"

namespace kata {
namespace {

double documented_map(double a, double a50, double slope) { return 100.0 / (1.0 + std::pow(a / a50, slope)); }

TEST(Tolerance, LevelsAndDegreesParseAndAnythingElseIsRefusedByName) {
  const metric::Tolerance normal = metric::parse_tolerance("normal");
  EXPECT_EQ(normal.angle50, 40.0);
  EXPECT_EQ(normal.slope, 5.0);
  EXPECT_EQ(metric::parse_tolerance("strict").angle50, 25.0);
  EXPECT_EQ(metric::parse_tolerance("strict").slope, 5.0);
  EXPECT_EQ(metric::parse_tolerance("lenient").angle50, 58.0);
  EXPECT_EQ(metric::parse_tolerance("lenient").slope, 5.0);
  EXPECT_EQ(metric::parse_tolerance("35").angle50, 35.0);
  EXPECT_EQ(metric::parse_tolerance("37.5").angle50, 37.5);
  EXPECT_EQ(metric::parse_tolerance("37.5").slope, 5.0);
  EXPECT_EQ(metric::parse_tolerance("5").angle50, 5.0);
  EXPECT_EQ(metric::parse_tolerance("120").angle50, 120.0);
  for (const char* bad : {"", "Normal", "loose", "4.99", "121", "nan", "inf", "35deg", " 35", "35 ", "-40", "1e3"}) {
    try {
      (void)metric::parse_tolerance(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::kInvalidArgument);
      const std::string m = e.what();
      EXPECT_NE(m.find(std::string("\"") + bad + "\""), std::string::npos) << m;
      EXPECT_NE(m.find("strict, normal, lenient"), std::string::npos) << m;
    }
  }
  EXPECT_THROW((void)metric::parse_tolerance(nullptr), Error);
}

TEST(Tolerance, PartScoresFollowTheLevelsMapAndNormalIsTheDefault) {
  const auto metric = std::make_shared<const metric::Metric>(
      metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  const BvhClip teacher = load_bvh(test::cmu("02_01.bvh")), student = load_bvh(test::cmu("07_01.bvh"));
  const GpdMap tm = make_gpd_map(teacher.skeleton, preset_joint_names("cmu"));
  const GpdMap sm = make_gpd_map(student.skeleton, preset_joint_names("cmu"));
  const std::vector<float> t = clip_features(teacher, tm, gpd::Stencil::kBackward, 1);
  const std::vector<float> s = clip_features(student, sm, gpd::Stencil::kBackward, 1);
  const auto ref = std::make_shared<const metric::Reference>(metric, t.data(), static_cast<int>(t.size() / gpd::kDims),
                                                             teacher.frame_time);
  metric::Scorer plain(ref), normal(ref), lenient(ref), degrees(ref);
  normal.set_tolerance(metric::parse_tolerance("normal"));
  lenient.set_tolerance(metric::parse_tolerance("lenient"));
  degrees.set_tolerance(metric::parse_tolerance("33"));
  const int frames = std::min(200, static_cast<int>(s.size() / gpd::kDims));
  double sum_normal = 0.0, sum_lenient = 0.0;
  for (int f = 0; f < frames; ++f) {
    const float* x = s.data() + static_cast<size_t>(f) * gpd::kDims;
    const double time = f * student.frame_time;
    const metric::ScoreRecord a = plain.score(x, time), b = normal.score(x, time), c = lenient.score(x, time),
                              d = degrees.score(x, time);
    // The normal level is today's scorer, record for record.
    EXPECT_EQ(a.score, b.score);
    EXPECT_EQ(a.part_to_fix, b.part_to_fix);
    EXPECT_EQ(a.cue_joint, b.cue_joint);
    // The map reads the same angles and matched frame at every level (the alignment does not read it).
    EXPECT_EQ(c.matched, a.matched);
    double worst_c = 100.0, worst_d = 100.0;
    for (int q = 0; q < metric::kParts; ++q) {
      EXPECT_EQ(c.part_degrees[q], a.part_degrees[q]);
      EXPECT_NEAR(a.part_scores[q], documented_map(a.part_degrees[q], 40.0, 5.0), 1e-3);
      EXPECT_NEAR(c.part_scores[q], documented_map(c.part_degrees[q], 58.0, 5.0), 1e-3);
      EXPECT_NEAR(d.part_scores[q], documented_map(d.part_degrees[q], 33.0, 5.0), 1e-3);
      worst_c = std::min(worst_c, documented_map(c.part_degrees[q], 58.0, 5.0));
      worst_d = std::min(worst_d, documented_map(d.part_degrees[q], 33.0, 5.0));
    }
    // The gate (the model's map of the distance) is the same at every level.
    EXPECT_EQ(c.model_score, a.model_score);
    EXPECT_NEAR(c.score, std::min<double>(c.model_score, worst_c), 1e-3);
    EXPECT_NEAR(d.score, std::min<double>(d.model_score, worst_d), 1e-3);
    if (a.state == metric::ScoreState::kScoring) sum_normal += a.score, sum_lenient += c.score;
  }
  EXPECT_GT(sum_lenient, sum_normal);  // another subject's walk: lenient forgives more of it
}

// A knee and an elbow turned on every frame of 2 s of a walk, each frame scored against its own
// teacher frame: the mean total against what each level promises.
TEST(Tolerance, EachLevelCatchesWhatItPromises) {
  const auto metric = std::make_shared<const metric::Metric>(
      metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  BvhClip clip = load_bvh(test::cmu("02_01.bvh"));
  clip.motion.resize(static_cast<size_t>(std::min(clip.frame_count(), 241)) * clip.channel_count);
  const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
  const std::vector<float> t = clip_features(clip, map, gpd::Stencil::kBackward, 1);
  const int frames = static_cast<int>(t.size() / gpd::kDims);
  const auto ref = std::make_shared<const metric::Reference>(metric, t.data(), frames, clip.frame_time);
  auto mean_total = [&](const char* joint, Channel axis, double deg, const char* level) {
    BvhClip s = clip;
    const int j = clip.skeleton.find(joint);
    const auto& ch = clip.channels[static_cast<size_t>(j)];
    const size_t c = static_cast<size_t>(clip.channel_offset[static_cast<size_t>(j)]) +
                     static_cast<size_t>(std::find(ch.begin(), ch.end(), axis) - ch.begin());
    for (int f = 1; f < s.frame_count(); ++f) s.motion[static_cast<size_t>(f) * s.channel_count + c] += deg;
    const std::vector<float> x = clip_features(s, map, gpd::Stencil::kBackward, 1);
    metric::Scorer scorer(ref);
    scorer.set_tolerance(metric::parse_tolerance(level));
    double sum = 0.0;
    for (int f = 0; f < frames; ++f)
      sum += scorer.score_matched(x.data() + static_cast<size_t>(f) * gpd::kDims, f * clip.frame_time, f).score;
    return sum / frames;
  };
  for (auto [joint, axis] : {std::make_pair("LeftLeg", Channel::kXrot), std::make_pair("RightForeArm", Channel::kYrot)}) {
    const double strict30 = mean_total(joint, axis, 30, "strict"), normal30 = mean_total(joint, axis, 30, "normal");
    const double normal45 = mean_total(joint, axis, 45, "normal"), lenient45 = mean_total(joint, axis, 45, "lenient");
    const double at45 = mean_total(joint, axis, 45, "45");
    std::printf("[ figures ] %s: 30 deg strict %.1f normal %.1f; 45 deg normal %.1f lenient %.1f, tolerance 45: %.1f\n",
                joint, strict30, normal30, normal45, lenient45, at45);
    EXPECT_LE(strict30, 50.0) << joint;
    EXPECT_GT(normal30, 50.0) << joint;
    EXPECT_LE(normal45, 50.0) << joint;
    EXPECT_GT(lenient45, 50.0) << joint;
    // A number is the angle that scores 50: a 45-degree error (28-45 degrees at the bone, below the
    // axis' cos) scores about 50 or more with tolerance 45.
    EXPECT_GT(at45, normal45) << joint;
  }
}

}  // namespace
}  // namespace kata
