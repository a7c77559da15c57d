// kata retarget: a teacher BVH clip put onto a student's body (the student clip supplies only its
// rest bone lengths), frame by frame with the warm-started SPG retargeter; written as joint
// positions (.npy) or as a BVH on the student's hierarchy (.bvh) that Blender can open.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/npy.hpp"
#include "io/ghost_bvh.hpp"
#include "retarget/joint_set.hpp"
#include "retarget/retargeter.hpp"

namespace {

struct RetargetArgs {
  std::string teacher, student, preset = "cmu", out;
  double tolerance = 3e-5;
  int max_iterations = 200;
  bool cold = false, no_restore = false;
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void run_retarget(const RetargetArgs& a) {
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
  kata::retarget::RetargetOptions opt;
  opt.solver.gradient_tolerance = a.tolerance;
  opt.solver.max_iterations = a.max_iterations;
  opt.warm_start = !a.cold;
  opt.restore_bone_lengths = !a.no_restore;
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
  cmd->add_option("--teacher", args->teacher, "teacher BVH clip (its motion is retargeted)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--student", args->student, "student BVH clip (same hierarchy; only its rest offsets are used)")
      ->required()
      ->check(CLI::ExistingFile);
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
