// kata retarget: a teacher BVH clip put onto a student's body (the student clip supplies only its
// rest bone lengths), frame by frame with the warm-started SPG retargeter; written as joint
// positions (.npy) or as a BVH on the student's hierarchy (.bvh) that Blender can open.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"
#include "data_files.hpp"
#include "io/bvh.hpp"
#include "io/npy.hpp"
#include "io/ghost_bvh.hpp"
#include "io/motion_source.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/mapped.hpp"
#include "retarget/retargeter.hpp"
#include "stream/stream.hpp"

namespace {

struct RetargetArgs {
  std::string teacher, student, preset = "cmu", out;
  std::string teacher_layout, student_layout, up = "y";  // across layouts (landmark arrays, other skeletons)
  double fps = 0.0;
  std::string time_units = "auto";  // of landmark arrays' timestamps
  double tolerance = 3e-5;
  int max_iterations = 200;
  bool cold = false, no_restore = false;
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

kata::retarget::RetargetOptions options_of(const RetargetArgs& a) {
  kata::retarget::RetargetOptions opt;
  opt.solver.gradient_tolerance = a.tolerance;
  opt.solver.max_iterations = a.max_iterations;
  opt.warm_start = !a.cold;
  opt.restore_bone_lengths = !a.no_restore;
  return opt;
}

// Across layouts: the teacher's 16 GPD joints onto the student's layout (retarget/mapped.hpp).
// The student's bone lengths come from its rest pose (a BVH) or are estimated from its frames
// (Stream::bone_lengths: the median over the first 60 frames with all 16 joints good). Output:
// frames x 16 x 3, GPD order, the student's axes and units, each ghost placed over the student's
// frame of the same index (the student's last frame once it has ended; a student frame whose
// mapped joints are not all finite keeps the previous placement).
void run_across(const RetargetArgs& a) {
  using namespace kata;
  if (!ends_with(a.out, ".npy"))
    throw Error(ErrorKind::kInvalidArgument,
                "retarget: across layouts the ghost is the 16 GPD joints: --out must end in .npy");
  const UpAxis up = a.up == "z" ? UpAxis::kZ : a.up == "y-down" ? UpAxis::kYDown : UpAxis::kY;
  const MotionSource teacher = load_motion(a.teacher, a.teacher_layout, a.fps, up, 0, parse_time_units(a.time_units));
  const MotionSource student = load_motion(a.student, a.student_layout, a.fps, up, 0, parse_time_units(a.time_units));
  const retarget::MappedSide teacher_side{teacher.layout.map, teacher.layout.axes, teacher.skeleton.joint_count()};
  const retarget::MappedSide student_side{student.layout.map, student.layout.axes, student.skeleton.joint_count()};
  std::array<double, kGpdJoints> lengths{};
  const char* source_of_lengths = "rest pose";
  if (student.skeleton.has_rest_pose) {
    lengths = retarget::gpd_rest_lengths(student.skeleton, student.layout.map);
  } else {
    StreamConfig config;
    config.map = student.layout.map;
    config.input_joints = student.skeleton.joint_count();
    config.up_axis = student.layout.axes;
    Stream stream(config);
    const size_t n = static_cast<size_t>(student.skeleton.joint_count());
    const std::vector<float> all_good(n, 1.0f);
    for (int f = 0; f < student.frames && !stream.bone_lengths(nullptr, nullptr); ++f) {
      const float* conf = student.confidence.empty() ? all_good.data() : student.confidence.data() + f * n;
      const Status s = stream.push(student.time_of(f), student.xyz.data() + f * n * 3, conf, static_cast<int>(n));
      if (s != Status::kOk && s != Status::kTrackingLost)
        throw Error(ErrorKind::kInvalidArgument, a.student + ": frame " + std::to_string(f) + ": " + stream.last_error());
    }
    double spread[kGpdJoints];
    if (!stream.bone_lengths(lengths.data(), spread))
      throw Error(ErrorKind::kInvalidArgument, a.student + ": fewer than " + std::to_string(config.bone_window) +
                                                   " frames with all 16 GPD joints tracked: its bone lengths cannot be "
                                                   "estimated");
    source_of_lengths = "estimated from the first 60 good frames";
  }
  retarget::MappedRetargeter rt(teacher_side, student_side, lengths, options_of(a));
  const size_t tn = static_cast<size_t>(teacher.skeleton.joint_count());
  const size_t sn = static_cast<size_t>(student.skeleton.joint_count());
  std::vector<float> ghosts(static_cast<size_t>(teacher.frames) * 3 * kGpdJoints);
  std::vector<double> out(ghosts.size());
  float mapped[3 * kGpdJoints];
  int placed_over = -1;
  long iterations = 0;
  double worst = 0.0;
  for (int f = 0; f < teacher.frames; ++f) {
    const float* t = teacher.xyz.data() + static_cast<size_t>(f) * tn * 3;
    map_to_gpd(teacher.layout.map, teacher.layout.axes, t, mapped);
    for (float v : mapped)
      if (!std::isfinite(v))
        throw Error(ErrorKind::kInvalidArgument, a.teacher + ": frame " + std::to_string(f) + " has a non-finite GPD joint");
    float* ghost = ghosts.data() + static_cast<size_t>(f) * 3 * kGpdJoints;
    const auto& r = rt.retarget(t, ghost);
    iterations += r.iterations;
    worst = std::max(worst, r.max_bone_error);
    const int sf = std::min(f, student.frames - 1);
    if (sf >= 0) {
      map_to_gpd(student.layout.map, student.layout.axes, student.xyz.data() + static_cast<size_t>(sf) * sn * 3, mapped);
      if (std::all_of(std::begin(mapped), std::end(mapped), [](float v) { return std::isfinite(v); })) placed_over = sf;
    }
    if (placed_over >= 0) rt.place(student.xyz.data() + static_cast<size_t>(placed_over) * sn * 3, ghost);
  }
  for (size_t i = 0; i < ghosts.size(); ++i) out[i] = ghosts[i];
  write_npy(a.out, out.data(), {static_cast<size_t>(teacher.frames), size_t{kGpdJoints}, size_t{3}});
  std::printf("%s (%s) -> %s (%s) bones (%s), across layouts on the 16 GPD joints: %d frames -> %s\n",
              a.teacher.c_str(), a.teacher_layout.empty() ? "cmu" : a.teacher_layout.c_str(), a.student.c_str(),
              a.student_layout.empty() ? "cmu" : a.student_layout.c_str(), source_of_lengths, teacher.frames,
              a.out.c_str());
  std::printf("SPG iterations: mean %.1f; max bone-length error after the restoring step %.2g%%\n",
              teacher.frames ? static_cast<double>(iterations) / teacher.frames : 0.0, 100.0 * worst);
}

void run_retarget(const RetargetArgs& a) {
  if (!a.teacher_layout.empty() || !a.student_layout.empty() || !ends_with(a.teacher, ".bvh") ||
      !ends_with(a.student, ".bvh")) {
    run_across(a);
    return;
  }
  const bool to_bvh = ends_with(a.out, ".bvh");
  if (!to_bvh && !ends_with(a.out, ".npy")) {
    throw kata::Error(kata::ErrorKind::kInvalidArgument, "retarget: --out must end in .npy or .bvh");
  }
  const kata::BvhClip teacher = kata::load_bvh(a.teacher);
  const kata::BvhClip student = kata::load_bvh(a.student);
  const auto sel = kata::retarget::select_joints(teacher.skeleton, student.skeleton, a.preset);
  if (to_bvh && a.preset != "cmu") {
    throw kata::Error(kata::ErrorKind::kInvalidArgument,
                      "retarget: BVH output needs --joints cmu (the 16 GPD joints do not drive every bone); use .npy");
  }
  const kata::retarget::RetargetOptions opt = options_of(a);
  kata::retarget::Retargeter rt(sel.parents, kata::retarget::selected_rest_lengths(student.skeleton, sel), opt,
                                kata::retarget::selected_rest_directions(student.skeleton, sel));
  const int n = rt.joint_count();
  const int frames = teacher.frame_count();
  std::vector<double> positions(static_cast<size_t>(frames) * 3 * static_cast<size_t>(n));
  std::vector<double> t(3 * static_cast<size_t>(n));
  Eigen::MatrixX3d world(teacher.skeleton.joint_count(), 3);
  std::unique_ptr<kata::retarget::GhostBvh> writer;
  kata::BvhClip ghost_clip;
  if (to_bvh) {
    writer = std::make_unique<kata::retarget::GhostBvh>(teacher, student, sel);
    ghost_clip = student;
    ghost_clip.path = a.out;
    ghost_clip.frame_time = teacher.frame_time;
    ghost_clip.motion.assign(static_cast<size_t>(frames) * static_cast<size_t>(student.channel_count), 0.0);
  }
  long iterations = 0;
  int max_iterations = 0, unconverged = 0;
  double worst_solved = 0.0, worst = 0.0;
  for (int f = 0; f < frames; ++f) {
    kata::world_positions(teacher, f, world);
    kata::retarget::gather_positions(world, sel, t.data());
    double* ghost = positions.data() + static_cast<size_t>(f) * 3 * static_cast<size_t>(n);
    const auto& r = rt.retarget(t.data(), ghost);
    iterations += r.iterations;
    max_iterations = std::max(max_iterations, r.iterations);
    unconverged += r.converged ? 0 : 1;
    worst_solved = std::max(worst_solved, r.max_bone_error_solved);
    worst = std::max(worst, r.max_bone_error);
    if (writer) {
      writer->motion_row(teacher, f, ghost,
                         ghost_clip.motion.data() + static_cast<size_t>(f) * static_cast<size_t>(student.channel_count));
    }
  }
  if (to_bvh) {
    kata::write_bvh(a.out, ghost_clip);
  } else {
    kata::write_npy(a.out, positions.data(), {static_cast<size_t>(frames), static_cast<size_t>(n), size_t{3}});
  }
  std::printf("%s -> %s bones (%s preset, %d joints, %d pairs): %d frames -> %s\n", a.teacher.c_str(), a.student.c_str(),
              a.preset.c_str(), n, rt.table().pairs, frames, a.out.c_str());
  std::printf("SPG iterations: mean %.1f, max %d, %d frame(s) at the cap; max bone-length error %.3f%% before the "
              "restoring step, %.2g%% after\n",
              frames ? static_cast<double>(iterations) / frames : 0.0, max_iterations, unconverged, 100.0 * worst_solved,
              100.0 * worst);
}

void setup(CLI::App& app) {
  auto args = std::make_shared<RetargetArgs>();
  CLI::App* cmd = app.add_subcommand(
      "retarget",
      "Retarget a teacher BVH clip onto a student's body (skeleton-independent distance matrices + warm-started "
      "spectral gradient, then exact bone lengths). The student clip supplies only its rest bone lengths. Output: "
      ".npy (frames x joints x 3 world positions in the student's units, root on the teacher's root, joints in "
      "preset order) or .bvh (the student's hierarchy, rotations that reproduce those positions; --joints cmu only)");
  cmd->add_option("--teacher", args->teacher,
                  "teacher motion (retargeted): a BVH clip, or across layouts a landmark .npy/.csv (see kata features)")
      ->required()
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--student", args->student,
                  "student: a BVH clip of the same hierarchy (only its rest offsets are used); across layouts any "
                  "motion (.bvh/.npy/.csv) whose rest pose or first 60 well-tracked frames give its bone lengths")
      ->required()
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--teacher-layout", args->teacher_layout,
                  "layout of the teacher (cmu, mediapipe, gpd, kinect2, ...); with it, or --student-layout, or a "
                  "non-BVH input, the ghost is made across layouts on the 16 GPD joints (default cmu for a BVH)");
  cmd->add_option("--student-layout", args->student_layout, "layout of the student (see --teacher-layout)");
  cmd->add_option("--fps", args->fps, "frame rate of landmark arrays (.npy/.csv) without timestamps")->check(CLI::PositiveNumber);
  cmd->add_option("--time-units", args->time_units,
                  "units of landmark arrays' timestamps (a .csv's first column, X.times.npy beside X.npy): s, ms or "
                  "auto (default: from the steps between frames; refused when they fit neither)")
      ->check(CLI::IsMember({"s", "ms", "auto"}));
  cmd->add_option("--up", args->up, "axes of landmark arrays whose layout does not fix them: y, z, y-down")
      ->check(CLI::IsMember({"y", "z", "y-down"}));
  cmd->add_option("--joints,--preset", args->preset,
                  "joint set (--preset is its deprecated old name): cmu = every joint that carries a bone (joints with a zero offset, sitting on their parent, "
                  "are dropped: 31 -> 21 joints for the CMU conversion, in hierarchy order); gpd = the 16 GPD v1 "
                  "joints (Hip, Chest, Neck, Head, L/R Shoulder, Elbow, Hand, L/R Hip, Knee, Foot) read through the "
                  "cmu name preset. Default cmu")
      ->check(CLI::IsMember(kata::retarget::retarget_preset_names()));
  cmd->add_option("--out", args->out, "output file: ghost.npy or ghost.bvh")->required();
  cmd->add_option("--tolerance", args->tolerance, "SPG relative gradient tolerance (default 3e-5)");
  cmd->add_option("--max-iterations", args->max_iterations, "SPG iteration cap per frame (default 200)");
  cmd->add_flag("--cold", args->cold, "start every frame from the forward-kinematics baseline (no warm start)");
  cmd->add_flag("--no-restore", args->no_restore,
                "skip the bone-length restoring step (output the paper's optimum, whose bones stretch by a few %)");
  cmd->callback([args] { run_retarget(*args); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
