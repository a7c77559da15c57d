// The per-stream pipeline: every emitted vector scored and ghosted in its push, whatever the
// reader's rate; each result equal to the stages run by hand (the scorer on the same features,
// a separately created retargeter on the same matched teacher frames); no allocation per push.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "io/model_file.hpp"
#include "metric/scorer.hpp"
#include "pipeline/pipeline.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/retargeter.hpp"
#include "support/alloc_counter.hpp"
#include "support/clips.hpp"

namespace kata {
namespace {

constexpr int kFrames = 120;

std::shared_ptr<const metric::Metric> shipped_metric() {
  static const auto m =
      std::make_shared<const metric::Metric>(metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  return m;
}


pipeline::PipelineConfig student_config(const BvhClip& student, const GpdMap& map, int capacity) {
  pipeline::PipelineConfig pc;
  pc.stream = stream_config_for(student.skeleton, map, gpd::Stencil::kBackward);
  pc.student = student.skeleton;
  pc.result_capacity = capacity;
  return pc;
}

std::shared_ptr<const pipeline::Teacher> teacher_02_01() {
  const BvhClip& t = test::clip("02_01");
  const std::vector<float>& pos = test::clip_positions("02_01", 1);
  const int frames = t.frame_count() - 1;
  return pipeline::Teacher::from_positions(
      shipped_metric(), t.skeleton,
      stream_config_for(t.skeleton, make_gpd_map(t.skeleton, preset_joint_names("cmu")), gpd::Stencil::kBackward),
      pos.data(), frames, t.frame_time);
}

double student_height(const BvhClip& c) {
  return rest_body_height(c.skeleton, make_gpd_map(c.skeleton, preset_joint_names("cmu")));
}

TEST(Pipeline, EveryPushedFrameIsScoredWhenReadEveryFourthPush) {
  const BvhClip& student = test::clip("07_01");
  const GpdMap map = make_gpd_map(student.skeleton, preset_joint_names("cmu"));
  pipeline::Pipeline p(student_config(student, map, 64));
  const auto teacher = teacher_02_01();
  p.set_teacher(teacher);
  ASSERT_TRUE(p.has_ghost());

  const std::vector<float>& pos = test::clip_positions("07_01", 1);
  const size_t per_frame = 3 * static_cast<size_t>(student.skeleton.joint_count());
  std::vector<pipeline::Result> got;
  std::vector<float> ghosts;
  std::vector<pipeline::Result> batch(64);
  std::vector<float> batch_ghosts(64 * static_cast<size_t>(p.ghost_joint_count()) * 3);
  auto drain = [&] {
    const size_t n = p.read(batch.data(), batch_ghosts.data(), nullptr, batch.size());
    got.insert(got.end(), batch.begin(), batch.begin() + static_cast<long>(n));
    ghosts.insert(ghosts.end(), batch_ghosts.begin(),
                  batch_ghosts.begin() + static_cast<long>(n * 3 * static_cast<size_t>(p.ghost_joint_count())));
  };
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_EQ(p.push(i * student.frame_time, pos.data() + static_cast<size_t>(i) * per_frame,
                     student.skeleton.joint_count()),
              Status::kOk);
    if (i % 4 == 3) drain();
  }
  drain();
  ASSERT_EQ(got.size(), static_cast<size_t>(kFrames));
  EXPECT_EQ(p.dropped(), 0u);

  // Reference loop: the C++ scorer on the same features, every frame, in order.
  metric::Scorer scorer(teacher->reference);
  const std::vector<float>& feats = test::clip_features("07_01", gpd::Stencil::kBackward, 1);
  for (int i = 0; i < kFrames; ++i) {
    const pipeline::Result& r = got[static_cast<size_t>(i)];
    const metric::ScoreRecord& want = scorer.score(feats.data() + static_cast<size_t>(i) * gpd::kDims,
                                                   i * student.frame_time);
    EXPECT_EQ(r.sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(r.frame_index, i);
    EXPECT_DOUBLE_EQ(r.capture_time, i * student.frame_time);
    ASSERT_TRUE(r.scored);
    EXPECT_EQ(r.score.distance, want.distance) << "frame " << i;
    for (int q = 0; q < metric::kParts; ++q) EXPECT_EQ(r.score.parts[q], want.parts[q]) << "frame " << i;
    EXPECT_EQ(r.matched_frame, want.matched) << "frame " << i;
    EXPECT_LE(r.arrival_ns, r.computed_ns);
    EXPECT_TRUE(r.has_ghost);
  }

  // Ghosts: a separately created retargeter solves the same matched teacher frames in order and
  // the result is placed over the student's frame.
  const retarget::JointSelection sel = retarget::select_joints(teacher->skeleton, student.skeleton, "cmu");
  retarget::Retargeter rt(sel.parents, retarget::selected_rest_lengths(student.skeleton, sel), {},
                          retarget::selected_rest_directions(student.skeleton, sel));
  const size_t g = sel.source.size();
  ASSERT_EQ(static_cast<size_t>(p.ghost_joint_count()), g);
  std::vector<double> t(3 * g), s(3 * g), ghost(3 * g);
  const double tolerance = 1e-5 * student_height(student);
  double worst = 0.0;
  for (int i = 0; i < kFrames; ++i) {
    const float* tf = teacher->frame_positions(got[static_cast<size_t>(i)].matched_frame);
    const float* sf = pos.data() + static_cast<size_t>(i) * per_frame;
    for (size_t j = 0; j < g; ++j)
      for (int c = 0; c < 3; ++c) {
        t[3 * j + c] = tf[3 * static_cast<size_t>(sel.source[j]) + c];
        s[3 * j + c] = sf[3 * static_cast<size_t>(sel.source[j]) + c];
      }
    rt.retarget(t.data(), ghost.data());
    retarget::place_over_student(static_cast<int>(g), s.data(), ghost.data());
    for (size_t k = 0; k < 3 * g; ++k)
      worst = std::max(worst, std::abs(ghost[k] - ghosts[static_cast<size_t>(i) * 3 * g + k]));
  }
  EXPECT_LE(worst, tolerance) << "largest ghost coordinate difference";
}

TEST(Pipeline, AFullRingDropsTheOldestAndCountsIt) {
  const BvhClip& student = test::clip("07_01");
  const GpdMap map = make_gpd_map(student.skeleton, preset_joint_names("cmu"));
  pipeline::Pipeline p(student_config(student, map, 8));
  const std::vector<float>& pos = test::clip_positions("07_01", 1);
  const size_t per_frame = 3 * static_cast<size_t>(student.skeleton.joint_count());
  for (int i = 0; i < 20; ++i)
    ASSERT_EQ(p.push(i * student.frame_time, pos.data() + static_cast<size_t>(i) * per_frame,
                     student.skeleton.joint_count()),
              Status::kOk);
  EXPECT_EQ(p.pending(), 8u);
  EXPECT_EQ(p.dropped(), 12u);
  std::vector<pipeline::Result> out(32);
  ASSERT_EQ(p.read(out.data(), nullptr, nullptr, out.size()), 8u);
  for (int k = 0; k < 8; ++k) EXPECT_EQ(out[static_cast<size_t>(k)].sequence, static_cast<uint64_t>(12 + k));
  EXPECT_FALSE(out[0].scored);  // no teacher: features only
  EXPECT_EQ(p.read(out.data(), nullptr, nullptr, out.size()), 0u);
}

TEST(Pipeline, CalibrationEmitsEveryHeldFrameAsItsOwnResult) {
  // A bare live source (no rest pose): H comes from the first 8 frames, held until then; the
  // push that completes calibration emits all 8, each becomes a result.
  const BvhClip& student = test::clip("07_01");
  pipeline::PipelineConfig pc;
  pc.stream.map = make_gpd_map(student.skeleton, preset_joint_names("cmu"));
  pc.stream.input_joints = student.skeleton.joint_count();
  pc.stream.calibration_frames = 8;
  pc.student = student.skeleton;
  pc.student.has_rest_pose = false;
  pipeline::Pipeline p(pc);
  p.set_teacher(teacher_02_01());
  EXPECT_FALSE(p.has_ghost());  // no bone lengths, no ghost
  const std::vector<float>& pos = test::clip_positions("07_01", 1);
  const size_t per_frame = 3 * static_cast<size_t>(student.skeleton.joint_count());
  for (int i = 0; i < 7; ++i)
    ASSERT_EQ(p.push(i / 120.0, pos.data() + static_cast<size_t>(i) * per_frame, pc.stream.input_joints), Status::kOk);
  EXPECT_EQ(p.pending(), 0u);
  ASSERT_EQ(p.push(7 / 120.0, pos.data() + 7 * per_frame, pc.stream.input_joints), Status::kOk);
  ASSERT_EQ(p.pending(), 8u);
  std::vector<pipeline::Result> out(8);
  ASSERT_EQ(p.read(out.data(), nullptr, nullptr, 8), 8u);
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(out[static_cast<size_t>(k)].frame_index, k);
    EXPECT_TRUE(out[static_cast<size_t>(k)].scored);
    EXPECT_FALSE(out[static_cast<size_t>(k)].has_ghost);
  }
}

TEST(Pipeline, ARefusedFrameChangesNothing) {
  const BvhClip& student = test::clip("07_01");
  pipeline::Pipeline p(student_config(student, make_gpd_map(student.skeleton, preset_joint_names("cmu")), 16));
  p.set_teacher(teacher_02_01());
  const std::vector<float>& pos = test::clip_positions("07_01", 1);
  const int n = student.skeleton.joint_count();
  ASSERT_EQ(p.push(0.0, pos.data(), n), Status::kOk);
  std::vector<float> bad(pos.begin(), pos.begin() + 3 * n);
  bad[4] = std::nanf("");
  EXPECT_EQ(p.push(0.01, bad.data(), n), Status::kNonFinite);
  EXPECT_EQ(p.push(0.0, pos.data(), n), Status::kTimestampNotIncreasing);
  EXPECT_EQ(p.push(0.01, pos.data(), n - 1), Status::kWrongJointCount);
  EXPECT_EQ(p.pending(), 1u);
  EXPECT_EQ(p.push(0.01, pos.data() + 3 * n, n), Status::kOk);
  EXPECT_EQ(p.pending(), 2u);
}

TEST(Pipeline, TheWholePushAllocatesNothingAfterOpen) {
  if (!test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  const BvhClip& student = test::clip("07_01");
  pipeline::Pipeline p(student_config(student, make_gpd_map(student.skeleton, preset_joint_names("cmu")), 16));
  p.set_teacher(teacher_02_01());
  ASSERT_TRUE(p.has_ghost());
  const std::vector<float>& pos = test::clip_positions("07_01", 1);
  const int n = student.skeleton.joint_count();
  std::vector<pipeline::Result> out(16);
  std::vector<float> ghosts(16 * 3 * static_cast<size_t>(p.ghost_joint_count()));
  test::arm_alloc_counter();
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_EQ(p.push(i / 120.0, pos.data() + static_cast<size_t>(i) * 3 * static_cast<size_t>(n), n), Status::kOk);
    if (i % 3 == 0) p.read(out.data(), ghosts.data(), nullptr, out.size());
  }
  p.flush();
  EXPECT_EQ(test::disarm_alloc_counter(), 0);
}

}  // namespace
}  // namespace kata
