// Offline convenience over the live path: GPD v1 features of every frame of a recorded clip,
// computed by pushing the frames one by one through a Stream (the exact live code path).
#pragma once

#include <string>
#include <vector>

#include "gpd/gpd.hpp"
#include "io/bvh.hpp"
#include "skeleton/skeleton.hpp"
#include "stream/stream.hpp"

namespace kata {

// Features of frames [first, clip.frame_count()) of a clip (timestamps i * frame_time, H from the
// clip's rest pose), frames x gpd::kDims, row-major. The stream is flushed after the last frame,
// so with the central stencil the last row uses the backward formulas (spec section 5).
// `first` = 1 skips the T-pose the CMU converter put at frame 0.
std::vector<float> clip_features(const BvhClip& clip, const GpdMap& map, gpd::Stencil stencil, int first = 0);
// The same features in chunks of at most `chunk_frames` (stream.hpp features_in_chunks), each
// frame's positions made when the stream needs them: neither the clip's positions nor its
// features are ever held whole (a long teacher's Reference).
void clip_features_in_chunks(const BvhClip& clip, const GpdMap& map, gpd::Stencil stencil, int first,
                             int chunk_frames, const FeatureSink& sink);

// World positions of frames [first, frame_count) by forward kinematics: (frames - first) x
// joints x 3 floats, row-major, file units.
std::vector<float> clip_positions(const BvhClip& clip, int first = 0);

// The map for a preset name or, when `preset` is empty, for a name-map file. Both set, or
// neither: kata::Error(kInvalidArgument).
GpdMap resolve_gpd_map(const Skeleton& skeleton, const std::string& preset, const std::string& name_map_path);
// The same for a clip's skeleton; errors start with the clip's path.
GpdMap resolve_gpd_map(const BvhClip& clip, const std::string& preset, const std::string& name_map_path);

// Parses "backward" / "central". Throws kata::Error(kInvalidArgument) otherwise.
gpd::Stencil parse_stencil(const std::string& name);

}  // namespace kata
