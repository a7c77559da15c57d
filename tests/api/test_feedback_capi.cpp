// The C ABI's score calibration and feedback (kata.h "Score calibration and feedback"), through
// libkata only: the shipped coaching model's stored map, a per-stream override, the documented
// default of a model file without a calibration, and the tracking-lost state on zeroed frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstddef>
#include <string>
#include <vector>

#include "kata/kata.h"
#include "support/capi_teacher.hpp"

namespace kata {
namespace {

double documented_map(double d, double d50, double slope) { return 100.0 / (1.0 + std::pow(d / d50, slope)); }
// The coaching total of a record (kata.h "Score calibration and feedback"): the model's map of d,
// capped by the worst part score.
double coaching_total(const kata_result_record& r, double d50, double slope) {
  double t = documented_map(r.distance, d50, slope);
  for (int q = 0; q < KATA_PART_COUNT; ++q) t = std::min(t, static_cast<double>(r.part_scores[q]));
  return t;
}

// A model file written before calibrations existed (the stand-in models are) reads as the
// default: d50 = delta*, slope 2 for the total and every part, good score 75.
TEST(FeedbackCApi, ModelWithoutCalibrationReadsTheDefault) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, KATA_TEST_MODELS_DIR "/random-r50-s7.kata", &m), KATA_OK) << kata_context_last_error(ctx);
  kata_score_calibration cal{};
  cal.struct_size = sizeof cal;
  ASSERT_EQ(kata_model_calibration(m, &cal), KATA_OK);
  EXPECT_EQ(cal.d50, kata_model_delta_star(m));
  EXPECT_EQ(cal.slope, 2.0);
  for (int q = 0; q < KATA_PART_COUNT; ++q) {
    EXPECT_EQ(cal.part_d50[q], kata_model_delta_star(m));
    EXPECT_EQ(cal.part_slope[q], 2.0);
  }
  EXPECT_EQ(cal.good_score, 75.0);
  cal.struct_size = 8;
  EXPECT_EQ(kata_model_calibration(m, &cal), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_model_calibration(nullptr, &cal), KATA_E_NULL_POINTER);
  kata_model_destroy(m);
  kata_context_destroy(ctx);
}

// Through the C ABI: a clip with frames zeroed out is reported as tracking lost, the record
// carries the part scores, and a stream calibration override changes the score as documented.
TEST(FeedbackCApi, StatesPartScoresAndOverride) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  const std::string path = std::string(KATA_SOURCE_DIR) + "/models/default.kata";  // stores a calibration
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_02.bvh", &clip), KATA_OK);
  ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, path.c_str(), &m), KATA_OK) << kata_context_last_error(ctx);
  kata_score_calibration cal{};
  cal.struct_size = sizeof cal;
  ASSERT_EQ(kata_model_calibration(m, &cal), KATA_OK);
  EXPECT_GT(cal.d50, 0.0);
  EXPECT_NE(cal.d50, kata_model_delta_star(m));  // not the default map
  EXPECT_GT(cal.good_score, 0.0);
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &d, &s), KATA_OK);
  EXPECT_EQ(kata_stream_set_calibration(s, &cal), KATA_E_STATE);
  ASSERT_EQ(kata::test::attach_clip(s, m, clip, 1, 60), KATA_OK) << kata_stream_last_error(s);
  const int n = static_cast<int>(kata_skeleton_joint_count(skel));
  std::vector<float> p(3 * static_cast<size_t>(n));
  kata_result_record r{};
  r.struct_size = sizeof r;
  int lost = 0, cued = 0;
  for (uint32_t f = 1; f < 200; ++f) {
    ASSERT_EQ(kata_clip_positions(clip, f, p.data(), p.size()), KATA_OK);
    const bool zeroed = f >= 100 && f < 110;
    if (zeroed) std::fill(p.begin(), p.end(), 0.0f);
    ASSERT_EQ(kata_stream_push(s, f / 120.0, p.data(), static_cast<uint32_t>(n)), KATA_OK) << kata_stream_last_error(s);
    if (kata::test::read_newest(s, &r) != KATA_OK) continue;
    // The correction cue (kata.h): present iff a part is named, one of that part's joints (the
    // GPD joint -> part grouping of kata_body_part), an action, finite degrees and a phrase.
    EXPECT_EQ(r.cue_joint >= 0, r.part_to_fix >= 0) << f;
    if (r.cue_joint >= 0) {
      static const int kJointPart[16] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4};
      ASSERT_LT(r.cue_joint, 16) << f;
      EXPECT_EQ(kJointPart[r.cue_joint], r.part_to_fix) << f;
      EXPECT_TRUE(r.cue_degrees >= 0.0f && r.cue_degrees <= 180.0f) << f;
      EXPECT_TRUE(r.cue_action >= KATA_CUE_BEND && r.cue_action <= KATA_CUE_TURN) << f;
      char text[64];
      EXPECT_GT(kata_cue_text(&r, text, sizeof text), 0u) << f;
      EXPECT_NE(std::string(text).find(": "), std::string::npos) << text;
      ++cued;
    } else {
      EXPECT_EQ(r.cue_action, KATA_CUE_NONE) << f;
      EXPECT_EQ(r.cue_degrees, 0.0f) << f;
    }
    if (zeroed) {
      EXPECT_EQ(r.state, KATA_SCORE_TRACKING_LOST) << f;
      EXPECT_EQ(r.part_to_fix, -1);
      EXPECT_EQ(r.score, 0.0f);
      ++lost;
    } else if (f > 40 && f < 100) {
      EXPECT_EQ(r.state, KATA_SCORE_SCORING) << f;
      // The coaching total (kata.h): min(the model's map of d, the worst part score).
      EXPECT_NEAR(r.score, coaching_total(r, cal.d50, cal.slope), 1e-3);
      for (int q = 0; q < KATA_PART_COUNT; ++q) EXPECT_TRUE(r.part_scores[q] >= 0.0f && r.part_scores[q] <= 100.0f);
    }
  }
  EXPECT_EQ(lost, 10);
  std::printf("frames with a cue: %d\n", cued);
  // Override: d50 four times larger, slope 1.
  kata_score_calibration mine = cal;
  mine.d50 = 4.0 * cal.d50;
  mine.slope = 1.0;
  ASSERT_EQ(kata_stream_set_calibration(s, &mine), KATA_OK) << kata_stream_last_error(s);
  ASSERT_EQ(kata_clip_positions(clip, 200, p.data(), p.size()), KATA_OK);
  ASSERT_EQ(kata_stream_push(s, 200 / 120.0, p.data(), static_cast<uint32_t>(n)), KATA_OK);
  ASSERT_EQ(kata::test::read_newest(s, &r), KATA_OK);
  EXPECT_NEAR(r.score, coaching_total(r, 4.0 * cal.d50, 1.0), 1e-3);
  mine.slope = -1.0;
  EXPECT_EQ(kata_stream_set_calibration(s, &mine), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_stream_last_error(s)).find("slope"), std::string::npos) << kata_stream_last_error(s);
  ASSERT_EQ(kata_stream_set_calibration(s, nullptr), KATA_OK);  // back to the model's
  ASSERT_EQ(kata_clip_positions(clip, 201, p.data(), p.size()), KATA_OK);
  ASSERT_EQ(kata_stream_push(s, 201 / 120.0, p.data(), static_cast<uint32_t>(n)), KATA_OK);
  ASSERT_EQ(kata::test::read_newest(s, &r), KATA_OK);
  EXPECT_NEAR(r.score, coaching_total(r, cal.d50, cal.slope), 1e-3);
  // An old caller's smaller struct receives only the fields it knows.
  kata_result_record small{};
  small.struct_size = offsetof(kata_result_record, part_scores);
  small.part_to_fix = 12345;
  ASSERT_EQ(kata_clip_positions(clip, 202, p.data(), p.size()), KATA_OK);
  ASSERT_EQ(kata_stream_push(s, 202 / 120.0, p.data(), static_cast<uint32_t>(n)), KATA_OK);
  ASSERT_EQ(kata::test::read_newest(s, &small), KATA_OK);
  EXPECT_EQ(small.frame_index, r.frame_index + 1);
  EXPECT_EQ(small.part_to_fix, 12345);
  kata_stream_destroy(s);
  kata_model_destroy(m);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
}

}  // namespace
}  // namespace kata
