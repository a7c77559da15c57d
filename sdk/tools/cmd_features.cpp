// kata features: GPD v1 features of every frame of a BVH clip, as a NumPy .npy file.
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "common/error.hpp"
#include "data_files.hpp"
#include "io/bvh.hpp"
#include "io/npy.hpp"
#include "io/clip_features.hpp"
#include "io/motion_source.hpp"

namespace {

struct FeaturesArgs {
  std::string bvh, preset, name_map, stencil = "backward", out, dtype = "float32";
  std::string student, up = "y";  // any source (.bvh, .npy, .csv) with --layout and --fps
  double fps = 0.0;
  std::string time_units = "auto";  // of a landmark array's timestamps
  int first = 0;
};

kata::UpAxis parse_up(const std::string& up) {
  return up == "z" ? kata::UpAxis::kZ : up == "y-down" ? kata::UpAxis::kYDown : kata::UpAxis::kY;
}

void write_rows(const std::string& path, const std::vector<float>& feats, const std::string& dtype) {
  const std::vector<size_t> shape = {feats.size() / kata::gpd::kDims, static_cast<size_t>(kata::gpd::kDims)};
  if (dtype == "float64") {
    const std::vector<double> wide(feats.begin(), feats.end());
    kata::write_npy(path, wide.data(), shape);
  } else {
    kata::write_npy(path, feats.data(), shape);
  }
}

void run_motion_features(const FeaturesArgs& a) {
  const kata::MotionSource m = kata::load_motion(a.student, a.preset, a.fps, parse_up(a.up), a.first,
                                                  kata::parse_time_units(a.time_units));
  std::vector<int> rows;
  int lost = 0;
  const std::vector<float> feats = kata::motion_features(m, kata::parse_stencil(a.stencil), &rows, &lost);
  write_rows(a.out, feats, a.dtype);
  std::printf("%s: %d frames, %zu feature rows (%s stencil, %d frames tracking lost) -> %s\n", a.student.c_str(),
              m.frames, rows.size(), a.stencil.c_str(), lost, a.out.c_str());
}

void run_features(const FeaturesArgs& a) {
  if (!a.student.empty()) return run_motion_features(a);
  if (a.bvh.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "give --bvh CLIP or --student FILE");
  // A landmark array given where a BVH clip is expected would otherwise read as a bad BVH
  // ("X.npy:1: expected HIERARCHY"); say which option takes it.
  for (const char* ext : {".npy", ".csv"}) {
    if (a.bvh.size() > 4 && a.bvh.compare(a.bvh.size() - 4, 4, ext) == 0)
      throw kata::Error(kata::ErrorKind::kInvalidArgument,
                        a.bvh + ": --bvh takes a BVH clip; a landmark array (" + ext + ") goes in with --student " +
                            a.bvh + " --layout NAME --fps N");
  }
  const kata::BvhClip clip = kata::load_bvh(a.bvh);
  const kata::GpdMap map = kata::resolve_gpd_map(clip, a.preset, a.name_map);
  const std::vector<float> feats = kata::clip_features(clip, map, kata::parse_stencil(a.stencil), a.first);
  const std::vector<size_t> shape = {feats.size() / kata::gpd::kDims, static_cast<size_t>(kata::gpd::kDims)};
  if (a.dtype == "float64") {
    const std::vector<double> wide(feats.begin(), feats.end());
    kata::write_npy(a.out, wide.data(), shape);
  } else {
    kata::write_npy(a.out, feats.data(), shape);
  }
  std::printf("%s: %zu frames x %d features (%s stencil) -> %s\n", a.bvh.c_str(), shape[0], kata::gpd::kDims,
              a.stencil.c_str(), a.out.c_str());
}

void setup(CLI::App& app) {
  auto args = std::make_shared<FeaturesArgs>();
  CLI::App* cmd = app.add_subcommand("features", "GPD v1 features (frames x 1683) of a BVH clip, pushed frame by frame "
                                                 "through a live stream; timestamps i x frame time, H from the rest pose");
  auto* bvh = cmd->add_option("--bvh", args->bvh, "input BVH clip")->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--student", args->student,
                  "input motion of any source: .bvh, or landmarks as .npy (frames, joints, 3|4|5: x y z [confidence | "
                  "visibility presence]) or .csv (a row per frame, optionally a timestamp first) in the joint order of --layout; rows are the frames that gave features")
      ->excludes(bvh)
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  auto* preset = cmd->add_option("--layout,--preset", args->preset,
                                 "layout mapping the input onto the 16 GPD joints: a preset (cmu, h36m, kinect2, "
                                 "azure-kinect, xsens, gpd, ...) or mediapipe (--preset is the old name)");
  cmd->add_option("--fps", args->fps, "frame rate of a landmark array (.npy/.csv) without timestamps")->check(CLI::PositiveNumber);
  cmd->add_option("--time-units", args->time_units,
                  "units of a landmark array's timestamps (a .csv's first column, X.times.npy beside X.npy): s, ms or "
                  "auto (default: from the steps between frames; refused when they fit neither)")
      ->check(CLI::IsMember({"s", "ms", "auto"}));
  cmd->add_option("--up", args->up, "axes of a landmark array whose layout does not fix them: y (default), z, y-down")
      ->check(CLI::IsMember({"y", "z", "y-down"}));
  cmd->add_option("--name-map", args->name_map, "user name-map file (JSON or 'Hip = joint' lines) instead of a preset")
      ->excludes(preset)
      ->transform(kata::cli::default_data_file)->check(CLI::ExistingFile);
  cmd->add_option("--stencil", args->stencil, "kinetics stencil: backward (lag 0) or central (lag 1)")
      ->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--out", args->out, "output .npy file (frames x 1683)")->required();
  cmd->add_option("--dtype", args->dtype, "float32 (default) or float64")->check(CLI::IsMember({"float32", "float64"}));
  cmd->add_option("--first-frame", args->first, "first frame to stream (1 skips the CMU converter's T-pose); default 0");
  cmd->callback([args] { run_features(*args); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
