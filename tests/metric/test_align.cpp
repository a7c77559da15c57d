// Online alignment to a clip reference: the student is the teacher's own motion, slowed down or
// delayed, pushed frame by frame through a live Stream; the matched teacher frames must follow
// the true ones.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>

#include "common/error.hpp"
#include "fixtures.hpp"
#include "metric/align.hpp"
#include "stream/stream.hpp"

namespace kata {
namespace {

// Student features: frame n at time n / 120 s shows the teacher's motion at teacher frame
// index true_index(n) (fractional: world joint positions interpolated linearly between frames).
// Teacher frame index i means clip frame i + 1 (frame 0, the T-pose, is skipped as in
// test::clip_rows).
template <typename TrueIndex>
std::vector<float> student_features(const std::string& name, int frames, TrueIndex true_index) {
  const BvhClip clip = load_bvh(test::cmu(name));
  const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
  Stream stream(stream_config_for(clip.skeleton, map, gpd::Stencil::kBackward));
  const int n = clip.skeleton.joint_count();
  Eigen::MatrixX3d a(n, 3), b(n, 3);
  std::vector<float> xyz(3 * static_cast<size_t>(n)), out;
  for (int f = 0; f < frames; ++f) {
    const double ti = true_index(f);
    const int i0 = static_cast<int>(std::floor(ti));
    const double w = ti - i0;
    world_positions(clip, i0 + 1, a);
    world_positions(clip, std::min(i0 + 2, clip.frame_count() - 1), b);
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) xyz[3 * j + k] = static_cast<float>((1.0 - w) * a(j, k) + w * b(j, k));
    const int64_t before = stream.emitted_count();
    EXPECT_EQ(stream.push(f / 120.0, xyz.data(), n), Status::kOk) << stream.last_error();
    EXPECT_EQ(stream.emitted_count(), before + 1);  // backward stencil: one vector per frame
    out.insert(out.end(), stream.features(), stream.features() + gpd::kDims);
  }
  return out;
}

// Scores the student against the whole teacher clip; returns the matched indices.
std::vector<int> align(const std::string& name, const std::vector<float>& student) {
  const auto metric = test::test_metric();
  const auto& teacher = test::clip_rows(name);
  const auto ref = std::make_shared<const metric::Reference>(metric, teacher.data(), test::clip_frames(name), 1.0 / 120);
  metric::Scorer scorer(ref);
  std::vector<int> matched;
  for (size_t f = 0; f < student.size() / gpd::kDims; ++f)
    matched.push_back(scorer.score(student.data() + f * gpd::kDims, static_cast<double>(f) / 120.0).matched);
  return matched;
}

void expect_follows(const std::vector<int>& matched, const std::function<double(int)>& true_index, int warmup) {
  int prev = 0, worst = 0;
  for (int f = 0; f < static_cast<int>(matched.size()); ++f) {
    ASSERT_GE(matched[f], prev) << "the match moved backwards at student frame " << f;
    prev = matched[f];
    if (f < warmup) continue;
    const int err = static_cast<int>(std::abs(matched[f] - std::lround(true_index(f))));
    worst = std::max(worst, err);
    EXPECT_LE(err, 2) << "student frame " << f << ": matched " << matched[f] << ", true " << true_index(f);
  }
  ::testing::Test::RecordProperty("worst_error_frames", worst);
  if (std::getenv("KATA_ALIGN_DEBUG")) std::printf("worst error %d frames\n", worst);
}

class Align : public ::testing::TestWithParam<const char*> {};

TEST_P(Align, TenPercentSlower) {
  const std::string name = GetParam();
  const int teacher_frames = test::clip_frames(name);
  // 10% slower: teacher time = student time / 1.1.
  auto truth = [](int f) { return f / 1.1; };
  const int frames = static_cast<int>((teacher_frames - 2) * 1.1);
  const std::vector<int> matched = align(name, student_features(name, frames, truth));
  expect_follows(matched, truth, 24);
}

TEST_P(Align, DelayedByThreeTenthsOfASecond) {
  const std::string name = GetParam();
  const int teacher_frames = test::clip_frames(name);
  // The student holds the first pose for 0.3 s (36 frames at 120 fps), then follows at speed.
  auto truth = [](int f) { return f < 36 ? 0.0 : f - 36.0; };
  const std::vector<int> matched = align(name, student_features(name, teacher_frames - 2 + 36, truth));
  expect_follows(matched, truth, 36 + 24);
}

TEST_P(Align, SameTimingMatchesExactly) {
  const std::string name = GetParam();
  const int frames = test::clip_frames(name);
  const std::vector<int> matched = align(name, test::clip_rows(name));
  for (int f = 0; f < frames; ++f) ASSERT_EQ(matched[f], f);
}

TEST_P(Align, FifteenPercentFaster) {
  const std::string name = GetParam();
  const int teacher_frames = test::clip_frames(name);
  auto truth = [](int f) { return f * 1.15; };
  const int frames = static_cast<int>((teacher_frames - 2) / 1.15);
  const std::vector<int> matched = align(name, student_features(name, frames, truth));
  expect_follows(matched, truth, 24);
}

// The Aligner on its own: fed the teacher's own static-blocks projections it matches every frame
// exactly, starts over after reset(), and refuses options out of range.
TEST(Aligner, FollowsTheTeachersOwnProjectionsAndRestarts) {
  const auto metric = test::test_metric();
  const auto& rows = test::clip_rows("07_01.bvh");
  const int frames = test::clip_frames("07_01.bvh");
  const auto ref = std::make_shared<const metric::Reference>(metric, rows.data(), frames, 1.0 / 120);
  metric::Aligner aligner(ref);
  for (int pass = 0; pass < 2; ++pass) {
    for (int f = 0; f < frames; f += 1) ASSERT_EQ(aligner.align(ref->alignment_projection(f), f / 120.0), f) << pass;
    aligner.reset();
  }
  EXPECT_THROW(metric::Aligner(ref, metric::AlignmentOptions{0.0, 2.0, 0.25}), Error);
  EXPECT_THROW(metric::Aligner(ref, metric::AlignmentOptions{0.5, 0.0, 0.25}), Error);
  EXPECT_THROW(metric::Aligner(ref, metric::AlignmentOptions{0.5, 2.0, -1.0}), Error);
  EXPECT_THROW(metric::Aligner(nullptr), Error);
}

TEST(Aligner, PoseReferenceAlwaysMatchesFrameZero) {
  const auto metric = test::test_metric();
  const auto ref = std::make_shared<const metric::Reference>(metric, test::clip_row("02_01.bvh", 5));
  metric::Aligner aligner(ref);
  for (int f = 0; f < 10; ++f) EXPECT_EQ(aligner.align(ref->alignment_projection(0), f / 120.0), 0);
}

INSTANTIATE_TEST_SUITE_P(Clips, Align,
                         ::testing::Values("02_01.bvh", "02_02.bvh", "05_02.bvh", "05_03.bvh", "07_01.bvh", "09_01.bvh"));

}  // namespace
}  // namespace kata
