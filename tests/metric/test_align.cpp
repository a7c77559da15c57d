// Online alignment to a clip reference: the student is the teacher's own motion, slowed down or
// delayed, pushed frame by frame through a live Stream; the matched teacher frames must follow
// the true ones.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <utility>
#include <vector>

#include "common/error.hpp"
#include "fixtures.hpp"
#include "metric/align.hpp"
#include "metric/align_pass.hpp"
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

// A step far beyond the band (a teacher of a small frame time, a long pause): max_rate x the
// expected advance overflowed an int (UBSan: align.cpp begin_step, found by fuzz_ingest); now the
// step is bounded by the section before the cast, and the match stays inside the clip.
TEST(Aligner, AStepOfBillionsOfTeacherFramesStaysInsideTheClip) {
  const auto metric = test::test_metric();
  const auto& rows = test::clip_rows("07_01.bvh");
  const int frames = test::clip_frames("07_01.bvh");
  for (const double frame_time : {1.0 / 120, 1e-4}) {  // 1e-4: a 10 kHz teacher; 9.9e5 s is 9.9e9 frames
    const auto ref = std::make_shared<const metric::Reference>(metric, rows.data(), frames, frame_time);
    metric::Aligner aligner(ref);
    double t = 0.0;
    for (const double step : {0.0, 1.0 / 120, 9.9e5, 1.0, 9.9e5}) {
      t += step;
      const int matched = aligner.align(ref->alignment_projection(10), t);
      EXPECT_GE(matched, 0);
      EXPECT_LT(matched, frames) << "frame time " << frame_time << ", t " << t;
    }
  }
}

TEST(Aligner, PoseReferenceAlwaysMatchesFrameZero) {
  const auto metric = test::test_metric();
  const auto ref = std::make_shared<const metric::Reference>(metric, test::clip_row("02_01.bvh", 5));
  metric::Aligner aligner(ref);
  for (int f = 0; f < 10; ++f) EXPECT_EQ(aligner.align(ref->alignment_projection(0), f / 120.0), 0);
}

INSTANTIATE_TEST_SUITE_P(Clips, Align,
                         ::testing::Values("02_01.bvh", "02_02.bvh", "05_02.bvh", "05_03.bvh", "07_01.bvh", "09_01.bvh"));


// The alignment's dynamic programme (align_pass.hpp): the dispatched step equals, bit for bit, the
// recurrence written out plainly here (every k, the wrap of a loop, the re-basing on the first
// least cost), on sections anywhere in the clip, with and without a loop, for steps up to 9.
TEST(Kernels, AlignmentStepMatchesThePlainRecurrence) {
  std::srand(11);
  auto value = [] { return static_cast<double>(std::rand()) / RAND_MAX * 3.0; };
  const int frames = 300;
  for (bool loop : {false, true})
    for (int k_max : {1, 2, 5, 9})
      for (auto [a, b] : {std::pair{0, frames - 1}, std::pair{17, 40}, std::pair{100, 110}}) {
        std::vector<double> prev(frames), pk(static_cast<size_t>(k_max) + 1), fast(frames, -1.0), plain(frames, -1.0);
        std::vector<float> c(frames);
        for (double& v : prev) v = value();
        for (float& v : c) v = static_cast<float>(value());
        for (double& v : pk) v = value() * 0.1;
        const double jump = 2.0;
        const int best = metric::detail::alignment_step(prev.data(), fast.data(), c.data(), a, b, pk.data(), k_max, jump, loop);
        const int n = b - a + 1;
        for (int j = a; j <= b; ++j) {
          double m = jump;
          for (int k = 0; k <= k_max; ++k) {
            if (j - k >= a) m = std::min(m, prev[j - k] + pk[k]);
            else if (loop) m = std::min(m, prev[j - k + n] + pk[k]);
          }
          plain[j] = m + c[j];
        }
        int plain_best = a;
        for (int j = a; j <= b; ++j)
          if (plain[j] < plain[plain_best]) plain_best = j;
        const double base = plain[plain_best];
        for (int j = a; j <= b; ++j) plain[j] -= base;
        ASSERT_EQ(best, plain_best) << "loop " << loop << " k_max " << k_max << " section " << a << ".." << b;
        for (int j = 0; j < frames; ++j) ASSERT_EQ(fast[j], plain[j]) << "frame " << j << " section " << a << ".." << b;
      }
}

// The windowed search's step (cold4) taken slice by slice: alignment_step_range over slices of
// 1, 7 and 64 frames, then re-based, equals the plain recurrence (and so alignment_step) frame for
// frame, and writes nothing outside its slice.
TEST(Kernels, AlignmentStepBySlicesMatchesThePlainRecurrence) {
  std::srand(12);
  auto value = [] { return static_cast<double>(std::rand()) / static_cast<double>(RAND_MAX) * 3.0; };
  const int frames = 300;
  for (bool loop : {false, true})
    for (int k_max : {1, 5, 17})
      for (auto [a, b] : {std::pair{0, frames - 1}, std::pair{17, 140}})
        for (int slice : {1, 7, 64}) {
          std::vector<double> prev(frames), pk(static_cast<size_t>(k_max) + 1), sliced(frames, -1.0), plain(frames, -1.0);
          std::vector<float> c(frames);
          for (double& v : prev) v = value();
          for (float& v : c) v = static_cast<float>(value());
          for (double& v : pk) v = value() * 0.1;
          const double jump = 2.0;
          for (int lo = a; lo <= b; lo += slice) {
            const int hi = std::min(b, lo + slice - 1);
            metric::detail::alignment_step_range(prev.data(), sliced.data(), c.data(), a, b, lo, hi, pk.data(), k_max,
                                                 jump, loop);
            if (hi < b) {
              ASSERT_EQ(sliced[hi + 1], -1.0) << "wrote past its slice " << lo << ".." << hi;
            }
          }
          const int best = metric::detail::alignment_rebase(sliced.data(), a, b);
          const int n = b - a + 1;
          for (int j = a; j <= b; ++j) {
            double m = jump;
            for (int k = 0; k <= k_max; ++k) {
              if (j - k >= a) m = std::min(m, prev[j - k] + pk[k]);
              else if (loop) m = std::min(m, prev[j - k + n] + pk[k]);
            }
            plain[j] = m + c[j];
          }
          int plain_best = a;
          for (int j = a; j <= b; ++j)
            if (plain[j] < plain[plain_best]) plain_best = j;
          const double base = plain[plain_best];
          for (int j = a; j <= b; ++j) plain[j] -= base;
          ASSERT_EQ(best, plain_best) << "loop " << loop << " k_max " << k_max << " slice " << slice;
          for (int j = 0; j < frames; ++j) ASSERT_EQ(sliced[j], plain[j]) << "frame " << j << " slice " << slice;
        }
}


// IEEE half precision for the alignment's rows: every one of the 65,536 halves converts exactly
// (checked against sign x mantissa x 2^exponent in double), and a float becomes the nearest half
// (ties to even) for normals, subnormals and the overflow to infinity.
TEST(Kernels, HalfPrecisionConversionsAreIeee) {
  for (uint32_t h = 0; h < 65536; ++h) {
    const uint32_t e = (h >> 10) & 31, m = h & 1023;
    const float f = metric::detail::half_to_float(static_cast<uint16_t>(h));
    if (e == 31) {
      ASSERT_TRUE(m ? std::isnan(f) : std::isinf(f)) << h;
      continue;
    }
    const double want = (h & 0x8000 ? -1.0 : 1.0) * (e == 0 ? std::ldexp(m, -24) : std::ldexp(1024 + m, static_cast<int>(e) - 25));
    ASSERT_EQ(static_cast<double>(f), want) << h;
    ASSERT_EQ(std::signbit(f), (h & 0x8000) != 0) << h;
    ASSERT_EQ(metric::detail::float_to_half(f), h) << "round trip of " << h;
  }
  std::srand(5);
  for (int i = 0; i < 100000; ++i) {
    const float f = std::ldexp(static_cast<float>(std::rand()) / static_cast<float>(RAND_MAX) - 0.5f, std::rand() % 44 - 28);
    const uint16_t h = metric::detail::float_to_half(f);
    const double got = metric::detail::half_to_float(h);
    // No other half is nearer; on a tie the chosen one is even.
    for (int d : {-1, 1}) {
      const double other = metric::detail::half_to_float(static_cast<uint16_t>(h + d));
      if (std::isinf(other) || ((h & 0x7fff) == 0 && d == -1)) continue;
      ASSERT_LE(std::fabs(got - f), std::fabs(other - f)) << f;
      if (std::fabs(got - f) == std::fabs(other - f)) {
        ASSERT_EQ(h & 1, 0) << f;
      }
    }
  }
  EXPECT_EQ(metric::detail::float_to_half(65504.0f), 0x7bff);
  EXPECT_EQ(metric::detail::float_to_half(65519.0f), 0x7bff);
  EXPECT_EQ(metric::detail::float_to_half(65520.0f), 0x7c00);
  EXPECT_EQ(metric::detail::float_to_half(-1e30f), 0xfc00);
  EXPECT_EQ(metric::detail::float_to_half(std::ldexp(1.0f, -25)), 0);  // a tie to even, 0
  EXPECT_EQ(metric::detail::float_to_half(std::ldexp(3.0f, -25)), 2);  // a tie to even, 2^-23
}

// The live aligner's pass over half-precision rows: every dispatched kernel equals the baseline
// bit for bit, and both equal the plain formula in double on the rows' half values, scaled.
TEST(Kernels, HalfRowAlignmentDistancesMatchThePlainFormula) {
  std::srand(9);
  auto value = [] { return (static_cast<float>(std::rand()) / static_cast<float>(RAND_MAX) - 0.5f) * 40.0f; };
  for (float scale : {1.0f, 4.0f})
    for (int stride : {8, 56, 64})
      for (int m : {1, 7, 8, 9, 61, 1829}) {
        std::vector<float> s(static_cast<size_t>(stride));
        std::vector<uint16_t> rows(static_cast<size_t>(m) * stride);
        for (float& v : s) v = value();
        for (uint16_t& v : rows) v = metric::detail::float_to_half(value());
        std::vector<float> fast(static_cast<size_t>(m)), base(static_cast<size_t>(m));
        metric::detail::alignment_distances_half(s.data(), rows.data(), m, stride, scale, fast.data());
        metric::detail::base::alignment_distances_half(s.data(), rows.data(), m, stride, scale, base.data());
        for (int j = 0; j < m; ++j) {
          ASSERT_EQ(fast[j], base[j]) << "stride " << stride << " rows " << m << " row " << j;
          double d2 = 0.0;
          for (int c = 0; c < stride; ++c) {
            const double e = static_cast<double>(s[c]) - metric::detail::half_to_float(rows[static_cast<size_t>(j) * stride + c]);
            d2 += e * e;
          }
          ASSERT_NEAR(base[j], scale * std::sqrt(d2), 1e-5 * scale * std::sqrt(d2) + 1e-6) << "row " << j;
        }
      }
}

// The scorer's subtraction of a teacher's 16-bit row: the dispatched kernel equals the baseline
// bit for bit, both equal row - step * q in float (one rounding each), and a result within 0.51
// steps is 0, including values placed on either side of that edge.
TEST(Kernels, SixteenBitRowSubtractionMatchesThePlainFormula) {
  std::srand(36);
  for (int n : {1, 7, 8, 50, 61}) {
    for (float step : {0.0f, 1e-5f, 3.0e-4f}) {
      std::vector<int16_t> q(static_cast<size_t>(n));
      std::vector<float> row(static_cast<size_t>(n));
      for (int c = 0; c < n; ++c) {
        q[static_cast<size_t>(c)] = static_cast<int16_t>(std::rand() % 65535 - 32767);
        const float decoded = step * static_cast<float>(q[static_cast<size_t>(c)]);
        // Near the decoded value (within a few steps, some on the 0.51-step edge) or anywhere.
        const float near[] = {0.0f, 0.5f, 0.51f, 0.52f, -0.51f, -2.0f};
        row[static_cast<size_t>(c)] = c % 3 == 2 ? (static_cast<float>(std::rand()) / static_cast<float>(RAND_MAX) - 0.5f)
                                                 : decoded + near[std::rand() % 6] * step;
      }
      std::vector<float> fast(row), base(row);
      metric::detail::subtract_rows16(fast.data(), q.data(), step, n);
      metric::detail::base::subtract_rows16(base.data(), q.data(), step, n);
      for (int c = 0; c < n; ++c) {
        ASSERT_EQ(fast[static_cast<size_t>(c)], base[static_cast<size_t>(c)]) << n << " " << c;
        const float d = row[static_cast<size_t>(c)] - step * static_cast<float>(q[static_cast<size_t>(c)]);
        ASSERT_EQ(base[static_cast<size_t>(c)], std::fabs(d) <= 0.51f * step ? 0.0f : d) << n << " " << c;
      }
    }
  }
}

}  // namespace
}  // namespace kata
