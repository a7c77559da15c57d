// Writes seed inputs for fuzz_stream (its input layout) from real motion: the 16 GPD joints of
// CMU clips at their frame rate, with and without rest offsets, both stencils, Y and Z up.
// Usage: make_stream_seeds OUT_DIR CLIP.bvh...
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/bvh.hpp"
#include "skeleton/skeleton.hpp"

namespace {

template <class T>
void put(std::vector<uint8_t>& out, T v) {
  uint8_t b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  out.insert(out.end(), b, b + sizeof v);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s OUT_DIR CLIP.bvh...\n", argv[0]);
    return 2;
  }
  int written = 0;
  for (int a = 2; a < argc; ++a) {
    const kata::BvhClip clip = kata::load_bvh(argv[a]);
    const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
    const Eigen::MatrixX3d rest = kata::rest_positions(clip.skeleton);
    Eigen::MatrixX3d world(clip.skeleton.joint_count(), 3);
    for (int variant = 0; variant < 4; ++variant) {
      const bool with_rest = variant & 1, central = variant & 2;
      std::vector<uint8_t> out;
      put<uint8_t>(out, static_cast<uint8_t>((with_rest ? 1 : 0) | 2));
      put<int32_t>(out, central ? 1 : 0);
      put<int32_t>(out, 0);
      put<double>(out, 0.25);
      put<uint32_t>(out, 16);
      put<double>(out, 0.0);
      put<uint32_t>(out, 8);
      if (with_rest) {
        // Offsets of the fuzz skeleton's tree (its own parents) from the clip's rest positions.
        const int parents[16] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};
        for (int j = 0; j < 16; ++j)
          for (int k = 0; k < 3; ++k) {
            const double here = rest(map.source[static_cast<size_t>(j)], k);
            put<double>(out, parents[j] < 0 ? here : here - rest(map.source[static_cast<size_t>(parents[j])], k));
          }
      }
      for (int f = 1; f < clip.frame_count() && f <= 24; ++f) {
        kata::world_positions(clip, f, world);
        put<double>(out, (f - 1) * clip.frame_time);
        for (int j = 0; j < 16; ++j)
          for (int k = 0; k < 3; ++k) put<float>(out, static_cast<float>(world(map.source[static_cast<size_t>(j)], k)));
      }
      const std::string base = std::string(argv[a]);
      const std::string name = std::string(argv[1]) + "/" + base.substr(base.find_last_of('/') + 1) + "-" +
                               std::to_string(variant) + ".bin";
      std::FILE* file = std::fopen(name.c_str(), "wb");
      if (!file || std::fwrite(out.data(), 1, out.size(), file) != out.size() || std::fclose(file) != 0) {
        std::perror(name.c_str());
        return 1;
      }
      ++written;
    }
  }
  std::printf("%d stream seeds in %s\n", written, argv[1]);
  return 0;
}
