// MediaPipe's own frame shape through the C ABI: kata_stream_push_landmarks with five
// channels (x, y, z, visibility, presence) and millisecond timestamps gives, frame by frame, the
// features kata_stream_push_confidence gives the same frames in seconds with confidence = the
// smaller of visibility and presence; kata_time_units_detect names the units of recorded
// timestamps and refuses steps that fit neither.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
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

// A NumPy .npy file of little-endian float32 ('<f4') or float64 ('<f8') values, as numpy.save
// writes version 1.0: the magic, the header length, the header dict padded with spaces to a
// multiple of 64 bytes ending in a newline, then the data.
template <class T>
void write_npy(const std::string& path, const std::vector<T>& values, const std::string& shape) {
  std::string header = std::string("{'descr': '<f") + (sizeof(T) == 4 ? "4" : "8") +
                       "', 'fortran_order': False, 'shape': (" + shape + "), }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::ofstream out(path, std::ios::binary);
  out.write("\x93NUMPY\x01\x00", 8);
  const uint16_t length = static_cast<uint16_t>(header.size());
  out.write(reinterpret_cast<const char*>(&length), 2);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  out.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(T)));
}

// kata_landmarks_load (1.1): a MediaPipe recording as `kata coach --record-teacher` writes it
// (frames x 33 x 4 float32, and X.times.npy in seconds) reads back with its positions (the first
// three channels), its frame time (the timestamps' median step) and capture times; the same times
// in milliseconds are inferred as such; a CSV of the gpd layout with a timestamp column too; no
// timing is refused, an unknown layout too.
TEST(LandmarksCapi, RecordingsReadBackWithTheirPositionsAndTiming) {
  kata_context ctx = nullptr;
  ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
  const std::string dir = ::testing::TempDir() + "kata_landmarks_capi_" + std::to_string(getpid());
  const std::string npy = dir + ".npy", times = dir + ".times.npy", csv = dir + ".csv";
  const int frames = 6, joints = 33;
  std::vector<float> values;
  for (int f = 0; f < frames; ++f)
    for (int j = 0; j < joints; ++j)
      for (int c = 0; c < 4; ++c) values.push_back(c == 3 ? 0.9f : 0.001f * static_cast<float>(f * 100 + j) + 0.1f * c);
  // Steps 30, 35, 35, 31, 34 ms: their median is 34 ms.
  const std::vector<double> seconds = {0.0, 0.030, 0.065, 0.100, 0.131, 0.165};
  write_npy(npy, values, "6, 33, 4");
  write_npy(times, seconds, "6,");
  kata_landmarks l = nullptr;
  ASSERT_EQ(kata_landmarks_load(ctx, npy.c_str(), "mediapipe", 0.0, KATA_TIME_SECONDS, &l), KATA_OK)
      << kata_context_last_error(ctx);
  EXPECT_EQ(kata_landmarks_frame_count(l), static_cast<uint32_t>(frames));
  EXPECT_EQ(kata_landmarks_joint_count(l), static_cast<uint32_t>(joints));
  EXPECT_NEAR(kata_landmarks_frame_time(l), 0.034, 1e-12);
  for (int f = 0; f < frames; ++f) EXPECT_NEAR(kata_landmarks_capture_time(l, static_cast<uint32_t>(f)), seconds[f], 1e-12) << f;
  EXPECT_EQ(kata_landmarks_capture_time(l, frames), -1.0);
  const float* xyz = kata_landmarks_positions(l);
  ASSERT_NE(xyz, nullptr);
  int wrong = 0;
  for (int f = 0; f < frames; ++f)
    for (int j = 0; j < joints; ++j)
      for (int c = 0; c < 3; ++c)
        if (xyz[(f * joints + j) * 3 + c] != values[static_cast<size_t>((f * joints + j) * 4 + c)]) ++wrong;
  EXPECT_EQ(wrong, 0);
  kata_landmarks_destroy(l);
  // The same timestamps in milliseconds, the units inferred.
  std::vector<double> ms;
  for (double t : seconds) ms.push_back(1000.0 * t);
  write_npy(times, ms, "6,");
  ASSERT_EQ(kata_landmarks_load(ctx, npy.c_str(), "mediapipe", 0.0, -1, &l), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_NEAR(kata_landmarks_frame_time(l), 0.034, 1e-12);
  EXPECT_NEAR(kata_landmarks_capture_time(l, 4), 0.131, 1e-12);
  kata_landmarks_destroy(l);
  // No timestamps and no fps: refused naming the file; with an fps, frame i at i / fps.
  std::remove(times.c_str());
  EXPECT_EQ(kata_landmarks_load(ctx, npy.c_str(), "mediapipe", 0.0, -1, &l), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(l, nullptr);
  EXPECT_NE(std::strstr(kata_context_last_error(ctx), "kata_landmarks_capi_"), nullptr) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_landmarks_load(ctx, npy.c_str(), "mediapipe", 25.0, -1, &l), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_NEAR(kata_landmarks_frame_time(l), 0.04, 1e-12);
  EXPECT_NEAR(kata_landmarks_capture_time(l, 3), 0.12, 1e-12);
  kata_landmarks_destroy(l);
  EXPECT_EQ(kata_landmarks_load(ctx, npy.c_str(), "no-such-layout", 25.0, -1, &l), KATA_E_NOT_FOUND);
  EXPECT_EQ(kata_landmarks_load(ctx, npy.c_str(), "mediapipe", 25.0, 7, &l), KATA_E_INVALID_ARGUMENT);
  // A CSV of the 16 GPD joints (x, y, z) after a timestamp column in milliseconds.
  {
    std::ofstream out(csv);
    for (int f = 0; f < 3; ++f) {
      out << 20 * f;  // ms: 50 Hz
      for (int k = 0; k < 16 * 3; ++k) out << ',' << f + 0.01 * k;
      out << '\n';
    }
  }
  ASSERT_EQ(kata_landmarks_load(ctx, csv.c_str(), "gpd", 0.0, KATA_TIME_MILLISECONDS, &l), KATA_OK)
      << kata_context_last_error(ctx);
  EXPECT_EQ(kata_landmarks_frame_count(l), 3u);
  EXPECT_EQ(kata_landmarks_joint_count(l), 16u);
  EXPECT_NEAR(kata_landmarks_frame_time(l), 0.02, 1e-12);
  EXPECT_NEAR(kata_landmarks_positions(l)[2 * 48 + 47], 2.47f, 1e-5f);
  kata_landmarks_destroy(l);
  EXPECT_EQ(kata_landmarks_frame_count(nullptr), 0u);
  EXPECT_EQ(kata_landmarks_positions(nullptr), nullptr);
  kata_landmarks_destroy(nullptr);
  std::remove(npy.c_str());
  std::remove(csv.c_str());
  kata_context_destroy(ctx);
}

}  // namespace
