#include "io/clip_features.hpp"

#include <algorithm>
#include <future>

#include "io/name_map.hpp"
#include "metric/loading.hpp"

#include "common/error.hpp"
#include "common/text.hpp"
#include "stream/stream.hpp"

namespace kata {

std::vector<float> clip_features(const BvhClip& clip, const GpdMap& map, gpd::Stencil stencil, int first) {
  const std::vector<float> xyz = clip_positions(clip, first);
  try {
    return features_of_frames(stream_config_for(clip.skeleton, map, stencil), xyz.data(), clip.frame_count() - first,
                              clip.frame_time);
  } catch (const Error& e) {
    throw Error(e.kind(), bounded(clip.path) + ": " + e.what());
  }
}

namespace {

void check_first(const BvhClip& clip, int first) {
  const int frames = clip.frame_count();
  if (first < 0 || first > frames)
    throw Error(ErrorKind::kInvalidArgument, bounded(clip.path) + ": first frame " + std::to_string(first) +
                                                 " out of range (the clip has " + std::to_string(frames) +
                                                 " frames; --first-frame takes 0.." + std::to_string(frames) + ")");
}

}  // namespace

void clip_features_in_chunks(const BvhClip& clip, const GpdMap& map, gpd::Stencil stencil, int first,
                             int chunk_frames, const FeatureSink& sink) {
  check_first(clip, first);
  const int n = clip.skeleton.joint_count(), frames = clip.frame_count() - first;
  const size_t per_frame = 3 * static_cast<size_t>(n);
  // Frames [b * kBlock, ...) made exactly as clip_positions makes them (the same floats, so the
  // same features), a block at a time on a second thread while the stream (sequential: it carries
  // state from frame to frame) takes the block before: the forward kinematics were a fifth of a
  // long teacher's load, on the one thread the stream runs on. Two buffers: block b
  // goes to buffer b % 2 once block b - 1 (the stream's current one, in the other) is complete.
  constexpr int kBlock = 1024;
  std::vector<float> block[2];
  auto make_block = [&clip, first, frames, n, per_frame](int b, std::vector<float>* out) {
    Eigen::MatrixX3d world(n, 3);
    const int begin = b * kBlock, end = std::min(frames, begin + kBlock);
    out->resize(static_cast<size_t>(end - begin) * per_frame);
    float* o = out->data();
    for (int i = begin; i < end; ++i) {
      world_positions(clip, first + i, world);
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(world(j, k));
    }
  };
  std::future<void> next;  // block (i / kBlock) + 1, under way
  auto positions = [&](int i, float* o) {
    const int b = i / kBlock;
    if (i % kBlock == 0) {
      if (b == 0) make_block(0, &block[0]);
      else next.get();
      if ((b + 1) * kBlock < frames) next = start_beside([&make_block, &block, b] { make_block(b + 1, &block[(b + 1) % 2]); });
    }
    const float* p = block[b % 2].data() + static_cast<size_t>(i % kBlock) * per_frame;
    std::copy(p, p + per_frame, o);
  };
  try {
    features_in_chunks(stream_config_for(clip.skeleton, map, stencil), positions, clip.frame_count() - first,
                       clip.frame_time, chunk_frames, sink);
  } catch (const Error& e) {
    throw Error(e.kind(), bounded(clip.path) + ": " + e.what());
  }
}

std::vector<float> clip_positions(const BvhClip& clip, int first) {
  const int frames = clip.frame_count();
  check_first(clip, first);
  const int n = clip.skeleton.joint_count();
  Eigen::MatrixX3d world(n, 3);
  std::vector<float> xyz(static_cast<size_t>(frames - first) * 3 * static_cast<size_t>(n));
  float* o = xyz.data();
  for (int i = first; i < frames; ++i) {
    world_positions(clip, i, world);
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) *o++ = static_cast<float>(world(j, k));
  }
  return xyz;
}

GpdMap resolve_gpd_map(const Skeleton& skeleton, const std::string& preset, const std::string& name_map_path) {
  // Both set is contradictory (which one wins would be a guess): refused.
  if (!preset.empty() && !name_map_path.empty())
    throw Error(ErrorKind::kInvalidArgument, "give a layout or a name-map file, not both (layout '" + bounded(preset) +
                                                 "', name map " + bounded(name_map_path) + ")");
  if (!preset.empty()) {
    const auto names = preset_joint_names(preset);
    try {
      return make_gpd_map(skeleton, names);
    } catch (const Error& e) {
      throw Error(e.kind(), "layout '" + bounded(preset) + "': " + e.what());
    }
  }
  if (!name_map_path.empty()) {
    std::array<int, kGpdJoints> lines{};
    const auto names = load_name_map(name_map_path, &lines);
    try {
      return make_gpd_map(skeleton, names);
    } catch (const Error& e) {
      // The map's line of the first name the skeleton lacks: where the typo is to be fixed.
      int line = 1;
      for (int g = 0; g < kGpdJoints; ++g)
        if (skeleton.find(names[static_cast<size_t>(g)]) < 0) {
          line = lines[static_cast<size_t>(g)];
          break;
        }
      throw Error(e.kind(), bounded(name_map_path) + ":" + std::to_string(line) + ": " + e.what());
    }
  }
  throw Error(ErrorKind::kInvalidArgument, "give a layout (--layout cmu) or a name-map file (--name-map FILE)");
}

GpdMap resolve_gpd_map(const BvhClip& clip, const std::string& preset, const std::string& name_map_path) {
  try {
    return resolve_gpd_map(clip.skeleton, preset, name_map_path);
  } catch (const Error& e) {
    throw Error(e.kind(), bounded(clip.path) + ": " + e.what());
  }
}

gpd::Stencil parse_stencil(const std::string& name) {
  if (name == "backward") return gpd::Stencil::kBackward;
  if (name == "central") return gpd::Stencil::kCentral;
  throw Error(ErrorKind::kInvalidArgument, "unknown stencil '" + name + "' (backward or central)");
}

}  // namespace kata
