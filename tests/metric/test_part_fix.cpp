// The part to fix over a whole clip against plain geometry, with the shipped
// model and its maps, through the Scorer a lesson uses:
// - a student made from the teacher's own frames with one part visibly wrong on every frame (an
//   elbow or knee bent 45 degrees more, the head turned on the neck): the part named is that part;
// - real pairs of different subjects shipped in data/cmu (walks of subjects 2 and 7), clip-aligned
//   by the offline DTW: the part with the lowest mean part score is one of the two parts whose
//   joints are farthest from the teacher's in the local frame (mean joint distance, MJD), and never
//   one below the median of the five. The full measurement (22 held-out pairs, 76 training pairs)
//   is docs/model/part_fix.py; these four pairs are its shipped subset;
// - what makes it so (the part distance is taken from the part's own joint positions, metric.hpp
//   kJointRows): a part whose joints did not move gets next to no distance, and over real pairs
//   each part's distance rises and falls with its own joints' distance from the teacher's.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "fixtures.hpp"
#include "io/model_file.hpp"
#include "metric/align_dtw.hpp"
#include "metric/scorer.hpp"
#include "stream/stream.hpp"

namespace kata {
namespace {

using metric::kParts;
constexpr double kFps = 120.0;

const std::shared_ptr<const metric::Metric>& shipped_metric() {
  static const auto m = std::make_shared<const metric::Metric>(
      metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  return m;
}

// GPD joints of each part (parts.hpp): the geometry's grouping.
const std::vector<int> kPartJoints[kParts] = {{0, 1, 2, 3}, {4, 5, 6}, {7, 8, 9}, {10, 11, 12}, {13, 14, 15}};

// Local-frame joint j of a feature row (block Jc: joints 1..15 relative to the hip, yaw removed,
// body heights; the hip itself by its height), as docs/model/part_fix.py reads it.
Eigen::Vector3d local_joint(const float* x, int j) {
  if (j == 0) return Eigen::Vector3d(0.0, x[45], 0.0);
  return Eigen::Vector3d(x[3 * (j - 1)], x[3 * (j - 1) + 1], x[3 * (j - 1) + 2]);
}

// Per part, the mean over the part's joints of the student-teacher joint distance.
void add_geometry(const float* student, const float* teacher, double* mjd) {
  for (int p = 0; p < kParts; ++p) {
    double s = 0.0;
    for (int j : kPartJoints[p]) s += (local_joint(student, j) - local_joint(teacher, j)).norm();
    mjd[p] += s / static_cast<double>(kPartJoints[p].size());
  }
}

std::vector<float> static_features(const float* joints, double height) {
  std::vector<float> x(gpd::kDims), local(3 * gpd::kJoints);
  gpd::GeometryState state;
  float hip = 0.0f;
  gpd::to_local_frame(joints, height, state, local.data(), &hip);
  gpd::static_features(local.data(), hip, state, x.data());
  gpd::kinetics_zero(x.data() + gpd::kOffsetJk);  // teacher and student alike: the pose is what differs
  return x;
}

// Bound of a still part's mean distance over the moved part's (OneWrongPartOverAClipIsNamed).
// Measured: 0.219 / 0.183 / 0.151 / 0.243 / 0.051 (elbows, knees, head); the share split of
// shared dimensions gave 0.432 / 0.466 / 0.543 / 0.483 / 0.938.
constexpr double kCrosstalk = 0.3;
// Least correlation of a part's distance with its joints' distance (PartDistanceFollowsItsJoints).
// Measured: 0.796 / 0.955 / 0.968 / 0.966 / 0.964; the share split: 0.168 (torso) / 0.744 /
// 0.835 / 0.972 / 0.931.
constexpr double kFollows = 0.6;

struct Wrong {
  int part;
  int pivot;               // the joint it turns about
  std::vector<int> moved;  // the joints it carries
  int axis;                // world axis of the turn
};

TEST(PartFix, OneWrongPartOverAClipIsNamed) {
  const auto& metric = shipped_metric();
  const BvhClip clip = load_bvh(test::cmu("07_01.bvh"));
  const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
  Stream stream(stream_config_for(clip.skeleton, map, gpd::Stencil::kBackward));
  const int n = clip.skeleton.joint_count();
  Eigen::MatrixX3d world(n, 3);
  std::vector<float> xyz(3 * static_cast<size_t>(n));
  std::vector<std::vector<float>> joints;  // GPD joints of frames 1.., world
  for (int f = 1; f < clip.frame_count(); ++f) {
    world_positions(clip, f, world);
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) xyz[3 * j + k] = static_cast<float>(world(j, k));
    ASSERT_EQ(stream.push(f / kFps, xyz.data(), n), Status::kOk);
    joints.emplace_back(stream.last_joints(), stream.last_joints() + 3 * gpd::kJoints);
  }
  const double height = stream.body_height();
  const int frames = static_cast<int>(joints.size());
  std::vector<float> teacher;
  for (const auto& j : joints) {
    const std::vector<float> x = static_features(j.data(), height);
    teacher.insert(teacher.end(), x.begin(), x.end());
  }
  const auto ref = std::make_shared<const metric::Reference>(metric, teacher.data(), frames, 1.0 / kFps);
  const Wrong cases[] = {
      {1, 5, {6}, 0},      // left elbow bent 45 degrees more
      {2, 8, {9}, 0},      // right elbow
      {3, 11, {12}, 0},    // left knee
      {4, 14, {15}, 0},    // right knee
      {0, 2, {3}, 2},      // the head turned sideways on the neck
  };
  for (const Wrong& w : cases) {
    const Eigen::Matrix3f r =
        Eigen::AngleAxisf(static_cast<float>(45.0 * M_PI / 180.0), Eigen::Vector3f::Unit(w.axis)).toRotationMatrix();
    metric::Scorer scorer(ref);
    int named[kParts] = {}, scored = 0;
    double total = 0.0, mean_score[kParts] = {}, mjd[kParts] = {}, distance[kParts] = {};
    for (int f = 0; f < frames; ++f) {
      std::vector<float> moved = joints[static_cast<size_t>(f)];
      const Eigen::Vector3f pivot(moved[3 * w.pivot], moved[3 * w.pivot + 1], moved[3 * w.pivot + 2]);
      for (int j : w.moved) {
        Eigen::Map<Eigen::Vector3f> p(moved.data() + 3 * j);
        p = pivot + r * (p - pivot);
      }
      const std::vector<float> student = static_features(moved.data(), height);
      // Matched to its own teacher frame: the truth is known, and it is the attribution under test
      // (the online alignment may settle a walk half a cycle off when an arm is wrong throughout).
      const metric::ScoreRecord& rec = scorer.score_matched(student.data(), f / kFps, f);
      if (rec.state != metric::ScoreState::kScoring) continue;
      ++scored;
      total += rec.score;
      if (rec.part_to_fix >= 0) ++named[rec.part_to_fix];
      for (int q = 0; q < kParts; ++q) mean_score[q] += rec.part_scores[q], distance[q] += rec.part_distance[q];
      add_geometry(student.data(), teacher.data() + static_cast<size_t>(rec.matched) * gpd::kDims, mjd);
    }
    ASSERT_GT(scored, frames / 2);
    // The parts that did not move: their distance is what the unit length of x'' passes on (every
    // coordinate is divided by the whole vector's length, which the moved part changes). A split
    // that shares the distances and angles between parts gives them far more.
    double crosstalk = 0.0;
    for (int q = 0; q < kParts; ++q)
      if (q != w.part) crosstalk = std::max(crosstalk, distance[q] / distance[w.part]);
    std::printf("%-10s wrong: largest distance of a part that did not move, over the moved part's: %.3f\n",
                metric::part_name(w.part), crosstalk);
    EXPECT_LT(crosstalk, kCrosstalk) << metric::part_name(w.part);
    const int most_named = static_cast<int>(std::max_element(named, named + kParts) - named);
    const int lowest = static_cast<int>(std::min_element(mean_score, mean_score + kParts) - mean_score);
    const int farthest = static_cast<int>(std::max_element(mjd, mjd + kParts) - mjd);
    std::printf("%-10s wrong: mean score %.1f (its part %.1f), named on %d of %d scoring frames (%d / %d / %d / %d / "
                "%d), lowest mean part %s, largest MJD %s\n",
                metric::part_name(w.part), total / scored, mean_score[w.part] / scored, named[w.part], scored,
                named[0], named[1], named[2], named[3], named[4], metric::part_name(lowest), metric::part_name(farthest));
    EXPECT_EQ(farthest, w.part) << "the construction: only this part's joints moved";
    EXPECT_EQ(lowest, w.part) << metric::part_name(w.part);
    // Every frame named names this part.
    EXPECT_EQ(named[w.part], std::accumulate(named, named + kParts, 0)) << metric::part_name(w.part);
    if (w.part != 0) {
      // A wrong arm or leg is named, and not only now and then: the arms by the total (their own
      // maps keep a 45-degree elbow at 81-85), the legs by their own score (50-68) though the
      // total stays at 93-97: a good total must not hide a wrong knee.
      EXPECT_EQ(most_named, w.part) << metric::part_name(w.part);
      EXPECT_GE(named[w.part], 0.5 * scored) << metric::part_name(w.part);
    }
  }
}

// One real pair, clip-aligned by the offline reference (kata score --align dtw), as part_fix.py
// does: per scoring frame, the part distances, part scores and the local-frame MJD of each part.
struct PairFrames {
  std::vector<std::array<double, kParts>> distance, score, mjd;
  int shown[kParts] = {};  // scoring frames naming each part (the part to fix, after its hysteresis)
};

PairFrames score_pair(const char* teacher_clip, const char* student_clip) {
  const auto& metric = shipped_metric();
  const int stride = metric->stride();
  const auto& teacher = test::clip_rows(teacher_clip);
  const auto& student = test::clip_rows(student_clip);
  const auto ref = std::make_shared<const metric::Reference>(metric, teacher.data(), test::clip_frames(teacher_clip), 1.0 / kFps);
  const int n = test::clip_frames(student_clip);
  std::vector<float> rows(static_cast<size_t>(n) * stride);
  metric::AlignedFloats proj(static_cast<size_t>(metric::kProjectionRows) * stride);
  metric::Metric::Workspace ws = metric->make_workspace();
  for (int i = 0; i < n; ++i) {
    metric->part_projections(student.data() + static_cast<size_t>(i) * gpd::kDims, ws, proj.data());
    const float* row = proj.data() + static_cast<size_t>(metric::kStaticRow) * stride;
    std::copy(row, row + stride, rows.data() + static_cast<size_t>(i) * stride);
  }
  const std::vector<int> dtw = metric::subsequence_dtw(*ref, rows.data(), n);
  metric::Scorer scorer(ref);
  PairFrames out;
  for (int i = 0; i < n; ++i) {
    const float* x = student.data() + static_cast<size_t>(i) * gpd::kDims;
    const metric::ScoreRecord& rec = scorer.score_matched(x, i / kFps, dtw[static_cast<size_t>(i)]);
    if (rec.state != metric::ScoreState::kScoring) continue;
    std::array<double, kParts> d{}, sc{}, g{};
    for (int q = 0; q < kParts; ++q) d[q] = rec.part_distance[q], sc[q] = rec.part_scores[q];
    add_geometry(x, teacher.data() + static_cast<size_t>(rec.matched) * gpd::kDims, g.data());
    out.distance.push_back(d), out.score.push_back(sc), out.mjd.push_back(g);
    if (rec.part_to_fix >= 0) ++out.shown[rec.part_to_fix];
  }
  EXPECT_GT(out.score.size(), static_cast<size_t>(n / 2)) << teacher_clip << " <- " << student_clip;
  return out;
}

const char* const kShippedPairs[][2] = {{"02_01.bvh", "07_01.bvh"}, {"07_01.bvh", "02_01.bvh"},
                                        {"02_02.bvh", "07_01.bvh"}, {"07_01.bvh", "02_02.bvh"}};

TEST(PartFix, AgreesWithGeometryOnShippedPairsOfDifferentSubjects) {
  int in_top2 = 0, below_median = 0;
  for (const auto& p : kShippedPairs) {
    const PairFrames f = score_pair(p[0], p[1]);
    double mean_score[kParts] = {}, mjd[kParts] = {};
    for (size_t i = 0; i < f.score.size(); ++i)
      for (int q = 0; q < kParts; ++q) mean_score[q] += f.score[i][q], mjd[q] += f.mjd[i][q];
    const double scored = static_cast<double>(f.score.size());
    // The product's answer over the pair: the part named as the part to fix on the most frames.
    const int named = static_cast<int>(std::max_element(f.shown, f.shown + kParts) - f.shown);
    int order[kParts] = {0, 1, 2, 3, 4};
    std::sort(order, order + kParts, [&](int a, int b) { return mjd[a] > mjd[b]; });
    const bool top2 = named == order[0] || named == order[1];
    const bool below = named == order[3] || named == order[4];  // below the median (order[2])
    in_top2 += top2, below_median += below;
    std::printf("%s <- %s: MJD x1000 %.1f %.1f %.1f %.1f %.1f, geometry top 2 %s %s, named %s%s\n", p[0], p[1],
                1000 * mjd[0] / scored, 1000 * mjd[1] / scored, 1000 * mjd[2] / scored, 1000 * mjd[3] / scored,
                1000 * mjd[4] / scored, metric::part_name(order[0]), metric::part_name(order[1]),
                metric::part_name(named), top2 ? "" : below ? " (BELOW THE MEDIAN)" : " (3rd)");
  }
  // Measured with the shipped model: see the printout; docs/model/part_fix.py measures the 98
  // pairs of every subject (the part named on the most frames in geometry's top 2: 85 of 98, issue
  // 34's 85 %). On these four pairs the parts' MJD differ by 10-20 % (the printout), so geometry's
  // order is close to a tie. Now 3 of 4 in the top 2 and none below the median; with the band
  // below good within 20 points and a 0.5 s hold (until 2026-12-04 evening) 2 of 4, and 02_02 <-
  // 07_01 named the right arm, geometry's 4th; the wider band and the shorter hold name its left
  // arm (scorer.cpp update_part_to_fix, docs/model/scores.md "The part to fix").
  EXPECT_GE(in_top2, 3);
  EXPECT_EQ(below_median, 0);
}

TEST(PartFix, PartDistanceFollowsItsJoints) {
  // Per part, over the scoring frames of the four pairs pooled: the correlation between the
  // part's distance and its joints' local-frame distance from the teacher's (MJD).
  std::vector<std::array<double, kParts>> d, g;
  for (const auto& p : kShippedPairs) {
    const PairFrames f = score_pair(p[0], p[1]);
    d.insert(d.end(), f.distance.begin(), f.distance.end());
    g.insert(g.end(), f.mjd.begin(), f.mjd.end());
  }
  const double n = static_cast<double>(d.size());
  for (int q = 0; q < kParts; ++q) {
    double sd = 0, sg = 0, sdd = 0, sgg = 0, sdg = 0;
    for (size_t i = 0; i < d.size(); ++i) {
      sd += d[i][q], sg += g[i][q], sdd += d[i][q] * d[i][q], sgg += g[i][q] * g[i][q], sdg += d[i][q] * g[i][q];
    }
    const double r = (sdg - sd * sg / n) / std::sqrt((sdd - sd * sd / n) * (sgg - sg * sg / n));
    std::printf("%-10s distance vs MJD over %zu frames: r = %.3f\n", metric::part_name(q), d.size(), r);
    EXPECT_GE(r, kFollows) << metric::part_name(q);
  }
}

}  // namespace
}  // namespace kata
