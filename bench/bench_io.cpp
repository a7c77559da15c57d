// Benchmarks of the io module on a shipped CMU clip: per-frame forward kinematics (the live
// path) and whole-file BVH parsing.
#include <benchmark/benchmark.h>

#include <string>

#include "io/bvh.hpp"

namespace {

const std::string kClip = std::string(KATA_DATA_DIR) + "/cmu/05_02.bvh";  // 1124 frames, 31 joints

// world_positions for one frame, cycling through the clip; reports frames per second.
void BM_WorldPositionsPerFrame(benchmark::State& state) {
  static const kata::BvhClip clip = kata::load_bvh(kClip);
  Eigen::MatrixX3d out(clip.skeleton.joint_count(), 3);
  int i = 0;
  for (auto _ : state) {
    kata::world_positions(clip, i, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    if (++i == clip.frame_count()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorldPositionsPerFrame);

// Reading and parsing the whole clip from disk; reports bytes per second.
void BM_LoadBvh(benchmark::State& state) {
  size_t values = 0;
  for (auto _ : state) {
    const kata::BvhClip clip = kata::load_bvh(kClip);
    values = clip.motion.size();
    benchmark::DoNotOptimize(values);
  }
  state.counters["values"] = static_cast<double>(values);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_LoadBvh)->Unit(benchmark::kMillisecond);

}  // namespace
