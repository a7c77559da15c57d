// A source that restarts mid-repetition (the runtime's restart path: a frame flagged restart, as
// the ingest flags a sequence back to 0 or a new revision of the same skeleton): the repetition in
// progress is ended first (as the end of a take ends it: complete or partial) and published before
// any result of the restarted source, then the count starts again from 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

// What the sinks saw, in the order the runtime sent it: a result (its frame sequence and
// repetition in progress) or a repetition.
struct Event {
  bool is_repetition = false;
  uint64_t frame_sequence = 0;
  int32_t repetition = 0;  // a result's repetition in progress
  kata_repetition rep{};   // a repetition's
};

TEST(runtime_reps_restart, ARestartEndsTheRepetitionInProgressBeforeTheCountRestarts) {
  const test::LiveClip clip("02_01");
  const std::shared_ptr<const metric::Metric> metric = test::default_metric();
  const int n = clip.rows();
  const double ft = clip.frame_time();
  RuntimeConfig config;
  config.workers = 1;
  std::mutex mutex;
  std::vector<Event> events;
  Sink sink;
  sink.on_result = [&](const transport::ResultFields& r) {
    std::lock_guard<std::mutex> lock(mutex);
    Event e;
    e.frame_sequence = r.frame_sequence;
    e.repetition = r.repetition;
    events.push_back(e);
  };
  config.sinks.push_back(sink);
  config.repetition_sinks.push_back([&](const kata_repetition& r) {
    std::lock_guard<std::mutex> lock(mutex);
    Event e;
    e.is_repetition = true;
    e.rep = r;
    events.push_back(e);
  });
  Runtime runtime(config);
  StreamSetup setup;
  const GpdMap map = make_gpd_map(clip.clip().skeleton, preset_joint_names("cmu"));
  setup.pipeline.stream = stream_config_for(clip.clip().skeleton, map, metric->stencil());
  setup.pipeline.student = clip.clip().skeleton;
  setup.pipeline.result_capacity = 256;
  setup.teacher = test::clip_teacher(metric, "02_01");
  setup.teacher_options.ghost = false;
  runtime.open_stream(clip.definition(3), setup);
  // The whole clip is one repetition, looped (the teacher is the student's own clip).
  transport::PracticeSetting loop;
  loop.stream_id = 3;
  loop.revision = 1;
  loop.loop = true;
  loop.loop_start = 0.0;
  loop.loop_end = (n - 1) * ft;
  ASSERT_EQ(runtime.set_practice(loop), transport::TableVerdict::kAccepted);
  // Two and a half plays, then the source restarts (sequence and clock from 0) and plays once more.
  const int before = 5 * n / 2;
  for (int k = 0; k < before; ++k)
    ASSERT_EQ(runtime.push(3, static_cast<uint64_t>(k), k * ft, clip.frame(k), clip.joints()), Status::kOk);
  for (int k = 0; k < n; ++k) {
    ASSERT_EQ(runtime.push(3, static_cast<uint64_t>(k), k * ft, clip.frame(k), clip.joints(), k == 0), Status::kOk);
    if (k % 50 == 49) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  runtime.stop();

  std::lock_guard<std::mutex> lock(mutex);
  std::vector<kata_repetition> reps;
  size_t restart_at = events.size();  // the first result of the restarted source
  size_t third_at = events.size();    // where the repetition the restart ended went out
  uint64_t previous = 0;
  for (size_t i = 0; i < events.size(); ++i) {
    const Event& e = events[i];
    if (e.is_repetition) {
      reps.push_back(e.rep);
      if (reps.size() == 3) third_at = i;
      continue;
    }
    if (restart_at == events.size() && i > 0 && e.frame_sequence < previous) restart_at = i;
    previous = e.frame_sequence;
  }
  ASSERT_LT(restart_at, events.size()) << "no result of the restarted source";
  // Two complete repetitions, the third abandoned halfway by the restart: partial (index 3, not
  // counted), from where the third play began to its last frame, about half the section; then the
  // restarted source's first repetition, numbered 1 again, closed by the stop.
  ASSERT_EQ(reps.size(), 4u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(reps[i].index, i + 1);
    EXPECT_EQ(reps[i].partial, 0) << i;
    EXPECT_EQ(reps[i].stream_id, 3u);
  }
  const kata_repetition& cut = reps[2];
  EXPECT_EQ(cut.index, 3);
  EXPECT_EQ(cut.partial, 1);
  EXPECT_EQ(cut.stream_id, 3u);
  EXPECT_NEAR(cut.start_time, 2 * n * ft, 0.05);
  EXPECT_NEAR(cut.end_time, (before - 1) * ft, 0.05);
  EXPECT_NEAR(cut.coverage, 0.5, 0.1);
  EXPECT_LT(third_at, restart_at) << "the abandoned repetition went out after the restarted source's results";
  EXPECT_EQ(reps[3].index, 1);
  EXPECT_EQ(reps[3].partial, 0);
  EXPECT_NEAR(reps[3].tempo, 1.0, 0.05);
  // The results: repetitions 1..3 before the restart, 1 after it.
  int32_t highest_before = 0, highest_after = 0;
  for (size_t i = 0; i < events.size(); ++i)
    if (!events[i].is_repetition)
      (i < restart_at ? highest_before : highest_after) =
          std::max(i < restart_at ? highest_before : highest_after, events[i].repetition);
  EXPECT_EQ(highest_before, 3);
  EXPECT_EQ(highest_after, 1);
}

}  // namespace
}  // namespace kata::runtime
