// GPD v1 per-frame cost on real poses (CMU 02_01, 05_02): static blocks + kinetics, for the
// dispatched fast path, each SIMD kernel explicitly, and the double reference.
//   build/bin/kata_bench --benchmark_filter=Gpd --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/cpu.hpp"
#include "gpd/gpd.hpp"
#include "gpd/gpd_detail.hpp"
#include "io/bvh.hpp"
#include "skeleton/skeleton.hpp"

namespace {

using namespace kata::gpd;

// Local-frame poses of two clips (walk and dance), with each frame's block 1 for the kinetics.
struct Poses {
  std::vector<float> local;  // frames x 48
  std::vector<float> hip;    // frames
  std::vector<float> jc;     // frames x 46
  std::vector<float> world;  // frames x 48
  double height = 1.0;
  int frames = 0;
};

const Poses& poses() {
  static const Poses p = [] {
    Poses r;
    for (const char* name : {"02_01", "05_02"}) {
      const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/" + name + ".bvh");
      const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
      const double h = kata::rest_body_height(clip.skeleton, map);
      r.height = h;
      Eigen::MatrixX3d pos(clip.skeleton.joint_count(), 3);
      GeometryState state;
      for (int i = 0; i < clip.frame_count(); ++i) {
        kata::world_positions(clip, i, pos);
        float world[48], local[48], hip = 0;
        for (int j = 0; j < 16; ++j) {
          for (int k = 0; k < 3; ++k) world[3 * j + k] = static_cast<float>(pos(map.source[j], k));
        }
        to_local_frame(world, h, state, local, &hip);
        r.world.insert(r.world.end(), world, world + 48);
        r.local.insert(r.local.end(), local, local + 48);
        r.hip.push_back(hip);
        r.jc.insert(r.jc.end(), local + 3, local + 48);
        r.jc.push_back(hip);
        ++r.frames;
      }
    }
    return r;
  }();
  return p;
}

enum class Impl { kDispatch, kBaseline, kAvx2 };

// static_features + kinetics (backward stencil) per frame, cycling through the clips.
void BM_GpdFrame(benchmark::State& st, Impl impl) {
  if (impl == Impl::kAvx2 && !(detail::avx2::compiled() && kata::cpu_has_avx2())) {
    st.SkipWithError("no AVX2 on this CPU (or KATA_NO_AVX2=1)");
    return;
  }
  const Poses& p = poses();
  std::vector<float> out(kDims);
  GeometryState state;
  const DifferenceWeights w = backward_weights(1.0 / 120, 1.0 / 120);
  int f = 2;
  for (auto _ : st) {
    const float* local = p.local.data() + 48 * static_cast<size_t>(f);
    switch (impl) {
      case Impl::kDispatch: static_features(local, p.hip[f], state, out.data()); break;
      case Impl::kBaseline: detail::sse4::static_features(local, p.hip[f], state, out.data()); break;
      case Impl::kAvx2: detail::avx2::static_features(local, p.hip[f], state, out.data()); break;
    }
    kinetics(p.jc.data() + 46 * static_cast<size_t>(f - 2), p.jc.data() + 46 * static_cast<size_t>(f - 1), out.data(),
             w, out.data() + kOffsetJk);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    if (++f == p.frames) f = 2;
  }
  st.SetItemsProcessed(st.iterations());
}
BENCHMARK_CAPTURE(BM_GpdFrame, dispatch, Impl::kDispatch);
BENCHMARK_CAPTURE(BM_GpdFrame, avx2, Impl::kAvx2);
BENCHMARK_CAPTURE(BM_GpdFrame, baseline, Impl::kBaseline);

// The same with the double reference for the static blocks.
void BM_GpdFrameReference(benchmark::State& st) {
  const Poses& p = poses();
  std::vector<double> ref(kStaticDims);
  std::vector<float> kin(kKineticDims);
  GeometryState state;
  const DifferenceWeights w = backward_weights(1.0 / 120, 1.0 / 120);
  int f = 2;
  for (auto _ : st) {
    detail::static_features_reference(p.local.data() + 48 * static_cast<size_t>(f), p.hip[f], state, ref.data());
    kinetics(p.jc.data() + 46 * static_cast<size_t>(f - 2), p.jc.data() + 46 * static_cast<size_t>(f - 1),
             p.jc.data() + 46 * static_cast<size_t>(f), w, kin.data());
    benchmark::DoNotOptimize(ref.data());
    benchmark::DoNotOptimize(kin.data());
    benchmark::ClobberMemory();
    if (++f == p.frames) f = 2;
  }
  st.SetItemsProcessed(st.iterations());
}
BENCHMARK(BM_GpdFrameReference);

// The parts alone: the local frame, and the kinetics kernel.
void BM_GpdLocalFrame(benchmark::State& st) {
  const Poses& p = poses();
  GeometryState state;
  float local[48], hip = 0;
  int f = 0;
  for (auto _ : st) {
    to_local_frame(p.world.data() + 48 * static_cast<size_t>(f), p.height, state, local, &hip);
    benchmark::DoNotOptimize(local);
    benchmark::ClobberMemory();
    if (++f == p.frames) f = 0;
  }
}
BENCHMARK(BM_GpdLocalFrame);

void BM_GpdKinetics(benchmark::State& st) {
  const Poses& p = poses();
  float kin[kKineticDims];
  const DifferenceWeights w = backward_weights(1.0 / 120, 1.0 / 120);
  int f = 2;
  for (auto _ : st) {
    kinetics(p.jc.data() + 46 * static_cast<size_t>(f - 2), p.jc.data() + 46 * static_cast<size_t>(f - 1),
             p.jc.data() + 46 * static_cast<size_t>(f), w, kin);
    benchmark::DoNotOptimize(kin);
    benchmark::ClobberMemory();
    if (++f == p.frames) f = 2;
  }
}
BENCHMARK(BM_GpdKinetics);

}  // namespace
