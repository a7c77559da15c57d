// kata model-make-test (hidden): writes a stand-in model with a random orthonormal W and min/max
// from given clips, for tests and demos until a learned model exists. Its metadata says
// "NOT LEARNED"; scores from it only measure pose change in a random 1683 -> r projection.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "io/bvh.hpp"
#include "metric/model.hpp"
#include "metric/random_model.hpp"
#include "stream/clip_features.hpp"

namespace {

struct MakeArgs {
  std::vector<std::string> clips;
  std::string preset, name_map, stencil = "backward", out;
  int rank = 50, first = 1;
  uint64_t seed = 1;
};

void run_make(const MakeArgs& a) {
  const kata::gpd::Stencil stencil = kata::parse_stencil(a.stencil);
  std::vector<float> all;
  std::string names;
  for (const std::string& path : a.clips) {
    const kata::BvhClip clip = kata::load_bvh(path);
    const kata::GpdMap map = kata::resolve_gpd_map(clip.skeleton, a.preset, a.name_map);
    const std::vector<float> f = kata::clip_features(clip, map, stencil, a.first);
    all.insert(all.end(), f.begin(), f.end());
    names += (names.empty() ? "" : ", ") + path;
  }
  kata::metric::Model m =
      kata::metric::make_random_model(a.rank, a.seed, all.data(), static_cast<int>(all.size() / kata::gpd::kDims), names);
  m.stencil = stencil;
  kata::metric::save_model(a.out, m);
  std::printf("%s: NOT LEARNED test model, r = %d, seed %llu, delta* = %.6g, min/max over %zu frames\n", a.out.c_str(),
              a.rank, static_cast<unsigned long long>(a.seed), m.delta_star, all.size() / kata::gpd::kDims);
}

void setup(CLI::App& app) {
  auto args = std::make_shared<MakeArgs>();
  CLI::App* cmd = app.add_subcommand("model-make-test", "write a NOT LEARNED test model (random orthonormal W)");
  cmd->group("");  // hidden from --help: a test/demo helper, not a product feature
  cmd->add_option("--bvh", args->clips, "clips whose features give min/max (repeatable)")->required()->check(CLI::ExistingFile);
  auto* preset = cmd->add_option("--preset", args->preset, "skeleton preset (default cmu)");
  cmd->add_option("--name-map", args->name_map, "name-map file instead of a preset")->excludes(preset);
  cmd->add_option("--stencil", args->stencil, "backward or central")->check(CLI::IsMember({"backward", "central"}));
  cmd->add_option("--rank", args->rank, "r, columns of W (default 50)")->check(CLI::Range(1, kata::gpd::kDims));
  cmd->add_option("--seed", args->seed, "random seed (default 1)");
  cmd->add_option("--first-frame", args->first, "first frame of each clip (default 1: skips the CMU T-pose)");
  cmd->add_option("--out", args->out, "output .kata file")->required();
  cmd->callback([args] {
    if (args->name_map.empty() && args->preset.empty()) args->preset = "cmu";
    run_make(*args);
  });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
