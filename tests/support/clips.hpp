// The shipped CMU clips (data/cmu/), loaded once per test process, and their features and
// positions through the library's own readers.
#pragma once

#include <string>
#include <vector>

#include "gpd/gpd.hpp"
#include "io/bvh.hpp"

namespace kata::test {

// The path of a shipped clip: "02_01" -> KATA_DATA_DIR/cmu/02_01.bvh.
std::string clip_path(const std::string& name);
// The clip, read once and kept for the process.
const BvhClip& clip(const std::string& name);
// GPD v1 features of frames first.. of a shipped clip ("cmu" preset), frames x kDims.
const std::vector<float>& clip_features(const std::string& name, gpd::Stencil stencil = gpd::Stencil::kBackward,
                                        int first = 1);
// World positions of frames first.. of a shipped clip, frames x joints x 3 floats.
const std::vector<float>& clip_positions(const std::string& name, int first = 1);

}  // namespace kata::test
