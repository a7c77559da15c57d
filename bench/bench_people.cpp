// The people tracker's cost per frame (people::Tracker::track, what kata_people_track runs): N
// people of MediaPipe's 33 landmarks walking on parallel lines, poses given in a rotating order,
// 30 Hz. Arg: N. Reported per frame; items = poses.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "people/tracker.hpp"

namespace {

void BM_PeopleTrack(benchmark::State& state) {
  const int people = static_cast<int>(state.range(0));
  constexpr int J = 33;
  kata::people::TrackerConfig c;
  c.joints = J;
  c.max_people = 16;
  kata::people::Tracker tracker(c);
  // 120 frames of every person, precomputed (a figure 1.7 m tall whose limbs swing).
  constexpr int kFrames = 120;
  std::vector<float> frames(static_cast<size_t>(kFrames) * people * J * 3);
  for (int f = 0; f < kFrames; ++f)
    for (int p = 0; p < people; ++p) {
      const int slot = (p + f) % people;  // a rotating order
      float* x = frames.data() + ((static_cast<size_t>(f) * people + slot) * J) * 3;
      for (int j = 0; j < J; ++j) {
        x[3 * j] = static_cast<float>(-3.0 + 1.5 * p + 0.8 * f / 30.0 + 0.2 * std::sin(0.3 * f + j));
        x[3 * j + 1] = static_cast<float>(1.7 * j / (J - 1));
        x[3 * j + 2] = static_cast<float>(0.5 * (p % 2));
      }
    }
  std::vector<uint32_t> ids(static_cast<size_t>(people));
  double t = 0.0;
  int f = 0;
  for (auto _ : state) {
    tracker.track(t, frames.data() + static_cast<size_t>(f) * people * J * 3, nullptr, people, ids.data());
    benchmark::DoNotOptimize(ids.data());
    t += 1.0 / 30.0;
    f = (f + 1) % kFrames;
  }
  state.SetItemsProcessed(state.iterations() * people);
}
BENCHMARK(BM_PeopleTrack)->Arg(1)->Arg(2)->Arg(4)->Arg(8);

}  // namespace
