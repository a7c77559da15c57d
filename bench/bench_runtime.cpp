// The cold frame: a push paced at 120 Hz (a sleep between frames, as live frames come),
// once through the runtime and once straight into a Pipeline on the benchmark thread, side by
// side in one run, so the runtime's addition to the paced push is its own figure.
//
//   BM_RuntimePacedPipelinePush: Pipeline::push timed on this thread after an 8.33 ms sleep
//     (the figure the speed issue's BM_PipelinePushPaced measures; named apart from it).
//   BM_RuntimePacedPush: Runtime::push after the same sleep; the time from the frame's arrival
//     stamp to the pipeline's computed stamp (the worker's wake-up from its semaphore + the push
//     on the worker), read from the result's stamps in a sink; no publisher (ZeroMQ is measured
//     by kata replay).
// Manual time (wall, the latency the frame sees); student 07_01 against teacher 02_01 with the
// shipped model, results with the ghost.
#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>

#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "support/clips.hpp"

namespace {

constexpr auto kPeriod = std::chrono::microseconds(8333);  // 120 Hz

struct PacedSetup {
  std::shared_ptr<const kata::pipeline::Teacher> teacher;
  kata::pipeline::PipelineConfig config;
  kata::Skeleton student;
  std::vector<float> frames;
  int frame_count = 0, joints = 0;
  double frame_time = 0.0;
  static const PacedSetup& get() {
    static const PacedSetup instance = [] {
      PacedSetup s;
      const kata::BvhClip& t = kata::test::clip("02_01");
      const kata::BvhClip& st = kata::test::clip("07_01");
      auto metric = std::make_shared<const kata::metric::Metric>(
          kata::metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
      const auto tmap = kata::make_gpd_map(t.skeleton, kata::preset_joint_names("cmu"));
      const std::vector<float>& tp = kata::test::clip_positions("02_01", 1);
      s.teacher = kata::pipeline::Teacher::from_positions(
          metric, t.skeleton, kata::stream_config_for(t.skeleton, tmap, metric->stencil()), tp.data(),
          t.frame_count() - 1, t.frame_time);
      const auto smap = kata::make_gpd_map(st.skeleton, kata::preset_joint_names("cmu"));
      s.config.stream = kata::stream_config_for(st.skeleton, smap, metric->stencil());
      s.config.student = st.skeleton;
      s.student = st.skeleton;
      s.frames = kata::test::clip_positions("07_01", 1);
      s.frame_count = st.frame_count() - 1;
      s.joints = st.skeleton.joint_count();
      s.frame_time = st.frame_time;
      return s;
    }();
    return instance;
  }
  const float* frame(int64_t i) const {
    return frames.data() + static_cast<size_t>(i % frame_count) * 3 * static_cast<size_t>(joints);
  }
};

void BM_RuntimePacedPipelinePush(benchmark::State& state) {
  const PacedSetup& s = PacedSetup::get();
  kata::pipeline::Pipeline p(s.config);
  p.set_teacher(s.teacher);
  std::vector<kata::pipeline::Result> out(8);
  std::vector<float> ghosts(8 * 3 * 64);
  int64_t i = 0;
  for (auto _ : state) {
    std::this_thread::sleep_for(kPeriod);
    const auto t0 = std::chrono::steady_clock::now();
    p.push(static_cast<double>(i) * s.frame_time, s.frame(i), s.joints);
    const auto t1 = std::chrono::steady_clock::now();
    p.read(out.data(), ghosts.data(), nullptr, out.size());
    state.SetIterationTime(std::chrono::duration<double>(t1 - t0).count());
    ++i;
  }
}
BENCHMARK(BM_RuntimePacedPipelinePush)->UseManualTime()->Iterations(240);

void BM_RuntimePacedPush(benchmark::State& state) {
  const PacedSetup& s = PacedSetup::get();
  std::atomic<int64_t> latency_ns{-1};
  kata::runtime::RuntimeConfig config;
  config.workers = 1;
  config.sinks.push_back({[&](const kata::transport::ResultFields& f) {
                            latency_ns.store(f.computed_ns - f.arrival_ns, std::memory_order_release);
                          },
                          nullptr});
  kata::runtime::Runtime runtime(config);
  kata::transport::SkeletonDefinition d;
  d.stream_id = 1;
  d.revision = 1;
  d.skeleton = s.student;
  d.layout = "cmu";
  kata::runtime::StreamSetup setup;
  setup.pipeline = s.config;
  setup.teacher = s.teacher;
  runtime.open_stream(d, setup);
  int64_t i = 0;
  for (auto _ : state) {
    std::this_thread::sleep_for(kPeriod);
    latency_ns.store(-1, std::memory_order_relaxed);
    runtime.push(1, static_cast<uint64_t>(i), static_cast<double>(i) * s.frame_time, s.frame(i), s.joints);
    int64_t ns;
    while ((ns = latency_ns.load(std::memory_order_acquire)) < 0) std::this_thread::yield();
    state.SetIterationTime(1e-9 * static_cast<double>(ns));
    ++i;
  }
  runtime.stop();
}
BENCHMARK(BM_RuntimePacedPush)->UseManualTime()->Iterations(240);

}  // namespace
