// The per-stream pipeline's push (features + score + ghost) against the sum of its three stages
// run alone on the same frames, side by side in one run (issue 8: the pipeline may add <= 5%).
//
// Student 07_01 (CMU, 31 joints, ghost on the 21 joints that carry a bone) against teacher 02_01
// with the shipped model. Each benchmark iteration runs one block of 120 frames through
//   (a) the Pipeline (push: stream -> scorer -> retargeter -> placement -> result ring), and
//   (b) a Stream, a Scorer and a Retargeter + place_over_student driven by hand, in the same order,
// alternating which goes first; counters report the per-frame thread CPU time of each and their
// ratio.
// BM_Pipeline* alone gives the plain per-frame figure.
#include <algorithm>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "pipeline/pipeline.hpp"
#include "support/clips.hpp"

namespace {

// Thread CPU time: the machines are shared, and wall time would charge other processes' load to
// whichever side happened to run during it.
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Setup {
  std::shared_ptr<const kata::pipeline::Teacher> teacher;
  kata::pipeline::PipelineConfig config;
  std::vector<float> frames;  // student frames x joints x 3
  int frame_count = 0, joints = 0;
  double frame_time = 0.0;

  static const Setup& get() {
    static const Setup instance = [] {
      Setup s;
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
      s.config.result_capacity = 256;
      s.frames = kata::test::clip_positions("07_01", 1);
      s.frame_count = st.frame_count() - 1;
      s.joints = st.skeleton.joint_count();
      s.frame_time = st.frame_time;
      return s;
    }();
    return instance;
  }
  const float* frame(int i) const { return frames.data() + static_cast<size_t>(i % frame_count) * 3 * joints; }
};

// The three stages by hand, with the state a pipeline holds.
struct Stages {
  explicit Stages(const Setup& s)
      : stream(s.config.stream),
        scorer(s.teacher->reference),
        selection(kata::retarget::select_joints(s.teacher->skeleton, s.config.student, "cmu")),
        retargeter(selection.parents, kata::retarget::selected_rest_lengths(s.config.student, selection), {},
                   kata::retarget::selected_rest_directions(s.config.student, selection)),
        teacher(3 * selection.source.size()),
        student(3 * selection.source.size()),
        ghost(3 * selection.source.size()),
        teacher_(s.teacher.get()) {}

  void push(double t, const float* xyz, int joints) {
    stream.push(t, xyz, joints);
    const kata::metric::ScoreRecord& r = scorer.score(stream.features(), stream.feature_time());
    const float* tf = teacher_->frame_positions(r.matched);
    for (size_t j = 0; j < selection.source.size(); ++j)
      for (int c = 0; c < 3; ++c) {
        teacher[3 * j + c] = tf[3 * static_cast<size_t>(selection.source[j]) + c];
        student[3 * j + c] = xyz[3 * static_cast<size_t>(selection.source[j]) + c];
      }
    retargeter.retarget(teacher.data(), ghost.data());
    kata::retarget::place_over_student(static_cast<int>(selection.source.size()), student.data(), ghost.data());
    benchmark::DoNotOptimize(ghost.data());
  }

  kata::Stream stream;
  kata::metric::Scorer scorer;
  kata::retarget::JointSelection selection;
  kata::retarget::Retargeter retargeter;
  std::vector<double> teacher, student, ghost;
  const kata::pipeline::Teacher* teacher_;
};

constexpr int kBlock = 120;

void BM_PipelinePush(benchmark::State& state) {
  const Setup& s = Setup::get();
  kata::pipeline::Pipeline p(s.config);
  p.set_teacher(s.teacher);
  std::vector<kata::pipeline::Result> out(256);
  int64_t i = 0;
  for (auto _ : state) {
    p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
    if (p.pending() >= 128) p.read(out.data(), nullptr, nullptr, out.size());
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PipelinePush);

void BM_PipelineVsStages(benchmark::State& state) {
  const Setup& s = Setup::get();
  kata::pipeline::Pipeline p(s.config);
  p.set_teacher(s.teacher);
  Stages stages(s);
  std::vector<kata::pipeline::Result> out(256);
  int64_t next = 0;
  double pipeline_s = 0.0, stages_s = 0.0;
  bool pipeline_first = true;
  for (auto _ : state) {
    auto run_pipeline = [&] {
      const double t0 = thread_cpu_seconds();
      for (int k = 0; k < kBlock; ++k) {
        const int64_t i = next + k;
        p.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
      }
      p.read(out.data(), nullptr, nullptr, out.size());
      pipeline_s += thread_cpu_seconds() - t0;
    };
    auto run_stages = [&] {
      const double t0 = thread_cpu_seconds();
      for (int k = 0; k < kBlock; ++k) {
        const int64_t i = next + k;
        stages.push(static_cast<double>(i) * s.frame_time, s.frame(static_cast<int>(i)), s.joints);
      }
      stages_s += thread_cpu_seconds() - t0;
    };
    if (pipeline_first) {
      run_pipeline();
      run_stages();
    } else {
      run_stages();
      run_pipeline();
    }
    pipeline_first = !pipeline_first;
    next += kBlock;
  }
  const double frames = static_cast<double>(next);
  state.counters["pipeline_us_per_frame"] = 1e6 * pipeline_s / frames;
  state.counters["stages_us_per_frame"] = 1e6 * stages_s / frames;
  state.counters["pipeline_over_stages"] = pipeline_s / stages_s;
  state.SetItemsProcessed(next);
}
BENCHMARK(BM_PipelineVsStages)->Unit(benchmark::kMillisecond);

}  // namespace
