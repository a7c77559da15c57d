// The float32 SIMD kernels (baseline and AVX2) against the double reference on many random
// poses, including degenerate ones, and on streams that exercise the plane-normal memory.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "gpd_test_util.hpp"
#include "support/alloc_counter.hpp"

namespace {

using namespace gpd_test;
using Pose = std::array<float, 48>;

// A random pose built along the skeleton (bones 0.05..0.3 body heights in random directions),
// with, at random, the degeneracies of the spec: coincident joints (zero bones and lines),
// straight limbs (collinear planes), almost straight limbs, and the whole body on one point.
Pose random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f), len(0.05f, 0.3f), prob(0.0f, 1.0f);
  Pose p{};
  for (int k = 0; k < 3; ++k) p[k] = 0.0f;  // the local frame has the hip at the origin
  for (int j = 1; j < 16; ++j) {
    const int par = detail::kParent[j];
    float d[3];
    float n2 = 0;
    do {
      for (float& x : d) x = unit(rng);
      n2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    } while (n2 < 1e-2f || n2 > 1.0f);
    const float l = len(rng) / std::sqrt(n2);
    const float r = prob(rng);
    const int gp = par > 0 ? detail::kParent[par] : -1;
    for (int k = 0; k < 3; ++k) {
      if (r < 0.05f) {
        p[3 * j + k] = p[3 * par + k];  // coincident with its parent
      } else if (r < 0.15f && gp >= 0) {
        p[3 * j + k] = p[3 * par + k] + 1.5f * (p[3 * par + k] - p[3 * gp + k]);  // straight limb
      } else if (r < 0.20f && gp >= 0) {
        p[3 * j + k] = p[3 * par + k] + (p[3 * par + k] - p[3 * gp + k]) + 1e-4f * d[k];  // almost
      } else {
        p[3 * j + k] = p[3 * par + k] + l * d[k];
      }
    }
  }
  if (prob(rng) < 0.02f) {
    for (int j = 1; j < 16; ++j) {
      for (int k = 0; k < 3; ++k) p[3 * j + k] = 0.0f;
    }
  }
  return p;
}

// Compares one fast path with the reference over a sequence of poses (each keeping its own
// GeometryState, as a stream would); reports the worst error per block.
void compare_sequence(Path path, const std::vector<Pose>& poses, const char* what) {
  GeometryState sr, sf;
  std::vector<double> ref(kStaticDims);
  std::vector<float> fast(kStaticDims);
  double worst[9] = {};
  int worst_dim[9] = {};
  int failures = 0;
  for (size_t f = 0; f < poses.size(); ++f) {
    const float hip = 0.5f + 0.001f * static_cast<float>(f % 100);
    detail::static_features_reference(poses[f].data(), hip, sr, ref.data());
    run_fast(path, poses[f].data(), hip, sf, fast.data());
    for (int p = 0; p < kPlanes; ++p) {
      ASSERT_EQ(sr.has_normal[p], sf.has_normal[p]) << what << " frame " << f << " plane " << p;
    }
    for (int d = 0; d < kStaticDims; ++d) {
      if (!std::isfinite(fast[d])) {
        ADD_FAILURE() << what << " " << path_name(path) << " frame " << f << " " << block_of(d) << " not finite";
        if (++failures > 20) return;
        continue;
      }
      const double err = std::abs(fast[d] - ref[d]);
      const int b = block_index(d);
      if (err > worst[b]) {
        worst[b] = err;
        worst_dim[b] = d;
      }
      if (err > tolerance(d, ref[d])) {
        ADD_FAILURE() << what << " " << path_name(path) << " frame " << f << " " << block_of(d) << ": fast "
                      << fast[d] << " reference " << ref[d];
        if (++failures > 20) return;
      }
    }
  }
  std::printf("  %s %-8s worst |fast - reference| per block:", what, path_name(path));
  for (int b = 0; b < 8; ++b) std::printf(" %s %.1e", block_of(worst_dim[b]).substr(0, 3).c_str(), worst[b]);
  std::printf("\n");
}

TEST(GpdFast, RandomPosesMatchReference) {
  std::mt19937 rng(12345);
  std::vector<Pose> poses;
  for (int i = 0; i < 3000; ++i) poses.push_back(random_pose(rng));
  for (Path p : fast_paths()) compare_sequence(p, poses, "random");
}

TEST(GpdFast, SmoothStreamMatchesReference) {
  // A pose drifting slowly, with straight limbs every 7th frame: the previous-normal memory
  // must evolve identically in both implementations.
  std::mt19937 rng(777);
  Pose base = random_pose(rng);
  std::vector<Pose> poses;
  std::normal_distribution<float> step(0.0f, 0.01f);
  for (int f = 0; f < 500; ++f) {
    for (int k = 3; k < 48; ++k) base[k] += step(rng);
    Pose p = base;
    if (f % 7 == 3) {
      for (int e : {6, 9, 12, 15}) {  // hand/foot on the line through its grandparent and parent
        const int par = detail::kParent[e], gp = detail::kParent[par];
        for (int k = 0; k < 3; ++k) p[3 * e + k] = 2 * p[3 * par + k] - p[3 * gp + k];
      }
    }
    poses.push_back(p);
  }
  for (Path p : fast_paths()) compare_sequence(p, poses, "stream");
}

TEST(GpdFast, LargeAndTinyScales) {
  // Body heights are ~1, but nothing in the kernels should assume it: x1e3 and x1e-3.
  std::mt19937 rng(99);
  for (float scale : {1e3f, 1e-3f}) {
    std::vector<Pose> poses;
    for (int i = 0; i < 200; ++i) {
      Pose p = random_pose(rng);
      for (float& x : p) x *= scale;
      poses.push_back(p);
    }
    GeometryState sr, sf;
    std::vector<double> ref(kStaticDims);
    std::vector<float> fast(kStaticDims);
    for (Path path : fast_paths()) {
      for (const Pose& p : poses) {
        detail::static_features_reference(p.data(), 0.5f, sr, ref.data());
        run_fast(path, p.data(), 0.5f, sf, fast.data());
        for (int d = 0; d < kStaticDims; ++d) {
          // Distances scale with the pose; directions and angles do not.
          const bool length = (d < kOffsetJJo && d != 45) || (d >= kOffsetJLd && d < kOffsetLLa) ||
                              (d >= kOffsetJPd && d < kOffsetLPa);
          const double tol = tolerance(d, ref[d]) * (length ? scale : 1.0);
          ASSERT_NEAR(fast[d], ref[d], tol) << path_name(path) << " scale " << scale << " " << block_of(d);
        }
      }
    }
  }
}

TEST(GpdFast, HugeCoordinatesStayFinite) {
  // Far beyond any body (1e25 body heights: float32 squares overflow), static_features() must
  // still give finite numbers, equal to the reference's (it hands such frames to it).
  std::mt19937 rng(11);
  for (int i = 0; i < 20; ++i) {
    Pose p = random_pose(rng);
    for (float& x : p) x *= 1e25f;
    GeometryState sr, sf;
    std::vector<double> ref(kStaticDims);
    std::vector<float> out(kStaticDims);
    detail::static_features_reference(p.data(), 0.5f, sr, ref.data());
    static_features(p.data(), 0.5f, sf, out.data());
    for (int d = 0; d < kStaticDims; ++d) {
      ASSERT_TRUE(std::isfinite(out[d])) << block_of(d);
      ASSERT_EQ(out[d], static_cast<float>(ref[d])) << block_of(d);
    }
  }
}

TEST(GpdFast, DispatchFollowsCpuCheck) {
  // static_features() must equal the AVX2 kernel when the CPU has it (and KATA_NO_AVX2 is
  // unset), the baseline kernel otherwise: bitwise, since it is the same code.
  std::mt19937 rng(5);
  const Path expected = fast_paths().back();
  for (int i = 0; i < 50; ++i) {
    const Pose p = random_pose(rng);
    GeometryState s1, s2;
    std::vector<float> a(kStaticDims), b(kStaticDims);
    static_features(p.data(), 0.5f, s1, a.data());
    run_fast(expected, p.data(), 0.5f, s2, b.data());
    ASSERT_EQ(a, b) << "dispatch is not " << path_name(expected);
  }
  std::printf("  dispatch uses the %s kernel\n", path_name(expected));
}

// The plain formula for what the kernels report: the largest |v| as its IEEE pattern with the
// sign cleared (those order as the magnitudes; Inf above every finite value, NaN above Inf).
uint32_t plain_largest_bits(const float* v, int n) {
  uint32_t m = 0;
  for (int i = 0; i < n; ++i) {
    uint32_t b;
    std::memcpy(&b, v + i, sizeof b);
    m = std::max(m, b & 0x7fffffffu);
  }
  return m;
}

// Each kernel folds what it stores into a running maximum instead of a second pass over the
// vector (the stream's finiteness check reads that report). It must equal the plain formula over
// the 1591 values left in `out`, bit for bit: the lanes a kernel writes and later overwrites
// (batch spills) must not count, and a NaN or Inf anywhere must show. Poses: random ones with
// the spec's degeneracies, at several scales, at the origin and off it; and the same with NaN, +-Inf or a huge value planted
// in each of the 48 coordinates (the dispatcher sends Inf and huge frames to the double
// reference, the kernels take them as they are).
TEST(GpdChecks, KernelsReportTheLargestMagnitudeTheyWrite) {
  using Fn = uint32_t (*)(const float*, float, GeometryState&, float*);
  std::vector<std::pair<const char*, Fn>> impls = {
      {"dispatch", [](const float* l, float h, GeometryState& s, float* o) { return static_features(l, h, s, o); }},
      {"baseline", [](const float* l, float h, GeometryState& s, float* o) {
         return run_fast(Path::kBaseline, l, h, s, o);
       }}};
  if (fast_paths().back() == Path::kAvx2)
    impls.push_back({"avx2", [](const float* l, float h, GeometryState& s, float* o) {
                       return run_fast(Path::kAvx2, l, h, s, o);
                     }});
  const float planted[] = {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::quiet_NaN(),
                           std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(), 3e18f,
                           -1e25f};
  std::mt19937 rng(23);
  std::vector<float> out(kStaticDims);
  int non_finite = 0, finite = 0;
  for (int i = 0; i < 400; ++i) {
    Pose p = random_pose(rng);
    const float scale = i % 4 == 0 ? 1e-3f : i % 4 == 1 ? 1e3f : 1.0f;
    for (float& x : p) x *= scale;
    // Off the origin too (the kernels take any local coordinates), so that a spilled lane
    // (a joint against the zero padding) can exceed every feature.
    if (i % 3 == 2)
      for (size_t c = 0; c < p.size(); ++c) p[c] += scale * (c % 3 == 1 ? 4.0f : -3.0f);
    if (i >= 100) p[static_cast<size_t>(i % 48)] = planted[i % 6];
    const float hip = i % 7 == 0 ? -2.5f : 0.9f;
    for (const auto& [name, fn] : impls) {
      GeometryState state;
      std::fill(out.begin(), out.end(), 0.0f);
      const uint32_t report = fn(p.data(), hip, state, out.data());
      const uint32_t plain = plain_largest_bits(out.data(), kStaticDims);
      ASSERT_EQ(report, plain) << name << " pose " << i << " (scale " << scale << ")";
      ++(plain >= 0x7f800000u ? non_finite : finite);
    }
  }
  EXPECT_GT(non_finite, 100) << "the planted values must reach the features";
  EXPECT_GT(finite, 300);
  // A non-finite hip height reaches Jc alone.
  for (const auto& [name, fn] : impls) {
    GeometryState state;
    const Pose p = random_pose(rng);
    uint32_t report = fn(p.data(), std::numeric_limits<float>::quiet_NaN(), state, out.data());
    EXPECT_EQ(report, 0x7fc00000u) << name;
    EXPECT_EQ(report, plain_largest_bits(out.data(), kStaticDims)) << name;
    report = fn(p.data(), -std::numeric_limits<float>::infinity(), state, out.data());
    EXPECT_EQ(report, 0x7f800000u) << name;
    EXPECT_EQ(report, plain_largest_bits(out.data(), kStaticDims)) << name;
  }
}

// The kinetics kernels report the largest magnitude of the 92 values they write, NaN and Inf
// included (from a sample that holds one).
TEST(GpdChecks, KineticsReportTheLargestMagnitudeTheyWrite) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> unit(-2.0f, 2.0f);
  const float planted[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                           -std::numeric_limits<float>::infinity(), 1e30f};
  std::vector<float> f0(kJcDims), f1(kJcDims), f2(kJcDims), out(kKineticDims);
  for (int i = 0; i < 300; ++i) {
    for (int k = 0; k < kJcDims; ++k) {
      f0[k] = unit(rng);
      f1[k] = f0[k] + 0.01f * unit(rng);
      f2[k] = f1[k] + 0.01f * unit(rng);
    }
    if (i >= 60) (i % 3 == 0 ? f0 : i % 3 == 1 ? f1 : f2)[static_cast<size_t>(i % kJcDims)] = planted[i % 4];
    const double h1 = 0.004 + 0.001 * (i % 5), h2 = 0.008;
    uint32_t report = kinetics(f0.data(), f1.data(), f2.data(), backward_weights(h1, h2), out.data());
    EXPECT_EQ(report, plain_largest_bits(out.data(), kKineticDims)) << "backward " << i;
    report = kinetics(f0.data(), f1.data(), f2.data(), central_weights(h1, h2), out.data());
    EXPECT_EQ(report, plain_largest_bits(out.data(), kKineticDims)) << "central " << i;
    report = kinetics_two_point(f0.data(), f1.data(), h1, out.data());
    EXPECT_EQ(report, plain_largest_bits(out.data(), kKineticDims)) << "two-point " << i;
  }
  std::fill(out.begin(), out.end(), std::numeric_limits<float>::quiet_NaN());
  const uint32_t report = kinetics_zero(out.data());
  EXPECT_EQ(report, 0u);
  EXPECT_EQ(plain_largest_bits(out.data(), kKineticDims), 0u);
}

TEST(GpdFast, PerFrameKernelsDoNotAllocate) {
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  std::mt19937 rng(3);
  const Pose p = random_pose(rng);
  GeometryState s;
  std::vector<float> out(kDims);
  float local[48], hip = 0;
  const DifferenceWeights w = backward_weights(0.01, 0.02);
  const std::vector<Path> paths = fast_paths();  // allocates: outside the counted region
  const long before = kata::test::allocations();
  to_local_frame(p.data(), 1.7, s, local, &hip);
  static_features(local, hip, s, out.data());
  for (Path path : paths) run_fast(path, local, hip, s, out.data());
  kinetics(out.data(), out.data(), out.data(), w, out.data() + kOffsetJk);
  kinetics_two_point(out.data(), out.data(), 0.01, out.data() + kOffsetJk);
  kinetics_zero(out.data() + kOffsetJk);
  EXPECT_EQ(kata::test::allocations(), before);
}

}  // namespace

namespace kata::gpd {
namespace {

// The per-frame checks' reduction (largest_magnitude_bits), each ISA and the dispatcher, against
// the plain formula: max |v| over finite values, and "some value is not finite", on lengths that
// cover every tail, with NaN, +-Inf, the largest float and negative zero planted anywhere.
TEST(GpdChecks, LargestMagnitudeBitsMatchesPlainFormula) {
  using Fn = uint32_t (*)(const float*, int);
  std::vector<std::pair<const char*, Fn>> impls = {
      {"dispatch", [](const float* v, int n) { return largest_magnitude_bits(v, n); }},
      {"sse4", [](const float* v, int n) { return detail::sse4::largest_magnitude_bits(v, n); }}};
  if (detail::avx2::compiled() && cpu_has_avx2())
    impls.push_back({"avx2", [](const float* v, int n) { return detail::avx2::largest_magnitude_bits(v, n); }});
  const float specials[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::max(),
                            -std::numeric_limits<float>::max(), -0.0f, 1e9f, -1.0000001e9f};
  uint32_t seed = 12345;
  auto next = [&seed] {
    seed = seed * 1664525u + 1013904223u;
    return seed;
  };
  for (int n : {0, 1, 7, 8, 15, 16, 17, 31, 48, 63, 64, 65, 79, 80, 93, 127, 128, 129, 1683}) {
    for (int trial = 0; trial < 40; ++trial) {
      std::vector<float> v(static_cast<size_t>(n));
      for (float& x : v) x = (static_cast<float>(next() % 20001) - 10000.0f) * 1e-2f;
      if (n > 0 && trial > 0) v[next() % static_cast<uint32_t>(n)] = specials[trial % 8];
      bool finite = true;
      float largest = 0.0f;
      for (float x : v) {
        finite = finite && std::isfinite(x);
        if (std::isfinite(x)) largest = std::max(largest, std::fabs(x));
      }
      for (const auto& [name, fn] : impls) {
        const uint32_t bits = fn(v.data(), n);
        EXPECT_EQ(bits < 0x7f800000u, finite) << name << " n " << n << " trial " << trial;
        if (finite) {
          float got;
          std::memcpy(&got, &bits, sizeof got);
          EXPECT_EQ(got, largest) << name << " n " << n << " trial " << trial;
        }
      }
    }
  }
}

}  // namespace
}  // namespace kata::gpd
