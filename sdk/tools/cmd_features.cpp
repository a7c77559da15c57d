// kata features: GPD v1 features of every frame of a BVH clip, as a NumPy .npy file.
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "io/bvh.hpp"
#include "io/npy.hpp"
#include "io/clip_features.hpp"

namespace {

struct FeaturesArgs {
  std::string bvh, preset, name_map, stencil = "backward", out, dtype = "float32";
  int first = 0;
};

void run_features(const FeaturesArgs& a) {
  const kata::BvhClip clip = kata::load_bvh(a.bvh);
  const kata::GpdMap map = kata::resolve_gpd_map(clip.skeleton, a.preset, a.name_map);
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
  cmd->add_option("--bvh", args->bvh, "input BVH clip")->required()->check(CLI::ExistingFile);
  auto* preset = cmd->add_option("--preset", args->preset, "skeleton preset mapping the clip onto the 16 GPD joints (cmu, ...)");
  cmd->add_option("--name-map", args->name_map, "user name-map file (JSON or 'Hip = joint' lines) instead of a preset")
      ->excludes(preset)
      ->check(CLI::ExistingFile);
  cmd->add_option("--stencil", args->stencil, "kinetics stencil: backward (lag 0) or central (lag 1)")
      ->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--out", args->out, "output .npy file (frames x 1683)")->required();
  cmd->add_option("--dtype", args->dtype, "float32 (default) or float64")->check(CLI::IsMember({"float32", "float64"}));
  cmd->add_option("--first-frame", args->first, "first frame to stream (1 skips the CMU converter's T-pose); default 0");
  cmd->callback([args] { run_features(*args); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
