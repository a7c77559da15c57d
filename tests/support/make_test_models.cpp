// kata_make_test_models OUT_DIR: writes the stand-in models the public-ABI tests load by path
// (they link only libkata, so they cannot build a model themselves):
//   random-r50-s7.kata  rank 50, seed 7      random-r2-s1.kata  rank 2, seed 1
// min/max over the real features of 02_01 and 05_02 (frame 0 skipped), W random orthonormal
// (NOT LEARNED; the metadata says so), and beside each a .delta file with delta* (%.17g).
#include <cstdio>
#include <string>
#include <vector>

#include "io/model_file.hpp"
#include "support/clips.hpp"
#include "support/random_model.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: kata_make_test_models OUT_DIR\n");
    return 2;
  }
  try {
    std::vector<float> all = kata::test::clip_features("02_01");
    const std::vector<float>& dance = kata::test::clip_features("05_02");
    all.insert(all.end(), dance.begin(), dance.end());
    const int frames = static_cast<int>(all.size() / kata::gpd::kDims);
    for (const auto& [rank, seed] : {std::pair<int, uint64_t>{50, 7}, std::pair<int, uint64_t>{2, 1}}) {
      const kata::metric::Model m =
          kata::metric::make_random_model(rank, seed, all.data(), frames, "02_01.bvh, 05_02.bvh");
      const std::string base = std::string(argv[1]) + "/random-r" + std::to_string(rank) + "-s" + std::to_string(seed);
      kata::metric::save_model(base + ".kata", m);
      std::FILE* f = std::fopen((base + ".delta").c_str(), "w");
      if (!f) throw std::runtime_error(base + ".delta: cannot write");
      std::fprintf(f, "%.17g\n", m.delta_star);
      std::fclose(f);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kata_make_test_models: %s\n", e.what());
    return 1;
  }
  return 0;
}
