// The re-localising alignment's cost per frame on the default lesson's teacher, CMU
// 05_18 (1,829 frames, rank-50 shipped model): the Aligner alone, fed the student's (05_19 on
// subject 2's body) static-blocks projections, with re-localisation (a pass over the whole clip
// every frame) and without it (relocate_time 0: the same DP, the same pass, no moves), and the
// whole-clip pass's distance part on its own.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <thread>
#include <string>
#include <vector>

#include <unistd.h>

#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "metric/align.hpp"
#include "metric/scorer.hpp"

namespace kata {
namespace {

struct AlignFixture {
  std::shared_ptr<const metric::Reference> ref;
  std::vector<float> student;  // n x stride static-blocks projections
  int n = 0, stride = 0;
};

// times: the teacher is the clip's frames repeated that many times (long teachers:
// 16x is 4 minutes, 64x 16 minutes); each fixture is built once.
const AlignFixture& align_fixture(int times = 1) {
  static std::map<int, AlignFixture> fixtures;
  auto found = fixtures.find(times);
  if (found != fixtures.end()) return found->second;
  const AlignFixture& f = fixtures[times] = [times] {
    AlignFixture r;
    const auto metric = std::make_shared<const metric::Metric>(
        metric::load_model(std::string(KATA_DATA_DIR) + "/../models/default.kata"));
    auto rows = [&](const char* name) {
      const BvhClip clip = load_bvh(std::string(KATA_DATA_DIR) + "/cmu/" + name);
      return clip_features(clip, make_gpd_map(clip.skeleton, preset_joint_names("cmu")), metric->stencil(), 1);
    };
    const std::vector<float> clip = rows("05_18.bvh"), student = rows("05_19_on_02.bvh");
    std::vector<float> teacher;
    teacher.reserve(clip.size() * static_cast<size_t>(times));
    for (int k = 0; k < times; ++k) teacher.insert(teacher.end(), clip.begin(), clip.end());
    r.ref = std::make_shared<const metric::Reference>(metric, teacher.data(),
                                                      static_cast<int>(teacher.size() / gpd::kDims), 1.0 / 120);
    r.stride = metric->stride();
    r.n = static_cast<int>(student.size() / gpd::kDims);
    r.student.resize(static_cast<size_t>(r.n) * r.stride);
    metric::AlignedFloats p(static_cast<size_t>(metric::kProjectionRows) * r.stride);
    metric::Metric::Workspace ws = metric->make_workspace();
    for (int i = 0; i < r.n; ++i) {
      metric->part_projections(student.data() + static_cast<size_t>(i) * gpd::kDims, ws, p.data());
      std::copy(p.data() + static_cast<size_t>(metric::kParts) * r.stride,
                p.data() + static_cast<size_t>(metric::kParts + 1) * r.stride,
                r.student.data() + static_cast<size_t>(i) * r.stride);
    }
    return r;
  }();
  return f;
}

void run_aligner(benchmark::State& state, double relocate_time, int times = 1) {
  const AlignFixture& f = align_fixture(times);
  metric::AlignmentOptions o;
  o.relocate_time = relocate_time;
  metric::Aligner aligner(f.ref, o);
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(aligner.align(f.student.data() + static_cast<size_t>(i) * f.stride, i / 120.0));
    if (++i == f.n) {
      i = 0;
      aligner.reset();
    }
  }
  state.counters["teacher_frames"] = f.ref->frames();
  state.counters["moves"] = static_cast<double>(aligner.relocations());
}

void Align_Relocating(benchmark::State& state) { run_aligner(state, 0.2); }
BENCHMARK(Align_Relocating);
void Align_NoRelocation(benchmark::State& state) { run_aligner(state, 0.0); }
BENCHMARK(Align_NoRelocation);
// The same with the teacher 1, 16 and 64 times as long (counter search_rows: the rows
// the search reads per frame, window excluded).
void Align_RelocatingLong(benchmark::State& state) {
  run_aligner(state, 0.2, static_cast<int>(state.range(0)));
  const AlignFixture& f = align_fixture(static_cast<int>(state.range(0)));
  metric::Aligner probe(f.ref, metric::AlignmentOptions{});
  const int grid = f.ref->frames() > metric::Reference::kSearchFrames ? f.ref->search_grid() : 1;
  state.counters["search_rows"] = (f.ref->frames() / grid) / static_cast<double>(probe.decimation());
}
BENCHMARK(Align_RelocatingLong)->ArgName("teacher_x")->Arg(1)->Arg(16)->Arg(64);

// The hot aligner timed frame by frame (wall clock): p50_us, and max_us the median over blocks of
// 32 frames of the block's slowest frame, to show the frame that runs the windowed search's
// programme step (one frame in R) beside the others.
void Align_RelocatingPerFrame(benchmark::State& state) {
  const AlignFixture& f = align_fixture();
  metric::AlignmentOptions o;
  o.windowed = state.range(0) == 0;
  metric::Aligner aligner(f.ref, o);
  std::vector<double> took, block_max;
  took.reserve(static_cast<size_t>(state.max_iterations));
  block_max.reserve(static_cast<size_t>(state.max_iterations) / 32 + 1);
  int i = 0;
  double slowest = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(aligner.align(f.student.data() + static_cast<size_t>(i) * f.stride, i / 120.0));
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(dt);
    took.push_back(dt);
    slowest = std::max(slowest, dt);
    if (took.size() % 32 == 0) block_max.push_back(slowest), slowest = 0.0;
    if (++i == f.n) i = 0;
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return 1e6 * v[v.size() / 2];
  };
  state.counters["p50_us"] = median(took);
  state.counters["max_us"] = median(block_max);
  state.counters["decimation"] = aligner.decimation();
}
BENCHMARK(Align_RelocatingPerFrame)
    ->ArgName("whole_section")
    ->DenseRange(0, 1)
    ->UseManualTime()
    ->Iterations(3200)
    ->Unit(benchmark::kMicrosecond);

// The same aligner when a live frame finds the caches cold: between two frames, an 8.3 ms sleep
// (a 120 Hz stream: what the machine leaves in the caches meanwhile) or a 64 MiB write (every
// data line cold). Counter p50_us: the median wall time of one align() of 240.
void run_aligner_paced(benchmark::State& state, int times, bool evict) {
  const AlignFixture& f = align_fixture(times);
  metric::Aligner aligner(f.ref, metric::AlignmentOptions{});
  std::vector<char> buffer(evict ? (64u << 20) : 0, 1);
  std::vector<double> took;
  took.reserve(static_cast<size_t>(state.max_iterations));
  int i = 0;
  char sink = 0;
  for (auto _ : state) {
    if (evict) {
      for (size_t k = 0; k < buffer.size(); k += 64) buffer[k] = static_cast<char>(buffer[k] + 1);
      sink = static_cast<char>(sink + buffer[buffer.size() / 2]);
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(8333));
    }
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(aligner.align(f.student.data() + static_cast<size_t>(i) * f.stride, i / 120.0));
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(dt);
    took.push_back(dt);
    if (++i == f.n) i = 0;
  }
  benchmark::DoNotOptimize(sink);
  std::nth_element(took.begin(), took.begin() + static_cast<long>(took.size() / 2), took.end());
  state.counters["p50_us"] = took.empty() ? 0.0 : 1e6 * took[took.size() / 2];
}
void Align_RelocatingPaced(benchmark::State& state) { run_aligner_paced(state, 1, state.range(0) == 1); }
BENCHMARK(Align_RelocatingPaced)
    ->ArgName("sleep0_evictall1")
    ->DenseRange(0, 1)
    ->UseManualTime()
    ->Iterations(240)
    ->Unit(benchmark::kMicrosecond);
// The paced aligner (8.3 ms sleeps) with the teacher 1, 16 and 64 times as long.
void Align_RelocatingPacedLong(benchmark::State& state) {
  state.SetLabel("sleep");
  run_aligner_paced(state, static_cast<int>(state.range(0)), false);
}
BENCHMARK(Align_RelocatingPacedLong)
    ->ArgName("teacher_x")
    ->Arg(1)
    ->Arg(16)
    ->Arg(64)
    ->UseManualTime()
    ->Iterations(240)
    ->Unit(benchmark::kMicrosecond);

// The distances alone: one dist2f of stride floats per teacher frame.
void Align_DistancePass(benchmark::State& state) {
  const AlignFixture& f = align_fixture();
  const int m = f.ref->frames();
  std::vector<float> c(static_cast<size_t>(m));
  int i = 0;
  for (auto _ : state) {
    const float* s = f.student.data() + static_cast<size_t>(i) * f.stride;
    for (int j = 0; j < m; ++j) c[j] = metric::detail::dist2f(s, f.ref->alignment_projection(j), f.stride);
    benchmark::DoNotOptimize(c.data());
    if (++i == f.n) i = 0;
  }
}
BENCHMARK(Align_DistancePass);

// Loading a long teacher from its file (under a second per 10 minutes of
// teacher): load_bvh, then its Reference from features made and projected chunk by chunk, as
// `kata score`, `kata coach` and `kata serve` load one. The teacher is 05_18 repeated (16x: 4
// minutes, 29,264 frames; 64x: 16 minutes), written once to a temporary file. Real time: the
// loading uses a second thread.
void Load_LongTeacher(benchmark::State& state) {
  const int times = static_cast<int>(state.range(0));
  const auto metric = std::make_shared<const metric::Metric>(
      metric::load_model(std::string(KATA_DATA_DIR) + "/../models/default.kata"));
  BvhClip clip = load_bvh(std::string(KATA_DATA_DIR) + "/cmu/05_18.bvh");
  const std::vector<double> once(clip.motion.begin(), clip.motion.end());
  for (int k = 1; k < times; ++k) clip.motion.insert(clip.motion.end(), once.begin(), once.end());
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("kata_bench_teacher_" + std::to_string(::getpid()) + "_" + std::to_string(times) + ".bvh"))
                               .string();
  write_bvh(path, clip);
  int frames = 0;
  double seconds = 0.0;  // wall, summed over the iterations
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const BvhClip t = load_bvh(path);
    const GpdMap map = make_gpd_map(t.skeleton, preset_joint_names("cmu"));
    frames = t.frame_count() - 1;
    const metric::Reference ref(
        metric,
        [&](const std::function<void(const float*, int)>& sink) {
          clip_features_in_chunks(t, map, metric->stencil(), 1, 1024, sink);
        },
        frames, t.frame_time);
    benchmark::DoNotOptimize(ref.step_cost());
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  std::filesystem::remove(path);
  state.counters["teacher_minutes"] = frames / 120.0 / 60.0;
  // The measure: wall seconds per 10 minutes of teacher (target < 1).
  state.counters["s_per_10_minutes"] = seconds / static_cast<double>(state.iterations()) / (frames / 120.0 / 600.0);
}
BENCHMARK(Load_LongTeacher)->ArgName("teacher_x")->Arg(16)->Arg(64)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

}  // namespace
}  // namespace kata
