// Cost per frame of the "any body" steps, side by side in one run: MediaPipe landmark
// synthesis, the confidence gate, One-Euro smoothing (each as a whole stream push, so the ratio
// to the plain push is the step's cost), a cross-layout retarget onto the 16 GPD joints, and the
// ghost as local rotations on a CMU hierarchy.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "io/bvh.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/local_rotations.hpp"
#include "retarget/mapped.hpp"
#include "skeleton/skeleton.hpp"
#include "stream/stream.hpp"

namespace {

// 64 frames of a swaying 33-landmark body in MediaPipe's camera axes (metres, y down).
std::vector<float> landmark_frames() {
  std::vector<float> out;
  for (int f = 0; f < 64; ++f) {
    for (int i = 0; i < kata::kMediaPipeLandmarkCount; ++i) {
      const float side = (i % 2) ? -1.0f : 1.0f;
      const float height = 0.9f - 0.05f * static_cast<float>(i);  // head (low ids) up, feet down
      out.push_back(side * (0.1f + 0.004f * i) + 0.02f * std::sin(0.2f * f + i));
      out.push_back(-height + 0.01f * std::cos(0.3f * f + i));
      out.push_back(0.03f * std::sin(0.1f * f + 2.0f * i));
    }
  }
  return out;
}

void BM_AnybodyMediaPipeSynthesis(benchmark::State& st) {
  const kata::Skeleton skel = kata::layout_skeleton("mediapipe");
  const kata::Layout layout = kata::resolve_layout(skel, "mediapipe");
  const std::vector<float> frames = landmark_frames();
  float gpd[48];
  size_t f = 0;
  for (auto _ : st) {
    kata::map_to_gpd(layout.map, layout.axes, frames.data() + (f++ % 64) * 99, gpd);
    benchmark::DoNotOptimize(gpd);
  }
}
BENCHMARK(BM_AnybodyMediaPipeSynthesis);

// Whole push of a MediaPipe frame: 0 plain, 1 with confidences (gate), 2 gate + One-Euro.
void BM_AnybodyStreamPush(benchmark::State& st) {
  const int mode = static_cast<int>(st.range(0));
  const kata::Skeleton skel = kata::layout_skeleton("mediapipe");
  const kata::Layout layout = kata::resolve_layout(skel, "mediapipe");
  kata::StreamConfig config;
  config.map = layout.map;
  config.input_joints = skel.joint_count();
  config.up_axis = layout.axes;
  config.smoothing = mode == 2;
  kata::Stream stream(config);
  const std::vector<float> frames = landmark_frames();
  std::vector<float> conf(kata::kMediaPipeLandmarkCount, 0.9f);
  double t = 0.0;
  size_t f = 0;
  for (auto _ : st) {
    const float* xyz = frames.data() + (f++ % 64) * 99;
    t += 1.0 / 30.0;
    benchmark::DoNotOptimize(mode == 0 ? stream.push(t, xyz, kata::kMediaPipeLandmarkCount)
                                       : stream.push(t, xyz, conf.data(), kata::kMediaPipeLandmarkCount));
  }
}
BENCHMARK(BM_AnybodyStreamPush)->Arg(0)->Arg(1)->Arg(2);

// A 16-joint teacher (gpd layout, Y up) onto a MediaPipe student: one warm solve per frame.
void BM_AnybodyCrossLayoutRetarget(benchmark::State& st) {
  const kata::Skeleton student = kata::layout_skeleton("mediapipe");
  const kata::Skeleton teacher = kata::layout_skeleton("gpd");
  const kata::retarget::MappedSide t{kata::resolve_layout(teacher, "gpd").map, kata::UpAxis::kYDown, 16};
  const kata::Layout sl = kata::resolve_layout(student, "mediapipe");
  const kata::retarget::MappedSide s{sl.map, sl.axes, 33};
  std::array<double, kata::kGpdJoints> lengths{};
  for (int g = 1; g < kata::kGpdJoints; ++g) lengths[static_cast<size_t>(g)] = 0.2 + 0.01 * g;
  kata::retarget::MappedRetargeter rt(t, s, lengths);
  // Teacher frames: the GPD joints of the landmark frames (already in camera axes).
  const std::vector<float> frames = landmark_frames();
  std::vector<float> teacher_frames(64 * 48);
  for (int f = 0; f < 64; ++f) kata::map_to_gpd(sl.map, kata::UpAxis::kY, frames.data() + f * 99, &teacher_frames[static_cast<size_t>(f) * 48]);
  float ghost[48];
  size_t f = 0;
  for (auto _ : st) {
    rt.retarget(teacher_frames.data() + (f++ % 64) * 48, ghost);
    benchmark::DoNotOptimize(ghost);
  }
}
BENCHMARK(BM_AnybodyCrossLayoutRetarget);

// The ghost as local rotations on a CMU student's 31-joint hierarchy (21 ghost joints, the "cmu"
// joint set): the clip's own frames stand for ghosts (every joint placed, bones exact).
void BM_AnybodyLocalRotations(benchmark::State& st) {
  const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/07_01.bvh");
  const auto sel = kata::retarget::select_joints(clip.skeleton, clip.skeleton, "cmu");
  kata::retarget::LocalRotations rotations(clip.skeleton, sel.source);
  const int frames = std::min(64, clip.frame_count());
  const size_t g = sel.source.size();
  std::vector<double> ghosts(static_cast<size_t>(frames) * 3 * g);
  Eigen::MatrixX3d world(clip.skeleton.joint_count(), 3);
  for (int f = 0; f < frames; ++f) {
    kata::world_positions(clip, f, world);
    kata::retarget::gather_positions(world, sel, ghosts.data() + static_cast<size_t>(f) * 3 * g);
  }
  std::vector<double> quats(4 * static_cast<size_t>(clip.skeleton.joint_count()));
  double root[3];
  size_t f = 0;
  for (auto _ : st) {
    rotations.solve(ghosts.data() + (f++ % static_cast<size_t>(frames)) * 3 * g, quats.data(), root, nullptr);
    benchmark::DoNotOptimize(quats.data());
  }
}
BENCHMARK(BM_AnybodyLocalRotations);

}  // namespace
