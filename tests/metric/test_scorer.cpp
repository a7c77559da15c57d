// Scoring against a pose reference: distance, score and the per-part breakdown, each compared
// with an independent dense evaluation in double precision; batching and allocation.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <cstdlib>

#include <Eigen/Dense>

#include "support/alloc_counter.hpp"
#include "fixtures.hpp"
#include "gpd/gpd.hpp"
#include "metric/parts.hpp"
#include "metric/scorer.hpp"

namespace kata {
namespace {

using metric::kParts;
using Vec = Eigen::VectorXd;

// What the Reference's 16-bit rows may move a score row by (reference.hpp): each kept value is
// within half its row's step (the row's largest |value| / 32767) of the projection's float, plus
// the float roundings of decoding it and subtracting it (2^-23 of the row's largest at most, 0.4 %
// of a step), and a difference within 0.51 steps is taken as 0: at most 1.02 steps in all. The
// teacher's float projection of pose y, row by row.
struct HeldRows {
  double step[metric::kProjectionRows] = {};  // per row; 0 for the static row (not kept this way)
  int rank = 0;
  // Largest change of u = sum of the part rows (its Euclidean norm), and of part row q's norm.
  double u_bound() const {
    double per_column = 0.0;
    for (int q = 0; q < kParts; ++q) per_column += 1.02 * step[q];
    return std::sqrt(static_cast<double>(rank)) * per_column;
  }
  double row_bound(int r) const { return std::sqrt(static_cast<double>(rank)) * 1.02 * step[r]; }
};
HeldRows held_rows(const metric::Metric& m, const float* y) {
  metric::Metric::Workspace ws = m.make_workspace();
  std::vector<float> p(static_cast<size_t>(metric::kProjectionRows) * m.stride());
  m.part_projections(y, ws, p.data());
  HeldRows h;
  h.rank = m.rank();
  for (int r = 0; r < metric::kProjectionRows; ++r) {
    if (r == metric::kStaticRow) continue;
    float largest = 0.0f;
    for (int c = 0; c < m.rank(); ++c) largest = std::max(largest, std::fabs(p[static_cast<size_t>(r) * m.stride() + c]));
    h.step[r] = largest / 32767.0;
  }
  return h;
}

// d and the five parts vs the dense quadratic form e^T W W^T e, with M formed explicitly.
TEST(Scorer, DistanceAndPartsMatchDenseQuadraticForm) {
  const metric::Model& model = test::test_model();
  const auto metric = std::make_shared<const metric::Metric>(model);
  const Eigen::MatrixXd w = test::dense_w(model);
  const Eigen::MatrixXd M = w * w.transpose();
  // The W this CPU's kernels hold (16-bit integers, or the AVX-512 kernels' pair-packed words):
  // within half a step of the model's, so d^2 through it is what the parts must add up to, to
  // float rounding; d against the model's own W is bounded by that quantisation instead.
  const std::vector<float> held = metric->weights();
  const Eigen::MatrixXd wh = Eigen::Map<const Eigen::MatrixXf>(held.data(), gpd::kDims, model.rank).cast<double>();
  const auto& parts = metric::dimension_parts();
  struct Pair {
    const char* teacher;
    int tf;
    const char* student;
    int sf;
  };
  // Far apart poses, nearby frames (small d: cancellation), and another subject's clip.
  const Pair pairs[] = {{"02_01.bvh", 10, "02_01.bvh", 150}, {"02_01.bvh", 100, "02_01.bvh", 103},
                        {"05_02.bvh", 400, "02_01.bvh", 40}, {"05_02.bvh", 10, "05_02.bvh", 900},
                        {"02_01.bvh", 50, "02_02.bvh", 50}};
  for (const Pair& p : pairs) {
    const float* y = test::clip_row(p.teacher, p.tf);
    const float* x = test::clip_row(p.student, p.sf);
    metric::Scorer scorer(std::make_shared<const metric::Reference>(metric, y));
    const metric::ScoreRecord& r = scorer.score(x, 0.0);

    const Vec e = test::dense_normalised(model, x) - test::dense_normalised(model, y);
    const Vec me = M * e;
    const double d2 = e.dot(me);
    const double d = std::sqrt(d2);
    SCOPED_TRACE(std::string(p.teacher) + ":" + std::to_string(p.tf) + " vs " + p.student + ":" + std::to_string(p.sf) +
                 " d=" + std::to_string(d));
    // The float path's rounding (1e-5 of d, as before the 16-bit rows) plus the rows' bound.
    const HeldRows rows = held_rows(*metric, y);
    EXPECT_NEAR(r.distance, d, 1e-5 * d + rows.u_bound());
    EXPECT_NEAR(r.model_score, 100.0 / (1.0 + (d / model.delta_star) * (d / model.delta_star)), 1e-3);
    // The coaching total: never above the model's map nor the worst part (scorer.hpp).
    float worst = 100.0f;
    for (int q = 0; q < kParts; ++q) worst = std::min(worst, r.part_scores[q]);
    EXPECT_EQ(r.score, std::min(r.model_score, worst));

    double dense_parts[kParts] = {};
    for (int i = 0; i < gpd::kDims; ++i) {
      const int count = __builtin_popcount(parts[i]);
      for (int q = 0; q < kParts; ++q)
        if (parts[i] & (1 << q)) dense_parts[q] += e[i] * me[i] / count;
    }
    // part q = u . D_q: held rows move it by at most |du| |D_q| + |u| |dD_q| + |du| |dD_q|, with
    // u and D_q = W^T (share_q o e) from the held W.
    const Vec u = wh.transpose() * e;
    double sum = 0.0, sum_bound = 0.0;
    for (int q = 0; q < kParts; ++q) {
      Vec share_e = Vec::Zero(gpd::kDims);
      for (int i = 0; i < gpd::kDims; ++i)
        if (parts[i] & (1 << q)) share_e[i] = e[i] / __builtin_popcount(parts[i]);
      const double dq = (wh.transpose() * share_e).norm();
      const double bound = rows.u_bound() * dq + u.norm() * rows.row_bound(q) + rows.u_bound() * rows.row_bound(q);
      EXPECT_NEAR(r.parts[q], dense_parts[q], 2e-5 * d2 + bound) << metric::part_name(q);
      sum += r.parts[q];
      sum_bound += bound;
    }
    const double d2_held = (wh.transpose() * e).squaredNorm();
    EXPECT_NEAR(sum, d2_held, 1e-5 * d2_held + sum_bound);
    // The bound itself is small beside the distances that matter: under 1 % of delta*, the
    // distance that scores 50.
    EXPECT_LT(rows.u_bound(), 0.01 * model.delta_star);
  }
}

TEST(Scorer, IdenticalPoseScoresHundred) {
  const auto metric = test::test_metric();
  for (int f : {1, 77, 300}) {
    const float* x = test::clip_row("02_01.bvh", f);
    metric::Scorer scorer(std::make_shared<const metric::Reference>(metric, x));
    const metric::ScoreRecord& r = scorer.score(x, 1.0);
    // Exactly, though the teacher's rows are 16-bit (differences within their rounding are 0).
    EXPECT_EQ(r.distance, 0.0f);
    EXPECT_EQ(r.score, 100.0f);
    for (float part : r.parts) EXPECT_EQ(part, 0.0f);
    for (float part : r.part_distance) EXPECT_EQ(part, 0.0f);
    EXPECT_EQ(r.matched, 0);
  }
}

// The 16 GPD joints of a BVH frame (world, file units) and the clip's rest body height.
struct Pose {
  std::vector<float> joints;
  double height = 0.0;
};
Pose bvh_pose(const std::string& name, int frame) {
  const BvhClip clip = load_bvh(test::cmu(name));
  const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
  Eigen::MatrixX3d world(clip.skeleton.joint_count(), 3);
  world_positions(clip, frame, world);
  Pose p;
  for (int j = 0; j < gpd::kJoints; ++j)
    for (int k = 0; k < 3; ++k) p.joints.push_back(static_cast<float>(world(map.source[j], k)));
  p.height = rest_body_height(clip.skeleton, map);
  return p;
}

// Features of a held pose, computed the way Reference::from_joints documents (kinetics zero).
std::vector<float> pose_features(const Pose& p) {
  std::vector<float> x(gpd::kDims), local(48);
  gpd::GeometryState state;
  float hip = 0.0f;
  gpd::to_local_frame(p.joints.data(), p.height, state, local.data(), &hip);
  gpd::static_features(local.data(), hip, state, x.data());
  gpd::kinetics_zero(x.data() + gpd::kOffsetJk);
  return x;
}

// Rotates joints `moved` about the vertical axis through joint `pivot` by `deg` degrees.
void swing(Pose& p, std::initializer_list<int> moved, int pivot, double deg) {
  const double a = deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
  const float px = p.joints[3 * pivot], pz = p.joints[3 * pivot + 2];
  for (int j : moved) {
    const double x = p.joints[3 * j] - px, z = p.joints[3 * j + 2] - pz;
    p.joints[3 * j] = static_cast<float>(px + c * x - s * z);
    p.joints[3 * j + 2] = static_cast<float>(pz + s * x + c * z);
  }
}

TEST(Scorer, MovingOnlyTheLeftArmBlamesTheLeftArm) {
  const auto metric = test::test_metric();
  for (int frame : {40, 200}) {
    const Pose teacher = bvh_pose("02_01.bvh", frame);
    const auto ref = std::make_shared<const metric::Reference>(
        metric::Reference::from_joints(metric, teacher.joints.data(), teacher.height));
    metric::Scorer scorer(ref);
    // The teacher's own pose through the same feature path scores 100.
    EXPECT_EQ(scorer.score(pose_features(teacher).data(), 0.0).distance, 0.0f);

    Pose student = teacher;
    swing(student, {5, 6}, 4, 40.0);  // left elbow and hand swung about the left shoulder
    const metric::ScoreRecord r = scorer.score(pose_features(student).data(), 0.1);
    SCOPED_TRACE("frame " + std::to_string(frame));
    EXPECT_GT(r.distance, 0.0f);
    EXPECT_LT(r.score, 100.0f);
    for (int q = 0; q < kParts; ++q)
      if (q != static_cast<int>(metric::Part::kLeftArm)) {
        EXPECT_GT(r.parts[1], r.parts[q]) << metric::part_name(q);
      }
    EXPECT_GT(r.parts[1], 0.35 * r.distance * r.distance);  // and a large share of d^2

    // Symmetric check on the right leg.
    Pose kick = teacher;
    swing(kick, {14, 15}, 13, 40.0);
    const metric::ScoreRecord k = scorer.score(pose_features(kick).data(), 0.2);
    for (int q = 0; q < kParts; ++q)
      if (q != static_cast<int>(metric::Part::kRightLeg)) {
        EXPECT_GT(k.parts[4], k.parts[q]) << metric::part_name(q);
      }
  }
}

TEST(Scorer, BatchEqualsSingleBitForBit) {
  const auto metric = test::test_metric();
  const auto ref = std::make_shared<const metric::Reference>(metric, test::clip_row("02_01.bvh", 20));
  constexpr int n = 2 * metric::detail::kBatch + 3;  // two kBatch groups and a remainder
  std::vector<std::unique_ptr<metric::Scorer>> batch, single;
  std::vector<metric::Scorer*> ptrs;
  std::vector<const float*> xs;
  std::vector<double> ts;
  for (int s = 0; s < n; ++s) {
    batch.push_back(std::make_unique<metric::Scorer>(ref));
    single.push_back(std::make_unique<metric::Scorer>(ref));
    ptrs.push_back(batch.back().get());
    xs.push_back(test::clip_row("05_02.bvh", 30 * s + 5));
    ts.push_back(0.5 * s);
  }
  metric::Scorer::score_batch(ptrs.data(), xs.data(), ts.data(), n);
  for (int s = 0; s < n; ++s) {
    const metric::ScoreRecord& a = batch[s]->last();
    const metric::ScoreRecord& b = single[s]->score(xs[s], ts[s]);
    EXPECT_EQ(a.distance, b.distance) << s;
    EXPECT_EQ(a.score, b.score) << s;
    EXPECT_EQ(a.time, b.time) << s;
    for (int q = 0; q < kParts; ++q) EXPECT_EQ(a.parts[q], b.parts[q]) << s;
  }
}

TEST(Scorer, ScoringAllocatesNothing) {
  const auto metric = test::test_metric();
  std::vector<float> clip(test::clip_rows("02_01.bvh").begin(), test::clip_rows("02_01.bvh").begin() + 100 * gpd::kDims);
  const auto pose = std::make_shared<const metric::Reference>(metric, clip.data());
  const auto seq = std::make_shared<const metric::Reference>(metric, clip.data(), 100, 1.0 / 120);
  metric::Scorer a(pose), b(seq), c(pose);
  metric::Scorer* both[2] = {&a, &c};
  const float* xs[2] = {clip.data(), clip.data() + gpd::kDims};
  const double ts[2] = {0.0, 0.0};
  test::arm_alloc_counter();
  for (int f = 0; f < 50; ++f) {
    a.score(clip.data() + static_cast<size_t>(f) * gpd::kDims, f / 120.0);
    b.score(clip.data() + static_cast<size_t>(f) * gpd::kDims, f / 120.0);
    metric::Scorer::score_batch(both, xs, ts, 2);
  }
  EXPECT_EQ(test::disarm_alloc_counter(), 0);
}

}  // namespace
}  // namespace kata
