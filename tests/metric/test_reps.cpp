// The repetition counter (metric/reps.hpp) driven by records whose matched teacher frame is set
// here, so that each case's truth (where a repetition starts and ends, its tempo) is known
// exactly. The counter against the real alignment of real clips is tests/cli/reps_check.py.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "fixtures.hpp"
#include "metric/reps.hpp"
#include "support/alloc_counter.hpp"

namespace kata {
namespace {

using metric::Repetition;
using metric::RepCounter;
using metric::ScoreRecord;

constexpr double kDt = 1.0 / 120.0;
constexpr int kFirst = 10, kLast = 109;  // a looped section of 100 teacher frames (0.833 s)

struct Rig {
  std::shared_ptr<const metric::Reference> ref;
  metric::Aligner aligner;
  RepCounter counter;
  std::vector<Repetition> ended;
  double t = 0.0;
  ScoreRecord record;

  static std::shared_ptr<const metric::Reference> reference() {
    return std::make_shared<const metric::Reference>(test::test_metric(), test::clip_rows("02_01.bvh").data(), 200,
                                                     kDt);
  }
  static metric::AlignmentOptions section() {
    metric::AlignmentOptions o;
    o.first_frame = kFirst;
    o.last_frame = kLast;
    o.loop = true;
    return o;
  }
  Rig() : ref(reference()), aligner(ref, section()), counter(ref) { ended.reserve(64); }

  // One student frame matched to teacher frame m (a pose from 02_01 for the angles).
  void frame(int m) {
    record.time = t;
    record.matched = m;
    record.state = metric::ScoreState::kScoring;
    record.score = 80.0f;
    record.model_score = 80.0f;  // the motion itself (RepCounter::kMotionScore)
    if (counter.update(record, test::clip_row("02_01.bvh", m), aligner) > 0) ended.push_back(counter.newest());
    t += kDt;
  }
  // The section from `from` to its end at `factor` times the teacher's duration, ending on
  // kLast; the next frame after it crosses to the start.
  void rep(double factor, int from = kFirst) {
    const int frames = static_cast<int>(std::lround(factor * (kLast - from + 1)));
    for (int i = 0; i < frames; ++i) frame(from + static_cast<int>(std::floor(i / factor)));
  }
  void hold(int m, double seconds) {
    for (int i = 0; i < static_cast<int>(std::lround(seconds / kDt)); ++i) frame(m);
  }
};

TEST(Reps, EachWrapEndsARepetitionTimedAtTheCrossing) {
  Rig r;
  const std::vector<double> factors = {1.0, 1.2, 0.8};
  for (double f : factors) r.rep(f);
  r.frame(kFirst);  // the next repetition's first frame: the last wrap
  ASSERT_EQ(r.ended.size(), 3u);
  const double period = (kLast - kFirst + 1) * kDt;
  double start = 0.0;
  for (size_t k = 0; k < 3; ++k) {
    const Repetition& rep = r.ended[k];
    EXPECT_EQ(rep.index, static_cast<int>(k + 1));
    EXPECT_FALSE(rep.partial);
    const double duration = std::lround(factors[k] * (kLast - kFirst + 1)) * kDt;
    EXPECT_NEAR(rep.start_time, start, 1.5 * kDt) << k;
    EXPECT_NEAR(rep.end_time, start + duration, 1.5 * kDt) << k;
    EXPECT_NEAR(rep.tempo, duration / period, 0.02) << k;
    EXPECT_FLOAT_EQ(rep.score, 80.0f);
    EXPECT_GE(rep.coverage, 0.95f);
    start += duration;
  }
  EXPECT_EQ(r.counter.count(), 3);
  EXPECT_EQ(r.counter.current_index(), 4);
}

TEST(Reps, APauseBetweenRepetitionsBelongsToNeither) {
  Rig r;
  r.rep(1.0);
  const double reached_end = r.t - kDt;
  r.hold(kLast, 0.3);  // stopped at the end, shorter than the end hold
  const double resumed = r.t - kDt;
  r.rep(1.0);
  r.frame(kFirst);
  ASSERT_EQ(r.ended.size(), 2u);
  EXPECT_NEAR(r.ended[0].end_time, reached_end, 1.5 * kDt);
  EXPECT_NEAR(r.ended[1].start_time, resumed, 1.5 * kDt);
  EXPECT_NEAR(r.ended[0].tempo, 1.0, 0.02);
  EXPECT_NEAR(r.ended[1].tempo, 1.0, 0.02);
}

TEST(Reps, HoldingAtTheEndEndsTheRepetitionWithoutTheNext) {
  Rig r;
  r.rep(1.0);
  r.hold(kLast, RepCounter::kEndHold + 0.1);
  ASSERT_EQ(r.ended.size(), 1u);
  EXPECT_FALSE(r.ended[0].partial);
  EXPECT_NEAR(r.ended[0].tempo, 1.0, 0.02);
  r.rep(1.0);  // the next starts from the hold, not counted twice
  r.frame(kFirst);
  ASSERT_EQ(r.ended.size(), 2u);
  EXPECT_EQ(r.ended[1].index, 2);
  EXPECT_NEAR(r.ended[1].tempo, 1.0, 0.03);
}

// The end of the stream (finish: kata score's clip end, a stream's flush, a runtime's stop or
// close) ends the repetition in progress: complete when the student reached the section's end,
// partial when it stopped halfway; after it the count goes on with the next take.
TEST(Reps, TheEndOfTheStreamEndsTheLastRepetition) {
  Rig r;
  r.rep(1.0);
  r.rep(1.1);
  ASSERT_EQ(r.ended.size(), 1u);  // the second is in progress: no wrap, no hold after it
  const double last = r.t - kDt;
  ASSERT_EQ(r.counter.finish(r.t), 1);
  const Repetition& done = r.counter.newest();
  EXPECT_EQ(done.index, 2);
  EXPECT_FALSE(done.partial);
  EXPECT_NEAR(done.end_time, last, 1e-9);
  EXPECT_NEAR(done.tempo, 1.1, 0.03);
  EXPECT_EQ(r.counter.count(), 2);
  EXPECT_EQ(r.counter.finish(r.t), 0);  // nothing in progress: nothing more
  // A new take: half the section, then the end.
  r.ended.clear();
  for (int m = kFirst; m < kFirst + 50; ++m) r.frame(m);
  ASSERT_EQ(r.counter.finish(r.t), 1);
  const Repetition& half = r.counter.newest();
  EXPECT_EQ(half.index, 3);
  EXPECT_TRUE(half.partial);
  EXPECT_NEAR(half.coverage, 0.5, 0.05);
  EXPECT_NEAR(half.end_time, r.t - kDt, 1e-9);
  EXPECT_EQ(r.counter.count(), 2);
  EXPECT_TRUE(r.ended.empty());
}

TEST(Reps, AnAbandonedRepetitionIsPartialAndTheCountGoesOn) {
  Rig r;
  r.rep(1.0);
  // Halfway, a pause, no pose for a second, then back to the start.
  for (int m = kFirst; m < kFirst + 50; ++m) r.frame(m);
  r.hold(kFirst + 49, 1.0);
  for (int i = 0; i < 120; ++i, r.t += kDt) {
    ScoreRecord lost;
    lost.time = r.t;
    lost.state = metric::ScoreState::kTrackingLost;
    lost.matched = kFirst + 49;
    if (r.counter.update(lost, nullptr, r.aligner) > 0) r.ended.push_back(r.counter.newest());
  }
  r.rep(1.0);
  r.rep(1.0);
  r.frame(kFirst);
  ASSERT_EQ(r.ended.size(), 4u);
  EXPECT_FALSE(r.ended[0].partial);
  EXPECT_TRUE(r.ended[1].partial);
  EXPECT_EQ(r.ended[1].index, 2);  // the attempt at the second
  EXPECT_NEAR(r.ended[1].coverage, 0.5, 0.05);
  EXPECT_EQ(r.ended[2].index, 2);  // the count goes on as if it had not happened
  EXPECT_EQ(r.ended[3].index, 3);
  EXPECT_FALSE(r.ended[2].partial);
  EXPECT_EQ(r.counter.count(), 3);
}

TEST(Reps, AJumpThroughTheSectionCoversNothing) {
  Rig r;
  r.rep(1.0);
  // The match leaps from the first quarter to the end (a re-localisation), then wraps: not complete.
  for (int m = kFirst; m < kFirst + 30; ++m) r.frame(m);
  for (int m = kLast - 5; m <= kLast; ++m) r.frame(m);
  r.frame(kFirst);
  ASSERT_EQ(r.ended.size(), 2u);
  EXPECT_TRUE(r.ended[1].partial);
  EXPECT_EQ(r.counter.count(), 1);
}

TEST(Reps, TheTeachersRangesAreTheSectionsAndTheStudentsItsOwn) {
  Rig r;
  r.rep(1.0);
  r.frame(kFirst);
  ASSERT_EQ(r.ended.size(), 1u);
  // The student played the teacher's own frames: the ranges agree (within a frame at the ends).
  for (int j = 0; j < metric::kRomJoints; ++j) {
    EXPECT_GT(r.ended[0].teacher_range[j], 0.0f) << metric::rom_joint_name(j);
    EXPECT_NEAR(r.ended[0].range[j], r.ended[0].teacher_range[j], 1.0) << metric::rom_joint_name(j);
  }
}

TEST(Reps, CountingAllocatesNothing) {
  if (!test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  Rig r;
  r.rep(1.0);
  r.record.model_score = 80.0f;
  test::arm_alloc_counter();
  for (int k = 0; k < 5; ++k) {
    for (int m = kFirst; m <= kLast; ++m) {
      r.record.time = r.t;
      r.record.matched = m;
      r.counter.update(r.record, test::clip_row("02_01.bvh", m), r.aligner);
      r.t += kDt;
    }
  }
  r.counter.finish(r.t);
  EXPECT_EQ(test::disarm_alloc_counter(), 0);
  EXPECT_EQ(r.counter.count(), 6);
}

}  // namespace
}  // namespace kata
