// The compiled metric: normalisation, projection and the score map, each compared with an
// independent dense evaluation in double precision; the AVX2 and baseline kernels side by side.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "common/cpu.hpp"
#include "fixtures.hpp"
#include "gpd/gpd.hpp"
#include "metric/kernels.hpp"
#include "metric/metric.hpp"

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

TEST(Metric, ProjectionMatchesDenseProduct) {
  const metric::Model& model = test::test_model();
  const metric::Metric metric(model);
  const Eigen::MatrixXd w = test::dense_w(model);
  auto ws = metric.make_workspace();
  std::vector<float> u(static_cast<size_t>(model.rank));
  for (int f : {3, 200}) {
    const float* x = test::clip_row("05_02.bvh", f);
    metric.project(x, ws, u.data());
    const Vec ref = w.transpose() * test::dense_normalised(model, x);
    for (int c = 0; c < model.rank; ++c) ASSERT_NEAR(u[c], ref[c], 2e-6 * ref.norm()) << c;
  }
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

// The AVX2 and baseline kernels compute the same products (up to float summation order).
TEST(Kernels, Avx2AndBaselineAgree) {
  if (!cpu_has_avx2()) GTEST_SKIP() << "no AVX2 on this CPU (or KATA_NO_AVX2=1)";
  for (int rank : {50, 8, 3, 12, 20, 64, 70, 130}) {
    // Synthetic W and input, two groups; both implementations called directly.
    std::vector<int> begin = {0, 700, 1683};
    std::vector<float> w(static_cast<size_t>(gpd::kDims) * rank), xp(gpd::kDims), x(gpd::kDims);
    for (size_t i = 0; i < w.size(); ++i) w[i] = static_cast<float>(std::sin(0.37 * double(i)));
    const std::vector<int> perm = [] {
      std::vector<int> p(gpd::kDims);
      for (int i = 0; i < gpd::kDims; ++i) p[i] = (i * 7) % gpd::kDims;
      return p;
    }();
    std::vector<float> a(gpd::kDims, 0.1f), b(gpd::kDims, 2.0f);
    for (int i = 0; i < gpd::kDims; ++i) x[i] = static_cast<float>(std::cos(0.11 * i));
    metric::detail::BlockedW bw;
    bw.data = w.data();
    bw.rows = gpd::kDims;
    bw.rank = rank;
    bw.out_stride = (rank + 7) / 8 * 8;
    bw.groups = 2;
    bw.group_begin = begin.data();
    bw.perm = perm.data();
    std::vector<float> xp2(gpd::kDims);
    const double s1 = metric::detail::base::normalise(x.data(), a.data(), b.data(), gpd::kDims, xp.data());
    const double s2 = metric::detail::avx2::normalise(x.data(), a.data(), b.data(), gpd::kDims, xp2.data());
    EXPECT_NEAR(s1, s2, 1e-9 * s1);
    ASSERT_EQ(xp, xp2);
    std::vector<float> v1(2 * bw.out_stride + 8, -1.0f), v2(v1), v3(v1), v4(v1);
    metric::detail::base::project_groups(bw, xp.data(), v1.data());
    metric::detail::avx2::project_groups(bw, xp.data(), v2.data());
    const float* xps[3] = {xp.data(), xp.data(), xp.data()};
    float* vs[3] = {v3.data(), v4.data(), v4.data()};
    metric::detail::avx2::project_groups_batch(bw, xps, vs, 2);
    for (size_t i = 0; i < 2u * bw.out_stride; ++i) {
      const float tol = 1e-4f * (1.0f + std::abs(v1[i]));
      ASSERT_NEAR(v1[i], v2[i], tol) << "rank " << rank << " i " << i;
      ASSERT_EQ(v2[i], v3[i]) << "rank " << rank << " i " << i;
    }
    EXPECT_EQ(v2[2 * bw.out_stride], -1.0f) << "wrote past the output";
    EXPECT_EQ(v3[2 * bw.out_stride], -1.0f) << "batched kernel wrote past the output";
  }
}

}  // namespace
}  // namespace kata
