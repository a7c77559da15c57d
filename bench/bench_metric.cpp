// Scoring cost per frame at r = 50 on real poses (CMU 02_01 features through the live stream),
// side by side with a plain Eigen W^T x of the same size; the projection kernels alone (AVX2 and
// baseline); and several streams' frames batched against one W.
//   build/bin/kata_bench --benchmark_filter=Metric --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
// ns/frame is the "per_frame" counter (seconds per frame, shown with its unit).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/cpu.hpp"
#include "eigen_native.hpp"
#include "io/bvh.hpp"
#include "metric/kernels.hpp"
#include "support/random_model.hpp"
#include "metric/scorer.hpp"
#include "skeleton/skeleton.hpp"
#include "io/clip_features.hpp"

namespace {

using namespace kata;
constexpr int kRank = 50;

struct Fixture {
  std::vector<float> rows;  // frames x kDims
  int frames = 0;
  std::shared_ptr<const metric::Metric> metric;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture r;
    const BvhClip clip = load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
    const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
    r.rows = clip_features(clip, map, gpd::Stencil::kBackward, 1);
    r.frames = static_cast<int>(r.rows.size() / gpd::kDims);
    r.metric = std::make_shared<const metric::Metric>(
        metric::make_random_model(kRank, 1, r.rows.data(), r.frames, "02_01.bvh"));
    return r;
  }();
  return f;
}

void per_frame(benchmark::State& state, int frames_per_iteration) {
  state.counters["per_frame"] = benchmark::Counter(static_cast<double>(state.iterations()) * frames_per_iteration,
                                                   benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The baseline the issue names: Eigen's W^T x, W 1683 x 50 floats (column-major, as Eigen
// stores it), compiled at the project's baseline ISA like every other TU here.
void Metric_EigenWtx(benchmark::State& state) {
  const Fixture& f = fixture();
  Eigen::MatrixXf w = Eigen::MatrixXf::Random(gpd::kDims, kRank);
  Eigen::VectorXf y(kRank);
  int i = 0;
  for (auto _ : state) {
    const Eigen::Map<const Eigen::VectorXf> x(f.rows.data() + static_cast<size_t>(i) * gpd::kDims, gpd::kDims);
    y.noalias() = w.transpose() * x;
    benchmark::DoNotOptimize(y.data());
    benchmark::ClobberMemory();
    if (++i == f.frames) i = 0;
  }
  per_frame(state, 1);
}
BENCHMARK(Metric_EigenWtx);

// The anchor: the same product with Eigen built for this machine (-march=native, a
// separate shared library), x cycling over the same real frames.
void Metric_EigenWtxNative(benchmark::State& state) {
  const Fixture& f = fixture();
  const Eigen::MatrixXf w = Eigen::MatrixXf::Random(gpd::kDims, kRank);
  std::vector<float> y(kRank);
  int i = 0;
  for (auto _ : state) {
    kata_bench::eigen_native_wtx(w.data(), gpd::kDims, kRank, f.rows.data() + static_cast<size_t>(i) * gpd::kDims,
                                 y.data());
    benchmark::DoNotOptimize(y.data());
    benchmark::ClobberMemory();
    if (++i == f.frames) i = 0;
  }
  per_frame(state, 1);
}
BENCHMARK(Metric_EigenWtxNative);

// What a half-precision W would buy (not shipped): the same row-major loop over fp16 and fp32 W,
// both -march=native, x cycling over the real frames. fp16 streams half the bytes from L2.
template <bool kHalf>
void Metric_RowMajorWtx(benchmark::State& state) {
  const Fixture& f = fixture();
  std::vector<float> w(static_cast<size_t>(gpd::kDims) * kRank);
  for (size_t k = 0; k < w.size(); ++k) w[k] = 0.001f * static_cast<float>(k % 997);
  std::vector<uint16_t> half(w.size(), 0x3c00);  // 1.0 in fp16: the cost does not depend on values
  std::vector<float> y(kRank);
  int i = 0;
  for (auto _ : state) {
    const float* x = f.rows.data() + static_cast<size_t>(i) * gpd::kDims;
    if constexpr (kHalf)
      kata_bench::fp16_wtx(half.data(), gpd::kDims, kRank, x, y.data());
    else
      kata_bench::fp32_wtx_rowmajor(w.data(), gpd::kDims, kRank, x, y.data());
    benchmark::DoNotOptimize(y.data());
    benchmark::ClobberMemory();
    if (++i == f.frames) i = 0;
  }
  per_frame(state, 1);
}
BENCHMARK(Metric_RowMajorWtx<false>)->Name("Metric_RowMajorWtxFp32Native");
BENCHMARK(Metric_RowMajorWtx<true>)->Name("Metric_RowMajorWtxFp16Native");

// Everything per frame after features: normalise, project (parts + static rows), distance,
// score, breakdown, against a pose reference.
void Metric_ScorePose(benchmark::State& state) {
  const Fixture& f = fixture();
  metric::Scorer scorer(std::make_shared<const metric::Reference>(f.metric, f.rows.data() + 10 * gpd::kDims));
  int i = 0;
  double t = 0.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(scorer.score(f.rows.data() + static_cast<size_t>(i) * gpd::kDims, t += 1.0 / 120).distance);
    if (++i == f.frames) i = 0;
  }
  per_frame(state, 1);
  state.counters["groups"] = f.metric->groups();
  state.SetLabel(cpu_has_avx512() ? "avx512" : cpu_has_avx2() ? "avx2" : "baseline");
}
BENCHMARK(Metric_ScorePose);

// The same against the whole clip as reference (adds the online alignment).
void Metric_ScoreClip(benchmark::State& state) {
  const Fixture& f = fixture();
  const auto ref = std::make_shared<const metric::Reference>(f.metric, f.rows.data(), f.frames, 1.0 / 120);
  metric::Scorer scorer(ref);
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(scorer.score(f.rows.data() + static_cast<size_t>(i) * gpd::kDims, i / 120.0).matched);
    if (++i == f.frames) {
      i = 0;
      scorer.reset();
    }
  }
  per_frame(state, 1);
}
BENCHMARK(Metric_ScoreClip);

// Several streams, one frame each, scored in one call sharing the passes over W.
void Metric_ScoreBatch(benchmark::State& state) {
  const Fixture& f = fixture();
  const int n = static_cast<int>(state.range(0));
  const auto ref = std::make_shared<const metric::Reference>(f.metric, f.rows.data() + 10 * gpd::kDims);
  std::vector<std::unique_ptr<metric::Scorer>> scorers;
  std::vector<metric::Scorer*> ptrs;
  std::vector<const float*> xs(static_cast<size_t>(n));
  std::vector<double> ts(static_cast<size_t>(n), 0.0);
  for (int s = 0; s < n; ++s) {
    scorers.push_back(std::make_unique<metric::Scorer>(ref));
    ptrs.push_back(scorers.back().get());
  }
  int i = 0;
  for (auto _ : state) {
    for (int s = 0; s < n; ++s) {
      xs[static_cast<size_t>(s)] = f.rows.data() + static_cast<size_t>((i + 37 * s) % f.frames) * gpd::kDims;
      ts[static_cast<size_t>(s)] += 1.0 / 120;
    }
    metric::Scorer::score_batch(ptrs.data(), xs.data(), ts.data(), n);
    benchmark::DoNotOptimize(ptrs[0]->last().distance);
    if (++i == f.frames) i = 0;
  }
  per_frame(state, n);
}
BENCHMARK(Metric_ScoreBatch)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Arg(16);

// The projection kernel alone (one pass over the blocked W), each implementation explicitly.
// kAvx512 reads the pair-packed W the metric uses on AVX-512 (kernels.hpp BlockedW::pairs);
// kAvx512Int16 the 16-bit integers the other ISAs read.
enum class Isa { kBase, kAvx2, kAvx512, kAvx512Int16 };
// kRows: how many rows of W one pass walks (0: all 1683). 300 rows
// of 50 int16 columns are 30 KB and stay in L1 (48 KiB here): per row, the kernel's instruction
// cost; over 1683 rows (168 KB, from L2) the cost of streaming W from L2 too.
template <Isa kIsa, int kRows = 0>
void Metric_Kernel(benchmark::State& state) {
  if ((kIsa == Isa::kAvx2 && !cpu_has_avx2()) || ((kIsa == Isa::kAvx512 || kIsa == Isa::kAvx512Int16) && !cpu_has_avx512())) {
    state.SkipWithError("instruction set not available");
    return;
  }
  const Fixture& f = fixture();
  metric::Metric::Workspace ws = f.metric->make_workspace();
  // Reuse the metric's normalised input; the kernel's cost does not depend on values.
  std::vector<float> p(static_cast<size_t>(metric::kProjectionRows) * f.metric->stride());
  f.metric->part_projections(f.rows.data(), ws, p.data());
  // A blocked view equivalent to the metric's (same sizes and grouping, random values).
  std::vector<int16_t> w(static_cast<size_t>(gpd::kDims) * kRank, 16384);
  std::vector<float> scale(static_cast<size_t>(kRank), 1.0f / 32768);
  const int rows = kRows > 0 ? kRows : gpd::kDims;
  const std::vector<int> groups = {0, rows / 5, 2 * rows / 5, 3 * rows / 5, 4 * rows / 5, rows};
  metric::detail::BlockedW bw;
  bw.data = w.data();
  bw.column_scale = scale.data();
  bw.rows = gpd::kDims;
  bw.rank = kRank;
  bw.out_stride = f.metric->stride();
  bw.groups = static_cast<int>(groups.size()) - 1;
  bw.group_begin = groups.data();
  std::vector<int> perm(gpd::kDims);
  for (int k = 0; k < gpd::kDims; ++k) perm[static_cast<size_t>(k)] = (k * 7) % gpd::kDims;
  bw.perm = perm.data();
  // 64-byte aligned, as Metric holds it.
  std::vector<uint32_t> pairs(metric::detail::pair_words_total(gpd::kDims, kRank) + 15);
  uint32_t* aligned = pairs.data() + ((64 - reinterpret_cast<uintptr_t>(pairs.data()) % 64) % 64) / sizeof(uint32_t);
  const std::vector<double> steps(w.begin(), w.end());
  metric::detail::pack_pairs(steps.data(), gpd::kDims, kRank, aligned);
  if (kIsa == Isa::kAvx512) bw.pairs = aligned;
  std::vector<float> v(static_cast<size_t>(bw.groups) * bw.out_stride);
  for (auto _ : state) {
    if constexpr (kIsa == Isa::kAvx512 || kIsa == Isa::kAvx512Int16)
      metric::detail::avx512::project_groups(bw, ws.xp.data(), v.data());
    else if constexpr (kIsa == Isa::kAvx2)
      metric::detail::avx2::project_groups(bw, ws.xp.data(), v.data());
    else
      metric::detail::base::project_groups(bw, ws.xp.data(), v.data());
    benchmark::DoNotOptimize(v.data());
    benchmark::ClobberMemory();
  }
  per_frame(state, 1);
}
BENCHMARK(Metric_Kernel<Isa::kAvx512>)->Name("Metric_KernelAvx512");
BENCHMARK(Metric_Kernel<Isa::kAvx512Int16>)->Name("Metric_KernelAvx512Int16");
BENCHMARK(Metric_Kernel<Isa::kAvx2>)->Name("Metric_KernelAvx2");
BENCHMARK(Metric_Kernel<Isa::kAvx512, 300>)->Name("Metric_KernelAvx512L1");
BENCHMARK(Metric_Kernel<Isa::kAvx512Int16, 300>)->Name("Metric_KernelAvx512Int16L1");
BENCHMARK(Metric_Kernel<Isa::kAvx2, 300>)->Name("Metric_KernelAvx2L1");
BENCHMARK(Metric_Kernel<Isa::kBase>)->Name("Metric_KernelBaseline");

}  // namespace
