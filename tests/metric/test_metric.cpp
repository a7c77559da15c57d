// The compiled metric: normalisation, projection and the score map, each compared with an
// independent dense evaluation in double precision; every ISA's kernels side by side.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "common/cpu.hpp"
#include "fixtures.hpp"
#include "gpd/gpd.hpp"
#include "metric/kernels.hpp"
#include "metric/metric.hpp"
#include "io/model_file.hpp"

namespace kata {
namespace {

using Vec = Eigen::VectorXd;

TEST(Metric, NormaliseMatchesDoublePrecision) {
  const metric::Model& model = test::test_model();
  const metric::Metric metric(model);
  std::vector<float> out(gpd::kDims);
  for (int f : {0, 100, 250}) {
    const float* x = test::clip_row("02_01.bvh", f);
    metric.normalise(x, out.data());
    const Vec ref = test::dense_normalised(model, x);
    for (int i = 0; i < gpd::kDims; ++i) ASSERT_NEAR(out[i], ref[i], 1e-6) << f << " " << i;
  }
}

// The product with the W the metric holds (16-bit integers times a column scale) to float
// rounding, and with the model's float W within the bound the quantisation guarantees: every
// weight is within half a step of the model's (plus the float rounding of q * step: 0.51 steps),
// so |du_c| <= 0.51 step_c * sum_i |x''_i|.
TEST(Metric, ProjectionMatchesDenseProduct) {
  const metric::Model& model = test::test_model();
  const metric::Metric metric(model);
  const Eigen::MatrixXd w = test::dense_w(model);
  const std::vector<float> held = metric.weights();
  Eigen::MatrixXd wq(gpd::kDims, model.rank);
  for (int c = 0; c < model.rank; ++c)
    for (int i = 0; i < gpd::kDims; ++i) {
      wq(i, c) = held[static_cast<size_t>(c) * gpd::kDims + i];
      ASSERT_LE(std::abs(wq(i, c) - w(i, c)), 0.51 * metric.weight_step(c)) << i << " " << c;
    }
  auto ws = metric.make_workspace();
  std::vector<float> u(static_cast<size_t>(model.rank));
  for (int f : {3, 200}) {
    const float* x = test::clip_row("05_02.bvh", f);
    metric.project(x, ws, u.data());
    const Vec xn = test::dense_normalised(model, x);
    const Vec ref = wq.transpose() * xn;
    const Vec exact = w.transpose() * xn;
    for (int c = 0; c < model.rank; ++c) {
      ASSERT_NEAR(u[c], ref[c], 2e-6 * ref.norm()) << c;
      ASSERT_NEAR(u[c], exact[c], 0.51 * metric.weight_step(c) * xn.lpNorm<1>() + 2e-6 * ref.norm()) << c;
    }
  }
}

// What the 16-bit W costs the shipped model's verdicts: distances and calibrated scores of real
// student/teacher frame pairs (CMU 05_02 against 02_01 and 02_01 against 07_01), the compiled
// metric against the plain formula with the model's float W in double precision.
TEST(Metric, SixteenBitWeightsKeepTheShippedModelsScores) {
  const metric::Model model = metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata");
  const metric::Metric metric(model);
  const Eigen::MatrixXd w = test::dense_w(model);
  const metric::ScoreCalibration& cal = metric.calibration();
  auto ws = metric.make_workspace();
  std::vector<float> ux(static_cast<size_t>(model.rank)), uy(static_cast<size_t>(model.rank));
  double worst_relative = 0.0, worst_score = 0.0;
  int pairs = 0;
  for (const auto& [student, teacher] : {std::pair<const char*, const char*>{"05_02.bvh", "02_01.bvh"},
                                         {"02_01.bvh", "07_01.bvh"}, {"02_01.bvh", "02_01.bvh"}}) {
    const int sf = test::clip_frames(student), tf = test::clip_frames(teacher);
    for (int k = 0; k < 100; ++k) {
      const int i = 1 + (k * 37) % (sf - 1), j = 1 + (k * 53 + 11) % (tf - 1);
      const float* x = test::clip_row(student, i);
      const float* y = test::clip_row(teacher, j);
      metric.project(x, ws, ux.data());
      metric.project(y, ws, uy.data());
      double d2 = 0.0;
      for (int c = 0; c < model.rank; ++c) d2 += double(ux[c] - uy[c]) * double(ux[c] - uy[c]);
      const double d = std::sqrt(d2);
      const double exact = (w.transpose() * (test::dense_normalised(model, x) - test::dense_normalised(model, y))).norm();
      if (exact > 1e-3) worst_relative = std::max(worst_relative, std::abs(d - exact) / exact);
      worst_score = std::max(worst_score, std::abs(metric::calibrated_score(d, cal.d50, cal.slope) -
                                                   metric::calibrated_score(exact, cal.d50, cal.slope)));
      ++pairs;
    }
  }
  std::printf("  %d frame pairs: largest relative distance error %.2e, largest score difference %.4f points\n", pairs,
              worst_relative, worst_score);
  EXPECT_LT(worst_relative, 1e-3);
  EXPECT_LT(worst_score, 0.05);
}

TEST(Metric, ScoreMapIsCalibratedAndMonotone) {
  EXPECT_DOUBLE_EQ(metric::score_from_distance(0.0, 0.3), 100.0);
  EXPECT_DOUBLE_EQ(metric::score_from_distance(0.3, 0.3), 50.0);
  EXPECT_DOUBLE_EQ(metric::score_from_distance(0.6, 0.3), 20.0);
  double prev = 101.0;
  for (double d = 0.0; d < 5.0; d += 0.01) {
    const double s = metric::score_from_distance(d, 0.3);
    EXPECT_LT(s, prev);
    EXPECT_GT(s, 0.0);
    prev = s;
  }
}

// The weights a pair-packed word stands for, decoded here from the format's definition (kernels.hpp
// BlockedW): the low half as a signed 16-bit integer; the whole word as a signed 32-bit integer,
// rounded to float (what a 32-bit integer to float conversion gives), over 2^16.
double decode_low(uint32_t word) { return static_cast<double>(static_cast<int16_t>(word & 0xFFFFu)); }
double decode_high(uint32_t word) {
  return static_cast<double>(static_cast<float>(static_cast<int32_t>(word))) / 65536.0;
}

// Every word keeps both weights within half a step (plus the 2^-9 step the conversion may round
// a word above 2^24 by) of what was asked, across the whole range, the extremes included.
TEST(Kernels, PairedWordsKeepBothWeightsWithinHalfAStep) {
  const double bound = 0.5 + 1.0 / 512;
  double worst_high = 0.0;
  int n = 0;
  for (double low : {0.0, 0.4, -0.4, 1.5, -1.5, 12345.49, -12345.51, 32767.0, -32767.0, 32766.6, -32766.6})
    for (int k = -400; k <= 400; ++k) {
      const double high = 32767.0 * std::sin(0.731 * k + 0.1) + (k == 0 ? 32767.0 - 32767.0 * std::sin(0.1) : 0.0);
      for (double h : {high, std::round(high), -32767.0, 32767.0, 0.0, 0.49999, -0.5}) {
        const uint32_t word = metric::detail::pack_pair(low, h);
        ASSERT_EQ(decode_low(word), std::nearbyint(low)) << low << " " << h;
        ASSERT_LE(std::abs(decode_high(word) - h), bound) << low << " " << h;
        ASSERT_EQ(metric::detail::pair_low(word), decode_low(word));
        ASSERT_EQ(metric::detail::pair_high(word), decode_high(word));
        worst_high = std::max(worst_high, std::abs(decode_high(word) - h));
        ++n;
      }
    }
  std::printf("  %d words: the high column within %.5f step of its weight\n", n, worst_high);
}

// The AVX2 / AVX-512 and baseline kernels compute the same products (up to float summation order
// and fused multiply-adds), each against the plain formula in double with the weights it holds;
// within one implementation the batched kernel equals the single one bit for bit for every frame
// of batches of 1..2 x kBatch + 1 distinct frames, and writes nothing past the output. Ranks cover
// narrow chunks (< one vector), tails, exact multiples and several chunks. "avx512 pairs" is the
// AVX-512 kernel on the pair-packed W (kernels.hpp BlockedW::pairs) packed from the same integers.
TEST(Kernels, WideKernelsAgreeWithBaseline) {
  if (!cpu_has_avx2()) GTEST_SKIP() << "no AVX2 on this CPU (or KATA_NO_AVX2=1)";
  using Project = void (*)(const metric::detail::BlockedW&, const float*, float*);
  using Batch = void (*)(const metric::detail::BlockedW&, const float* const*, float* const*, int);
  using Normalise = double (*)(const float*, const float*, const float*, int, float*);
  struct Impl {
    const char* name;
    Project project;
    Batch batch;
    Normalise normalise;
    bool pairs;
    double (*dot)(const float*, const float*, int);
  };
  std::vector<Impl> impls = {
      {"base", metric::detail::base::project_groups, metric::detail::base::project_groups_batch,
       metric::detail::base::normalise, false, metric::detail::base::dot},
      {"avx2", metric::detail::avx2::project_groups, metric::detail::avx2::project_groups_batch,
       metric::detail::avx2::normalise, false, metric::detail::avx2::dot}};
  if (cpu_has_avx512()) {
    impls.push_back({"avx512", metric::detail::avx512::project_groups, metric::detail::avx512::project_groups_batch,
                     metric::detail::avx512::normalise, false, metric::detail::avx512::dot});
    impls.push_back({"avx512 pairs", metric::detail::avx512::project_groups,
                     metric::detail::avx512::project_groups_batch, metric::detail::avx512::normalise, true,
                     metric::detail::avx512::dot});
  }
  constexpr int kFrames = 2 * metric::detail::kBatch + 1;
  for (int rank : {50, 8, 3, 1, 12, 20, 31, 33, 64, 70, 97, 130}) {
    // Synthetic W and inputs, three groups (one empty); every implementation called directly.
    std::vector<int> begin = {0, 700, 700, 1683};
    const int groups = static_cast<int>(begin.size()) - 1;
    std::vector<int16_t> w(static_cast<size_t>(gpd::kDims) * rank);
    std::vector<float> scale(static_cast<size_t>(rank));
    for (size_t i = 0; i < w.size(); ++i) w[i] = static_cast<int16_t>(std::lround(32767.0 * std::sin(0.37 * double(i))));
    for (int c = 0; c < rank; ++c) scale[static_cast<size_t>(c)] = 3e-5f * static_cast<float>(1 + c % 3);
    std::vector<double> steps(w.begin(), w.end());
    std::vector<uint32_t> pairs(metric::detail::pair_words_total(gpd::kDims, rank));
    metric::detail::pack_pairs(steps.data(), gpd::kDims, rank, pairs.data());
    const std::vector<int> perm = [] {
      std::vector<int> p(gpd::kDims);
      for (int i = 0; i < gpd::kDims; ++i) p[i] = (i * 7) % gpd::kDims;
      return p;
    }();
    std::vector<float> a(gpd::kDims, 0.1f), b(gpd::kDims, 2.0f);
    std::vector<std::vector<float>> xps(kFrames, std::vector<float>(gpd::kDims));
    std::vector<double> sums(kFrames);
    std::vector<std::vector<float>> xs(kFrames, std::vector<float>(gpd::kDims));
    for (int f = 0; f < kFrames; ++f) {
      for (int i = 0; i < gpd::kDims; ++i) xs[f][i] = static_cast<float>(std::cos(0.11 * i + 0.7 * f));
      sums[f] = metric::detail::base::normalise(xs[f].data(), a.data(), b.data(), gpd::kDims, xps[f].data());
    }
    // The weight of row k, column c, in steps: the integers, or what the word holding them decodes to.
    auto weight = [&](bool paired, int k, int c) {
      const int c0 = c / metric::detail::kChunk * metric::detail::kChunk;
      const int width = std::min(metric::detail::kChunk, rank - c0);
      if (!paired) return double(w[static_cast<size_t>(gpd::kDims) * c0 + static_cast<size_t>(k) * width + (c - c0)]);
      // Word m of row k: the chunk's first block holds words 0..15 of every row, the second the rest.
      const int h = (width + 1) / 2, j = c - c0, m = j < h ? j : j - h;
      const size_t in_chunk = m < 16 ? static_cast<size_t>(k) * std::min(h, 16) + m
                                     : static_cast<size_t>(gpd::kDims) * 16 + static_cast<size_t>(k) * (h - 16) + (m - 16);
      const uint32_t word = pairs[static_cast<size_t>(gpd::kDims) * (c0 / 2) + in_chunk];
      const double q = j < h ? decode_low(word) : decode_high(word);
      EXPECT_LE(std::abs(q - w[static_cast<size_t>(gpd::kDims) * c0 + static_cast<size_t>(k) * width + j]), 0.5 + 1.0 / 512);
      EXPECT_EQ(metric::detail::paired_weight(pairs.data(), gpd::kDims, rank, k, c), static_cast<float>(q));
      return q;
    };
    metric::detail::BlockedW bw;
    bw.data = w.data();
    bw.column_scale = scale.data();
    bw.rows = gpd::kDims;
    bw.rank = rank;
    bw.out_stride = (rank + 7) / 8 * 8;
    bw.groups = groups;
    bw.group_begin = begin.data();
    bw.perm = perm.data();
    const size_t out_size = static_cast<size_t>(groups) * bw.out_stride;
    for (const Impl& impl : impls) {
      bw.pairs = impl.pairs ? pairs.data() : nullptr;
      // The dense product in double, computed independently of the blocked layout, for frame 0.
      std::vector<double> dense(out_size, 0.0);
      for (int g = 0; g < groups; ++g)
        for (int k = begin[g]; k < begin[g + 1]; ++k)
          for (int c = 0; c < rank; ++c)
            dense[static_cast<size_t>(g) * bw.out_stride + c] +=
                weight(impl.pairs, k, c) * double(scale[static_cast<size_t>(c)]) * xps[0][perm[k]];
      std::vector<float> xp2(gpd::kDims);
      const double s = impl.normalise(xs[0].data(), a.data(), b.data(), gpd::kDims, xp2.data());
      EXPECT_EQ(sums[0], s) << impl.name;  // exact products, the same summation order
      ASSERT_EQ(xps[0], xp2) << impl.name;
      // The dot product of two projection rows (padded to a multiple of 8), exact to the last bit
      // on every ISA, and to double rounding against the plain sum.
      {
        const int n = bw.out_stride;
        double plain = 0.0;
        for (int i = 0; i < n; ++i) plain += double(xps[0][i]) * double(xps[1][i + 5]);
        const double d = impl.dot(xps[0].data(), xps[1].data() + 5, n);
        EXPECT_EQ(d, metric::detail::base::dot(xps[0].data(), xps[1].data() + 5, n)) << impl.name;
        EXPECT_NEAR(d, plain, 1e-12 * (1.0 + std::abs(plain))) << impl.name;
      }
      std::vector<std::vector<float>> singles(kFrames, std::vector<float>(out_size + 8, -1.0f));
      for (int f = 0; f < kFrames; ++f) impl.project(bw, xps[f].data(), singles[f].data());
      for (size_t i = 0; i < out_size; ++i)
        ASSERT_NEAR(dense[i], singles[0][i], 1e-4 * (1.0 + std::abs(dense[i])))
            << impl.name << " rank " << rank << " i " << i;
      for (int f = 0; f < kFrames; ++f)
        EXPECT_EQ(singles[f][out_size], -1.0f) << impl.name << " wrote past the output";
      for (int n = 1; n <= kFrames; ++n) {
        std::vector<std::vector<float>> outs(static_cast<size_t>(n), std::vector<float>(out_size + 8, -1.0f));
        std::vector<const float*> in;
        std::vector<float*> vs;
        for (int f = 0; f < n; ++f) in.push_back(xps[(f + n) % kFrames].data());
        for (auto& o : outs) vs.push_back(o.data());
        impl.batch(bw, in.data(), vs.data(), n);
        for (int f = 0; f < n; ++f)
          ASSERT_EQ(outs[static_cast<size_t>(f)], singles[(f + n) % kFrames])
              << impl.name << " rank " << rank << " batch " << n << " frame " << f;
      }
    }
  }
}

}  // namespace
}  // namespace kata
