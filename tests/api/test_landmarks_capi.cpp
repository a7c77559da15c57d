// MediaPipe's own frame shape through the C ABI (issue 26): kata_stream_push_landmarks with five
// channels (x, y, z, visibility, presence) and millisecond timestamps gives, frame by frame, the
// features kata_stream_push_confidence gives the same frames in seconds with confidence = the
// smaller of visibility and presence; kata_time_units_detect names the units of recorded
// timestamps and refuses steps that fit neither.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "kata/kata.h"

namespace {

TEST(LandmarksCapi, FiveChannelsInMillisecondsEqualConfidenceInSeconds) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  kata_clip clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &clip), KATA_OK) << kata_context_last_error(ctx);
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  const uint32_t n = kata_skeleton_joint_count(skel);
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "cmu";
  kata_stream a = nullptr, b = nullptr;
  ASSERT_EQ(kata_stream_open(ctx, skel, &d, &a), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_stream_open(ctx, skel, &d, &b), KATA_OK);

  std::vector<float> xyz(3 * n), conf(n), five(5 * n), fa(KATA_GPD_DIMS), fb(KATA_GPD_DIMS);
  const uint32_t frames = std::min<uint32_t>(kata_clip_frame_count(clip) - 1, 200);
  int compared = 0;
  double worst = 0.0;
  for (uint32_t f = 1; f <= frames; ++f) {
    ASSERT_EQ(kata_clip_positions(clip, f, xyz.data(), xyz.size()), KATA_OK);
    for (uint32_t j = 0; j < n; ++j) {
      const float visibility = 0.6f + 0.4f * static_cast<float>((f + j) % 3) / 2.0f;
      const float presence = (f >= 100 && f < 110 && j % 2) ? 0.2f : 0.9f;  // some joints not present
      conf[j] = std::min(visibility, presence);
      for (int k = 0; k < 3; ++k) five[5 * j + k] = xyz[3 * j + k];
      five[5 * j + 3] = visibility, five[5 * j + 4] = presence;
    }
    const double t = f * kata_clip_frame_time(clip);
    const kata_status sa = kata_stream_push_confidence(a, t, xyz.data(), conf.data(), n);
    const kata_status sb = kata_stream_push_landmarks(b, 1234567.0 + 1000.0 * t - 1234567.0, KATA_TIME_MILLISECONDS,
                                                      five.data(), n, 5);
    ASSERT_EQ(sa, sb) << "frame " << f << ": " << kata_stream_last_error(b);
    double ta = 0, tb = 0;
    int64_t ia = -1, ib = -1;
    const kata_status ra = kata_stream_features(a, fa.data(), fa.size(), &ta, &ia);
    ASSERT_EQ(ra, kata_stream_features(b, fb.data(), fb.size(), &tb, &ib));
    if (ra != KATA_OK) continue;
    ASSERT_EQ(ia, ib);
    EXPECT_NEAR(ta, tb, 1e-9) << "results carry seconds";
    for (size_t i = 0; i < fa.size(); ++i) worst = std::max(worst, std::fabs(double(fa[i]) - fb[i]) / (1.0 + std::fabs(fa[i])));
    ++compared;
  }
  EXPECT_GT(compared, 150);
  EXPECT_LT(worst, 1e-4);

  // Refusals change nothing: a wrong channel count, wrong units, a wrong joint count.
  EXPECT_EQ(kata_stream_push_landmarks(b, 1e6, KATA_TIME_MILLISECONDS, five.data(), n, 6), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_stream_push_landmarks(b, 1e6, static_cast<kata_time_units>(7), five.data(), n, 5), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_stream_push_landmarks(b, 1e6, KATA_TIME_MILLISECONDS, five.data(), n - 1, 5), KATA_E_WRONG_JOINT_COUNT);
  EXPECT_EQ(kata_stream_push_landmarks(b, 1e6, KATA_TIME_MILLISECONDS, nullptr, n, 5), KATA_E_NULL_POINTER);

  kata_stream_destroy(a);
  kata_stream_destroy(b);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
}

TEST(LandmarksCapi, TimeUnitsFromTheSteps) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  std::vector<double> ms, s, neither;
  for (int i = 0; i < 50; ++i) {
    ms.push_back(987654.0 + 33.3 * i + (i % 2));  // MediaPipe at 30 Hz with jitter
    s.push_back(ms.back() * 1e-3);
    neither.push_back(0.7 * i);  // 1.4 Hz or 1400 Hz
  }
  kata_time_units u = KATA_TIME_SECONDS;
  EXPECT_EQ(kata_time_units_detect(ms.data(), ms.size(), &u), KATA_OK);
  EXPECT_EQ(u, KATA_TIME_MILLISECONDS);
  EXPECT_EQ(kata_time_units_detect(s.data(), s.size(), &u), KATA_OK);
  EXPECT_EQ(u, KATA_TIME_SECONDS);
  EXPECT_EQ(kata_time_units_detect(neither.data(), neither.size(), &u), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("ambiguous time units"), std::string::npos)
      << kata_context_last_error(ctx);
  std::reverse(s.begin(), s.end());
  EXPECT_EQ(kata_time_units_detect(s.data(), s.size(), &u), KATA_E_INVALID_ARGUMENT);
  kata_context_destroy(ctx);
}

}  // namespace
