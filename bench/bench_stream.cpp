// Per-frame cost of GPD v1 features (static blocks + kinetics) through the live stream API, on a
// real clip, single thread. Run: build/bin/kata_bench --benchmark_filter=Stream
//   --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "stream/stream.hpp"

namespace {

struct ClipData {
  kata::BvhClip clip;
  kata::GpdMap map;
  std::vector<float> frames;  // frames x joints x 3
  int joints = 0, count = 0;
};

const ClipData& dance() {
  static const ClipData data = [] {
    ClipData d{kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/05_02.bvh"), {}, {}, 0, 0};
    d.map = kata::make_gpd_map(d.clip.skeleton, kata::preset_joint_names("cmu"));
    d.joints = d.clip.skeleton.joint_count();
    d.count = d.clip.frame_count() - 1;  // skip the T-pose
    Eigen::MatrixX3d w(d.joints, 3);
    for (int i = 1; i <= d.count; ++i) {
      kata::world_positions(d.clip, i, w);
      for (int j = 0; j < d.joints; ++j)
        for (int k = 0; k < 3; ++k) d.frames.push_back(static_cast<float>(w(j, k)));
    }
    return d;
  }();
  return data;
}

void run_stream(benchmark::State& state, kata::gpd::Stencil stencil) {
  const ClipData& d = dance();
  kata::Stream stream(kata::stream_config_for(d.clip.skeleton, d.map, stencil));
  double t = 0.0;
  int i = 0;
  float sink = 0.0f;
  for (auto _ : state) {
    stream.push(t, d.frames.data() + static_cast<size_t>(i) * 3 * d.joints, d.joints);
    if (const float* f = stream.features()) sink += f[kata::gpd::kDims - 1];
    t += d.clip.frame_time;
    if (++i == d.count) i = 0;  // loop the clip; the jump back is just a fast motion
  }
  benchmark::DoNotOptimize(sink);
  state.SetItemsProcessed(state.iterations());  // one frame per iteration: Time is the per-frame cost
}

void BM_StreamFeatures_Backward(benchmark::State& state) { run_stream(state, kata::gpd::Stencil::kBackward); }
void BM_StreamFeatures_Central(benchmark::State& state) { run_stream(state, kata::gpd::Stencil::kCentral); }
BENCHMARK(BM_StreamFeatures_Backward);
BENCHMARK(BM_StreamFeatures_Central);

}  // namespace
