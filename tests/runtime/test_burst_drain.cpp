// A worker's drain in bursts (RuntimeConfig::drain_burst): the frames waiting for a worker, of
// distinct streams, go through Pipeline::push_burst together. Every result of every stream equals
// the frame-by-frame drain's (drain_burst 1), field for field, with a restart and a practice
// setting among the frames; and the burst path allocates nothing per frame.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/accounting.hpp"
#include "support/alloc_counter.hpp"
#include "support/live_clip.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

using transport::SkeletonDefinition;

struct Fixture {
  BvhClip student = load_bvh(std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh");
  std::shared_ptr<const metric::Metric> metric = test::default_metric();
  std::vector<float> positions = clip_positions(student);
  std::shared_ptr<const pipeline::Teacher> teacher = test::clip_teacher(metric, "02_01");

  int joints() const { return student.skeleton.joint_count(); }
  int frames() const { return static_cast<int>(positions.size() / (3 * static_cast<size_t>(joints()))); }
  const float* frame(int i) const {
    return positions.data() + static_cast<size_t>(i % frames()) * 3 * static_cast<size_t>(joints());
  }
  SkeletonDefinition definition(uint64_t id) const {
    SkeletonDefinition d;
    d.stream_id = id;
    d.revision = 1;
    d.skeleton = student.skeleton;
    d.layout = "cmu";
    d.frame_rate = static_cast<float>(1.0 / student.frame_time);
    return d;
  }
  StreamSetup setup(bool with_teacher, bool features) const {
    StreamSetup s;
    const GpdMap map = make_gpd_map(student.skeleton, preset_joint_names("cmu"));
    s.pipeline.stream = stream_config_for(student.skeleton, map, metric->stencil());
    s.pipeline.student = student.skeleton;
    s.pipeline.result_capacity = 256;
    s.publish_features = features;
    if (with_teacher) s.teacher = teacher;
    return s;
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

struct Got {
  transport::ResultFields fields;
  std::vector<float> ghost, features;
};

constexpr int kStreams = 12;
constexpr int kTicks = 150;

// Runs kStreams streams for kTicks ticks through a runtime draining in bursts of `drain_burst`,
// every tick's frames pushed at once (so frames wait for the workers); stream 4 restarts its
// source at tick 80 and stream 7 gets a practice loop at tick 60. Returns each stream's results,
// and the frames drained in bursts.
std::map<uint64_t, std::vector<Got>> run(int drain_burst, uint64_t* bursts) {
  Fixture& fx = fixture();
  RuntimeConfig config;
  config.workers = 2;
  config.drain_burst = drain_burst;
  std::map<uint64_t, std::vector<Got>> got;
  for (uint64_t id = 1; id <= kStreams; ++id) got[id];
  Sink sink;  // on the I/O thread: read after stop (joined)
  sink.on_result = [&got](const transport::ResultFields& r) {
    Got g{r, std::vector<float>(r.ghost, r.ghost + 3 * r.ghost_joint_count),
          r.features ? std::vector<float>(r.features, r.features + gpd::kDims) : std::vector<float>()};
    got.at(r.stream_id).push_back(std::move(g));
  };
  config.sinks.push_back(sink);
  Runtime runtime(config);
  for (uint64_t id = 1; id <= kStreams; ++id) runtime.open_stream(fx.definition(id), fx.setup(id != 9, id % 4 == 0));
  for (int i = 0; i < kTicks; ++i) {
    if (i == 60) {
      transport::PracticeSetting p;
      p.stream_id = 7;
      p.loop = true;
      p.loop_start = 0.5;
      p.loop_end = 1.5;
      p.revision = 1;
      EXPECT_EQ(runtime.set_practice(p, nullptr), transport::TableVerdict::kAccepted);
    }
    for (uint64_t id = 1; id <= kStreams; ++id) {
      const bool restarted = id == 4 && i >= 80;
      const int k = restarted ? i - 80 : i;
      const double t = k * fx.student.frame_time;
      EXPECT_EQ(runtime.push(id, static_cast<uint64_t>(i), t, fx.frame(static_cast<int>(7 * id) + i), fx.joints(),
                             id == 4 && i == 80),
                Status::kOk);
    }
    // A tick every few frames' worth of time, as a source does (the workers catch up between).
    if (i % 10 == 9) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const uint64_t want = static_cast<uint64_t>(kStreams) * kTicks;
  for (int tries = 0; tries < 4000 && runtime.counters().total.results < want; ++tries)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  *bursts = runtime.burst_frames();
  runtime.stop();
  EXPECT_EQ(runtime.counters().total.refused + runtime.counters().total.queue_full, 0u);
  return got;
}

TEST(runtime_burst, EveryStreamsResultsEqualTheFrameByFrameDrain) {
  uint64_t one_bursts = 0, bursts = 0;
  const auto one = run(1, &one_bursts);
  const auto burst = run(16, &bursts);
  EXPECT_EQ(one_bursts, 0u);
  // The frames of a tick were pushed at once: most of them waited for their worker.
  EXPECT_GT(bursts, static_cast<uint64_t>(kStreams) * kTicks / 4);
  for (uint64_t id = 1; id <= kStreams; ++id) {
    const auto& a = one.at(id);
    const auto& b = burst.at(id);
    ASSERT_EQ(a.size(), b.size()) << "stream " << id;
    ASSERT_GE(a.size(), static_cast<size_t>(kTicks - 1)) << "stream " << id;
    for (size_t i = 0; i < a.size(); ++i) {
      SCOPED_TRACE("stream " + std::to_string(id) + " result " + std::to_string(i));
      const transport::ResultFields& x = a[i].fields;
      const transport::ResultFields& y = b[i].fields;
      EXPECT_EQ(x.result_sequence, y.result_sequence);
      EXPECT_EQ(x.frame_sequence, y.frame_sequence);
      EXPECT_EQ(x.frame_index, y.frame_index);
      EXPECT_EQ(x.capture_time, y.capture_time);
      EXPECT_EQ(x.scored, y.scored);
      EXPECT_EQ(x.score, y.score);
      EXPECT_EQ(x.distance, y.distance);
      for (int k = 0; k < metric::kParts; ++k) {
        EXPECT_EQ(x.parts[k], y.parts[k]);
        EXPECT_EQ(x.part_scores[k], y.part_scores[k]);
      }
      EXPECT_EQ(x.part_to_fix, y.part_to_fix);
      EXPECT_EQ(x.cue_joint, y.cue_joint);
      EXPECT_EQ(x.cue_degrees, y.cue_degrees);
      EXPECT_EQ(x.cue_action, y.cue_action);
      EXPECT_EQ(x.state, y.state);
      EXPECT_EQ(x.matched_teacher_frame, y.matched_teacher_frame);
      EXPECT_EQ(x.matched_teacher_time, y.matched_teacher_time);
      EXPECT_EQ(x.repetition, y.repetition);
      EXPECT_EQ(x.repetition_progress, y.repetition_progress);
      EXPECT_EQ(x.has_practice, y.has_practice);
      EXPECT_EQ(x.practice_revision, y.practice_revision);
      EXPECT_EQ(x.practice_start_time, y.practice_start_time);
      EXPECT_EQ(x.practice_end_time, y.practice_end_time);
      EXPECT_EQ(x.practice_loop, y.practice_loop);
      EXPECT_EQ(x.ghost_joint_count, y.ghost_joint_count);
      EXPECT_EQ(x.arrival_ns > 0, y.arrival_ns > 0);
      EXPECT_EQ(a[i].ghost, b[i].ghost);
      EXPECT_EQ(a[i].features, b[i].features);
      if (::testing::Test::HasFailure()) return;
    }
  }
}

TEST(runtime_alloc, TheBurstDrainAllocatesNothingPerFrame) {
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  Fixture& fx = fixture();
  RuntimeConfig config;  // no publisher: libzmq mallocs every message it sends
  config.workers = 2;
  config.drain_burst = 16;
  std::map<uint64_t, kata::test::StreamTally> tally;
  for (uint64_t id = 1; id <= kStreams; ++id) tally[id];  // every node made first: at() never allocates
  Sink sink;
  sink.on_result = [&tally](const transport::ResultFields& r) { ++tally.at(r.stream_id).received; };
  config.sinks.push_back(sink);
  Runtime runtime(config);
  for (uint64_t id = 1; id <= kStreams; ++id) runtime.open_stream(fx.definition(id), fx.setup(true, false));
  auto push_and_wait = [&](int first, int count) {
    for (int i = first; i < first + count; ++i)
      for (uint64_t id = 1; id <= kStreams; ++id) {
        ++tally[id].sent;
        if (runtime.push(id, static_cast<uint64_t>(i), i * fx.student.frame_time, fx.frame(i + static_cast<int>(id)),
                         fx.joints()) != Status::kOk)
          return false;
      }
    const uint64_t want = static_cast<uint64_t>(kStreams) * static_cast<uint64_t>(first + count);
    for (int tries = 0; tries < 4000 && runtime.counters().total.results < want; ++tries)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return runtime.counters().total.results == want;
  };
  ASSERT_TRUE(push_and_wait(0, 20));  // warm-up: first-frame paths, thread-local state
  const uint64_t bursts_before = runtime.burst_frames();
  const long before = kata::test::allocations();
  const bool done = push_and_wait(20, 100);
  const long allocated = kata::test::allocations() - before;
  ASSERT_TRUE(done);
  EXPECT_EQ(allocated, 0) << "the burst drain allocated";
  EXPECT_GT(runtime.burst_frames(), bursts_before) << "no frame was drained in a burst";
  runtime.stop();
  EXPECT_TRUE(kata::test::every_frame_accounted(runtime, tally, kata::test::Delivery::kSinks));
}

}  // namespace
}  // namespace kata::runtime
