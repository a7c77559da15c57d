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


// A replay's tick through Pipeline::push_burst: every stream's results equal push()'s, field for
// field and bit for bit (computed_ns, a clock, aside), ghosts and features included, over streams
// of several students and two teachers, one stream without a teacher, a tracking-lost frame and a
// refused frame among them.
struct BurstStreams {
  struct One {
    std::unique_ptr<pipeline::Pipeline> p;
    const std::vector<float>* pos = nullptr;
    int joints = 0, frames = 0, offset = 0;
    double frame_time = 0.0;
  };
  std::vector<One> streams;
  static std::shared_ptr<const pipeline::Teacher> teacher_05_18() {
    static const auto t = [] {
      const BvhClip& c = test::clip("05_18");
      const std::vector<float>& pos = test::clip_positions("05_18", 1);
      return pipeline::Teacher::from_positions(
          shipped_metric(), c.skeleton,
          stream_config_for(c.skeleton, make_gpd_map(c.skeleton, preset_joint_names("cmu")), gpd::Stencil::kBackward),
          pos.data(), c.frame_count() - 1, c.frame_time);
    }();
    return t;
  }
  explicit BurstStreams(int k) {
    static const auto walk = teacher_02_01();
    const char* students[] = {"07_01", "02_02", "09_01", "05_19_on_02", "05_02"};
    for (int j = 0; j < k; ++j) {
      const std::string name = students[j % 5];
      const BvhClip& c = test::clip(name);
      One o;
      pipeline::PipelineConfig pc =
          student_config(c, make_gpd_map(c.skeleton, preset_joint_names("cmu")), 64);
      pc.keep_features = j % 3 == 0;
      o.p = std::make_unique<pipeline::Pipeline>(pc);
      if (j % 7 != 6) o.p->set_teacher(j % 2 ? teacher_05_18() : walk);
      o.pos = &test::clip_positions(name, 1);
      o.joints = c.skeleton.joint_count();
      o.frames = c.frame_count() - 1;
      o.offset = (j * 37) % o.frames;
      o.frame_time = c.frame_time;
      streams.push_back(std::move(o));
    }
  }
  // Frame i of stream j (tick i): the clip's frame, zeros (tracking lost) at tick 50 on stream 1.
  const float* frame(size_t j, int i, std::vector<float>& scratch) const {
    const One& o = streams[j];
    const float* xyz = o.pos->data() + static_cast<size_t>((o.offset + i) % o.frames) * 3 * static_cast<size_t>(o.joints);
    if (j == 1 && i == 50) {
      scratch.assign(3 * static_cast<size_t>(o.joints), 0.0f);
      return scratch.data();
    }
    return xyz;
  }
  int joints_of(size_t j, int i) const { return j == 2 && i == 70 ? streams[j].joints - 1 : streams[j].joints; }
};

void expect_same_results(pipeline::Pipeline& a, pipeline::Pipeline& b, size_t stream) {
  std::vector<pipeline::Result> ra(64), rb(64);
  const size_t g = 3 * static_cast<size_t>(a.ghost_joint_count());
  std::vector<float> ga(64 * std::max<size_t>(g, 1)), gb(ga.size()), fa(64 * gpd::kDims), fb(fa.size());
  ASSERT_EQ(a.pending(), b.pending()) << "stream " << stream;
  const size_t na = a.read(ra.data(), ga.data(), fa.data(), ra.size());
  const size_t nb = b.read(rb.data(), gb.data(), fb.data(), rb.size());
  ASSERT_EQ(na, nb);
  for (size_t i = 0; i < na; ++i) {
    const pipeline::Result& x = ra[i];
    const pipeline::Result& y = rb[i];
    SCOPED_TRACE("stream " + std::to_string(stream) + " result " + std::to_string(x.sequence));
    EXPECT_EQ(x.sequence, y.sequence);
    EXPECT_EQ(x.frame_index, y.frame_index);
    EXPECT_EQ(x.capture_time, y.capture_time);
    EXPECT_EQ(x.arrival_ns, y.arrival_ns);
    EXPECT_EQ(x.scored, y.scored);
    EXPECT_EQ(x.matched_frame, y.matched_frame);
    EXPECT_EQ(x.has_ghost, y.has_ghost);
    EXPECT_EQ(x.repetition, y.repetition);
    EXPECT_EQ(x.repetition_progress, y.repetition_progress);
    EXPECT_EQ(x.repetition_ended, y.repetition_ended);
    const metric::ScoreRecord& s = x.score;
    const metric::ScoreRecord& t = y.score;
    EXPECT_EQ(s.time, t.time);
    EXPECT_EQ(s.frame, t.frame);
    EXPECT_EQ(s.distance, t.distance);
    EXPECT_EQ(s.score, t.score);
    EXPECT_EQ(s.model_score, t.model_score);
    EXPECT_EQ(s.matched, t.matched);
    EXPECT_EQ(s.part_to_fix, t.part_to_fix);
    EXPECT_EQ(s.cue_joint, t.cue_joint);
    EXPECT_EQ(s.cue_degrees, t.cue_degrees);
    EXPECT_EQ(s.cue_action, t.cue_action);
    EXPECT_EQ(s.state, t.state);
    EXPECT_EQ(s.matched_time, t.matched_time);
    for (int q = 0; q < metric::kParts; ++q) {
      EXPECT_EQ(s.parts[q], t.parts[q]);
      EXPECT_EQ(s.part_distance[q], t.part_distance[q]);
      EXPECT_EQ(s.part_degrees[q], t.part_degrees[q]);
      EXPECT_EQ(s.part_joint[q], t.part_joint[q]);
      EXPECT_EQ(s.part_offset[q], t.part_offset[q]);
      EXPECT_EQ(s.part_scores[q], t.part_scores[q]);
    }
    for (size_t c = 0; c < g; ++c) EXPECT_EQ(ga[i * g + c], gb[i * g + c]);
    for (size_t c = 0; c < gpd::kDims; ++c) EXPECT_EQ(fa[i * gpd::kDims + c], fb[i * gpd::kDims + c]);
  }
  const bool reps = a.repetitions() != nullptr;
  ASSERT_EQ(reps, b.repetitions() != nullptr);
  if (reps) {
    EXPECT_EQ(a.repetitions()->ended(), b.repetitions()->ended());
  }
}

TEST(Pipeline, ABurstEqualsItsFramesPushedOneByOne) {
  constexpr int kStreams = 14;
  BurstStreams one(kStreams), burst(kStreams);
  std::vector<pipeline::Pipeline::BurstFrame> frames(kStreams);
  std::vector<float> scratch;
  int64_t scored_results = 0;
  for (int i = 0; i < 2 * kFrames; ++i) {
    for (size_t j = 0; j < kStreams; ++j) {
      const double t = i * one.streams[j].frame_time;
      const int64_t arrival = 1000 + i;
      const Status st = one.streams[j].p->push(t, one.frame(j, i, scratch), one.joints_of(j, i), arrival);
      pipeline::Pipeline::BurstFrame& f = frames[j];
      f = {};
      f.pipeline = burst.streams[j].p.get();
      f.capture_time = t;
      f.xyz = burst.frame(j, i, scratch);
      f.joint_count = burst.joints_of(j, i);
      f.arrival_ns = arrival;
      (void)st;
    }
    pipeline::Pipeline::push_burst(frames.data(), kStreams);
    for (size_t j = 0; j < kStreams; ++j) {
      if (const pipeline::Result* r = one.streams[j].p->newest(); r && r->scored) ++scored_results;
      expect_same_results(*one.streams[j].p, *burst.streams[j].p, j);
    }
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(scored_results, 100 * kStreams);
  int64_t repetitions = 0;  // the repetition counters were exercised, not only equal at zero
  for (const auto& s : burst.streams)
    if (s.p->repetitions()) repetitions += s.p->repetitions()->ended();
  EXPECT_GT(repetitions, 0);
  EXPECT_EQ(frames[2].status, Status::kOk);
}

// One Scratch for every stream a thread pushes (a runtime worker's): the scorer's and the ghost's
// per-frame work shared across 14 streams, pushed one by one and in bursts, leaves every result
// equal to the pipelines' own scratch's, bit for bit.
TEST(Pipeline, OneScratchForManyStreamsChangesNoResult) {
  constexpr int kStreams = 14;
  BurstStreams own(kStreams), own2(kStreams), shared(kStreams), burst(kStreams);
  pipeline::Scratch one_by_one, bursts;
  std::vector<pipeline::Pipeline::BurstFrame> frames(kStreams);
  std::vector<float> scratch;
  int64_t ghosts = 0;
  for (int i = 0; i < 2 * kFrames; ++i) {
    for (size_t j = 0; j < kStreams; ++j) {
      const double t = i * own.streams[j].frame_time;
      const int64_t arrival = 1000 + i;
      (void)own.streams[j].p->push(t, own.frame(j, i, scratch), own.joints_of(j, i), arrival);
      (void)own2.streams[j].p->push(t, own2.frame(j, i, scratch), own2.joints_of(j, i), arrival);
      (void)shared.streams[j].p->push(t, shared.frame(j, i, scratch), nullptr, shared.joints_of(j, i), arrival,
                                      &one_by_one);
      pipeline::Pipeline::BurstFrame& f = frames[j];
      f = {};
      f.pipeline = burst.streams[j].p.get();
      f.capture_time = t;
      f.xyz = burst.frame(j, i, scratch);
      f.joint_count = burst.joints_of(j, i);
      f.arrival_ns = arrival;
    }
    pipeline::Pipeline::push_burst(frames.data(), kStreams, &bursts);
    for (size_t j = 0; j < kStreams; ++j) {
      if (const pipeline::Result* r = own.streams[j].p->newest(); r && r->has_ghost) ++ghosts;
      expect_same_results(*own.streams[j].p, *shared.streams[j].p, j);
      expect_same_results(*own2.streams[j].p, *burst.streams[j].p, j);
    }
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(ghosts, 100 * kStreams);
}

TEST(Pipeline, ABurstReturnsEachFramesPushStatus) {
  BurstStreams one(3), burst(3);
  std::vector<float> scratch;
  for (int i = 0; i < 71; ++i) {
    pipeline::Pipeline::BurstFrame frames[3];
    Status want[3];
    for (size_t j = 0; j < 3; ++j) {
      want[j] = one.streams[j].p->push(i / 120.0, one.frame(j, i, scratch), one.joints_of(j, i));
      frames[j].pipeline = burst.streams[j].p.get();
      frames[j].capture_time = i / 120.0;
      frames[j].xyz = burst.frame(j, i, scratch);
      frames[j].joint_count = burst.joints_of(j, i);
    }
    pipeline::Pipeline::push_burst(frames, 3);
    for (size_t j = 0; j < 3; ++j) EXPECT_EQ(frames[j].status, want[j]) << "stream " << j << " tick " << i;
  }
  // Tick 70 gave stream 2 a wrong joint count: refused in both, the stream usable after it.
  EXPECT_NE(one.streams[2].p->push(71 / 120.0, one.frame(2, 80, scratch), one.joints_of(2, 70)), Status::kOk);
  pipeline::Pipeline::BurstFrame next;
  next.pipeline = burst.streams[2].p.get();
  next.capture_time = 71 / 120.0;
  next.xyz = burst.frame(2, 71, scratch);
  next.joint_count = burst.streams[2].joints;
  pipeline::Pipeline::push_burst(&next, 1);
  EXPECT_EQ(next.status, Status::kOk);
}

TEST(Pipeline, ABurstAllocatesNothingAfterOpen) {
  if (!test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  constexpr int kStreams = 16;
  BurstStreams b(kStreams);
  std::vector<pipeline::Pipeline::BurstFrame> frames(kStreams);
  std::vector<pipeline::Result> out(64);
  std::vector<float> ghosts(64 * 3 * 64), features(64 * gpd::kDims);
  std::vector<float> scratch(3 * 64, 0.0f);
  test::arm_alloc_counter();
  for (int i = 0; i < kFrames; ++i) {
    for (size_t j = 0; j < kStreams; ++j) {
      frames[j] = {};
      frames[j].pipeline = b.streams[j].p.get();
      frames[j].capture_time = i * b.streams[j].frame_time;
      frames[j].xyz = b.frame(j, i, scratch);
      frames[j].joint_count = b.streams[j].joints;
    }
    pipeline::Pipeline::push_burst(frames.data(), kStreams);
    if (i % 3 == 0)
      for (auto& s : b.streams) s.p->read(out.data(), ghosts.data(), features.data(), out.size());
  }
  EXPECT_EQ(test::disarm_alloc_counter(), 0);
}

// The same with one Scratch for every stream: after its first tick (which sizes it), nothing.
TEST(Pipeline, ABurstWithAScratchAllocatesNothingAfterItsFirstTick) {
  if (!test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  constexpr int kStreams = 16;
  BurstStreams b(kStreams);
  pipeline::Scratch work;
  std::vector<pipeline::Pipeline::BurstFrame> frames(kStreams);
  std::vector<pipeline::Result> out(64);
  std::vector<float> ghosts(64 * 3 * 64), features(64 * gpd::kDims);
  std::vector<float> scratch(3 * 64, 0.0f);
  for (int i = 0; i < kFrames; ++i) {
    if (i == 1) test::arm_alloc_counter();
    for (size_t j = 0; j < kStreams; ++j) {
      frames[j] = {};
      frames[j].pipeline = b.streams[j].p.get();
      frames[j].capture_time = i * b.streams[j].frame_time;
      frames[j].xyz = b.frame(j, i, scratch);
      frames[j].joint_count = b.streams[j].joints;
    }
    pipeline::Pipeline::push_burst(frames.data(), kStreams, &work);
    if (i % 3 == 0)
      for (auto& s : b.streams) s.p->read(out.data(), ghosts.data(), features.data(), out.size());
  }
  EXPECT_EQ(test::disarm_alloc_counter(), 0);
}

}  // namespace
}  // namespace kata
