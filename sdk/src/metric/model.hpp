// A learned pose metric: normalisation + W (spec gpd-v1.md section 6), as held in memory and as
// stored in a .kata file (a FlatBuffers buffer, schemas/model.fbs, identifier "KATA").
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gpd/gpd.hpp"

namespace kata::metric {

// The largest .kata buffer or file accepted (documented in kata.h): a full-rank gpd-v1 model
// (W 1683 x 1683 floats) is ~11 MiB.
constexpr uint64_t kMaxModelBytes = uint64_t{64} << 20;

// How a feature vector x is normalised before projection.
enum class Normalisation : int {
  // The spec's: x' = (x - min) / (max - min) per dimension (0 where max == min), then unit length.
  kMinMaxUnit = 0,
  // Block-balanced (a documented model option): x' = (x - mean) / std per dimension (0 where
  // std == 0) times the block weight in `scale` (so each of the nine blocks carries equal total
  // variance), then unit length. Stored per dimension in `shift` (= mean) and `scale`.
  kBlockBalanced = 1,
};

struct TrainingInfo {
  std::string date;        // ISO 8601
  std::string data;        // what it was trained on (clips, pair files)
  std::string parameters;  // JSON text of every parameter (N', r, alpha, gamma, seed, ...)
  std::vector<std::pair<std::string, double>> evaluation;  // named figures (precision, ...)
};

struct Model {
  std::string layout_id = "gpd-v1";
  gpd::Stencil stencil = gpd::Stencil::kBackward;
  Normalisation normalisation = Normalisation::kMinMaxUnit;
  std::vector<float> min, max;      // kDims each (always present: the spec's ranges)
  std::vector<float> shift, scale;  // kDims each when normalisation == kBlockBalanced, else empty
  int rank = 0;                     // r
  std::vector<float> w;             // kDims x rank, column-major: column c = w[c*kDims .. ]
  double delta_star = 0.0;          // decision threshold on d
  TrainingInfo info;
};

// Checks a model's content (what parse_model checks after the container): layout id, rank >= 1,
// sizes (min/max 1683, W 1683 x r, shift/scale 1683 for kBlockBalanced and empty otherwise),
// no NaN/Inf, max >= min, scale >= 0, delta* finite and > 0; magnitudes: |min|, |max|, |shift|
// <= 1e15, a non-zero max - min >= 1e-9 (min/max normalisation), scale <= 1e9, |W| <= 1e6 (so
// scoring any feature vector a stream emits stays finite). Throws kata::Error(kModel) naming
// the first problem. (Added by the scorer for models built in memory, e.g. by the trainer.)
void validate_model(const Model& model);

// Serialises a model to a .kata buffer. Throws kata::Error(kModel) if the model is invalid.
std::vector<uint8_t> serialize_model(const Model& model);
// Verifies (FlatBuffers verifier first) and checks a .kata buffer, then copies it out. Throws
// kata::Error(kModel) with a message naming the problem: not a model / wrong identifier,
// another layout id, wrong dimensions, NaN/Inf, max < min, rank 0, ...
Model parse_model(const uint8_t* data, size_t size);
// Checks a .kata buffer's first 12 bytes (size prefix, identifier) against its whole size (data
// holds at least min(size, 12) bytes), so a file reader can refuse a foreign or truncated file
// before reading the rest. Throws kata::Error(kModel) as parse_model does.
void check_model_header(const uint8_t* data, size_t size);

}  // namespace kata::metric
