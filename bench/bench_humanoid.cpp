// The humanoid (VRM) rig's cost per frame (kata/humanoid.h): the student's and the ghost's bone
// rotations added to a stream's push, through the C ABI as an app calls it.
//
// Student 07_01 (CMU, 31 joints; its ghost on the 21 joints that carry a bone) against teacher 02_01
// with the shipped model. BM_HumanoidPushSideBySide runs two identical streams on the same frames,
// block by block (120 frames), alternating which goes first:
//   base:     kata_stream_push + kata_stream_read_newest (the result and its ghost), and
//   humanoid: the same + kata_humanoid_rig_pose (student) + kata_humanoid_rig_pose_ghost (ghost),
//             both in Unity's frame (what a VMC sender sends);
// counters: each side's thread CPU time per frame and added_us, their difference.
// BM_HumanoidPoses times the two rig calls alone, on the frames and ghosts recorded from the same
// stream (the added cost without the push's noise around it).
#include <algorithm>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "kata/kata.h"

namespace {

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// A clip's frames (file units), frames 1.. (frame 0 is the T-pose).
struct Frames {
  std::vector<float> xyz;
  uint32_t joints = 0, count = 0;
  double frame_time = 0;
  const float* frame(uint64_t i) const { return xyz.data() + (i % count) * 3 * joints; }
};

struct Session {
  kata_context ctx = nullptr;
  kata_clip student = nullptr, teacher = nullptr;
  kata_skeleton skel = nullptr;
  kata_model model = nullptr;
  Frames frames;
  Session() {
    kata_context_create(&ctx);
    kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/07_01.bvh", &student);
    kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &teacher);
    kata_clip_skeleton(student, &skel);
    kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model);
    frames.joints = kata_skeleton_joint_count(skel);
    frames.count = kata_clip_frame_count(student) - 1;
    frames.frame_time = kata_clip_frame_time(student);
    frames.xyz.resize(static_cast<size_t>(frames.count) * 3 * frames.joints);
    for (uint32_t f = 0; f < frames.count; ++f)
      kata_clip_positions(student, f + 1, frames.xyz.data() + static_cast<size_t>(f) * 3 * frames.joints,
                          3 * static_cast<size_t>(frames.joints));
  }
  ~Session() {
    kata_model_destroy(model);
    kata_skeleton_destroy(skel);
    kata_clip_destroy(teacher);
    kata_clip_destroy(student);
    kata_context_destroy(ctx);
  }
  static const Session& get() {
    static const Session s;
    return s;
  }
};

// One stream with the teacher attached and, when asked, its rig.
struct Side {
  kata_stream stream = nullptr;
  kata_humanoid_rig rig = nullptr;
  std::vector<float> ghost;
  kata_result_record record{};
  kata_humanoid_pose student_pose{}, ghost_pose{};
  uint32_t ghost_joints = 0;
  Side(const Session& s, bool humanoid) {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "cmu";
    d.result_capacity = 256;
    kata_stream_open(s.ctx, s.skel, &d, &stream);
    kata_teacher_desc t;
    kata_teacher_desc_init(&t);
    t.model = s.model;
    t.clip = s.teacher;
    t.first_frame = 1;
    kata_stream_attach_teacher(stream, &t);
    ghost_joints = kata_stream_ghost_joint_count(stream);
    ghost.resize(3 * static_cast<size_t>(ghost_joints));
    record.struct_size = sizeof record;
    student_pose.struct_size = ghost_pose.struct_size = sizeof(kata_humanoid_pose);
    if (humanoid) kata_humanoid_rig_create_for_stream(s.ctx, stream, nullptr, &rig);
  }
  ~Side() {
    kata_humanoid_rig_destroy(rig);
    kata_stream_destroy(stream);
  }
  void push(double t, const float* xyz, uint32_t joints) {
    kata_stream_push(stream, t, xyz, joints);
    const bool fresh = kata_stream_read_newest(stream, &record, ghost.data(), ghost.size(), nullptr, 0) == KATA_OK;
    if (rig) {
      kata_humanoid_rig_pose(rig, xyz, joints, KATA_HUMANOID_UNITY, &student_pose);
      if (fresh && record.ghost_joint_count)
        kata_humanoid_rig_pose_ghost(rig, ghost.data(), ghost_joints, KATA_HUMANOID_UNITY, &ghost_pose);
    }
    benchmark::DoNotOptimize(record.score);
    benchmark::DoNotOptimize(ghost_pose.rotation[0][0]);
  }
};

constexpr int kBlock = 120;

void BM_HumanoidPushSideBySide(benchmark::State& state) {
  const Session& s = Session::get();
  Side base(s, false), humanoid(s, true);
  if (!humanoid.rig) {
    state.SkipWithError("kata_humanoid_rig_create_for_stream failed");
    return;
  }
  uint64_t i = 0;
  double base_s = 0, humanoid_s = 0;
  int64_t frames = 0;
  bool base_first = true;
  for (auto _ : state) {
    auto run = [&](Side& side, uint64_t from) {
      const double t0 = thread_cpu_seconds();
      for (uint64_t k = from; k < from + kBlock; ++k) side.push(static_cast<double>(k) * s.frames.frame_time, s.frames.frame(k), s.frames.joints);
      return thread_cpu_seconds() - t0;
    };
    if (base_first) {
      base_s += run(base, i);
      humanoid_s += run(humanoid, i);
    } else {
      humanoid_s += run(humanoid, i);
      base_s += run(base, i);
    }
    base_first = !base_first;
    i += kBlock;
    frames += kBlock;
  }
  state.counters["base_us"] = 1e6 * base_s / static_cast<double>(frames);
  state.counters["humanoid_us"] = 1e6 * humanoid_s / static_cast<double>(frames);
  state.counters["added_us"] = 1e6 * (humanoid_s - base_s) / static_cast<double>(frames);
  state.SetItemsProcessed(frames);
}
BENCHMARK(BM_HumanoidPushSideBySide)->Unit(benchmark::kMillisecond)->MinTime(2.0);

// The two rig calls alone, on recorded frames and ghosts.
void BM_HumanoidPoses(benchmark::State& state) {
  const Session& s = Session::get();
  Side side(s, true);
  std::vector<float> ghosts;
  for (uint32_t f = 0; f < s.frames.count; ++f) {
    side.push(f * s.frames.frame_time, s.frames.frame(f), s.frames.joints);
    if (side.record.ghost_joint_count) ghosts.insert(ghosts.end(), side.ghost.begin(), side.ghost.end());
  }
  const size_t n_ghosts = ghosts.size() / side.ghost.size();
  if (n_ghosts == 0) {
    state.SkipWithError("no ghosts");
    return;
  }
  uint64_t i = 0;
  for (auto _ : state) {
    kata_humanoid_rig_pose(side.rig, s.frames.frame(i), s.frames.joints, KATA_HUMANOID_UNITY, &side.student_pose);
    kata_humanoid_rig_pose_ghost(side.rig, ghosts.data() + (i % n_ghosts) * side.ghost.size(), side.ghost_joints,
                                 KATA_HUMANOID_UNITY, &side.ghost_pose);
    benchmark::DoNotOptimize(side.ghost_pose.rotation[0][0]);
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_HumanoidPoses);

}  // namespace
