// Stand-in models for tests and demos until a learned W exists: W is a random orthonormal
// 1683 x r basis (NOT learned; the metadata says so), min/max come from real feature vectors.
#pragma once

#include <cstdint>
#include <string>

#include "metric/model.hpp"

namespace kata::metric {

// A model with a random orthonormal W (QR of a Gaussian matrix drawn from `seed`), min/max over
// `frames` feature vectors (frames x kDims floats, row-major, frames >= 2) and delta* = the
// median distance between frames half a second apart (pairs (i, i + 60) at 120 fps; any two
// distinct frames if the set is shorter), so a typical half-second change of pose scores 50.
// `data` describes the frames (clip names) for the metadata. Throws kInvalidArgument.
Model make_random_model(int rank, uint64_t seed, const float* frames_data, int frames, const std::string& data);

}  // namespace kata::metric
