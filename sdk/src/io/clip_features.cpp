#include "io/name_map.hpp"
#include "io/clip_features.hpp"

#include "common/error.hpp"
#include "stream/stream.hpp"

namespace kata {

std::vector<float> clip_features(const BvhClip& clip, const GpdMap& map, gpd::Stencil stencil, int first) {
  const int frames = clip.frame_count();
  if (first < 0 || first > frames) throw Error(ErrorKind::kInvalidArgument, "clip_features: first frame out of range");
  const Skeleton& skeleton = clip.skeleton;
  StreamConfig config = stream_config_for(skeleton, map, stencil);
  Stream stream(config);
  const int n = skeleton.joint_count();
  Eigen::MatrixX3d world(n, 3);
  std::vector<float> xyz(3 * static_cast<size_t>(n));
  std::vector<float> out(static_cast<size_t>(frames - first) * gpd::kDims);
  int64_t seen = 0;
  auto collect = [&] {
    if (stream.emitted_count() == seen) return;
    seen = stream.emitted_count();
    const int64_t row = stream.feature_frame();  // index among pushed frames
    std::copy(stream.features(), stream.features() + gpd::kDims, out.begin() + row * gpd::kDims);
  };
  for (int i = first; i < frames; ++i) {
    world_positions(clip, i, world);
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) xyz[3 * j + k] = static_cast<float>(world(j, k));
    const Status s = stream.push((i - first) * clip.frame_time, xyz.data(), n);
    if (s != Status::kOk)
      throw Error(ErrorKind::kInvalidArgument, clip.path + ": frame " + std::to_string(i) + ": " + stream.last_error());
    collect();
  }
  stream.flush();
  collect();
  return out;
}

GpdMap resolve_gpd_map(const Skeleton& skeleton, const std::string& preset, const std::string& name_map_path) {
  if (!preset.empty()) return make_gpd_map(skeleton, preset_joint_names(preset));
  if (!name_map_path.empty()) return make_gpd_map(skeleton, load_name_map(name_map_path));
  throw Error(ErrorKind::kInvalidArgument, "give a preset (--preset cmu) or a name-map file (--name-map FILE)");
}

gpd::Stencil parse_stencil(const std::string& name) {
  if (name == "backward") return gpd::Stencil::kBackward;
  if (name == "central") return gpd::Stencil::kCentral;
  throw Error(ErrorKind::kInvalidArgument, "unknown stencil '" + name + "' (backward or central)");
}

}  // namespace kata
