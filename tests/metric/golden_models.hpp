// The content of the golden model files under tests/data/models/, from closed formulas (values
// exact in float), so a test compares what a file loads as against numbers computed here.
#pragma once

#include <string>

#include "metric/model.hpp"

namespace kata::test {

// kind 0: tests/data/models/v1-minmax-backward.kata; kind 1: v1-blockbalanced-central.kata.
inline metric::Model golden_model(int kind) {
  metric::Model m;
  m.layout_id = "gpd-v1";
  m.stencil = kind == 0 ? gpd::Stencil::kBackward : gpd::Stencil::kCentral;
  m.normalisation = kind == 0 ? metric::Normalisation::kMinMaxUnit : metric::Normalisation::kBlockBalanced;
  m.rank = 1;
  for (int i = 0; i < gpd::kDims; ++i) {
    m.min.push_back(-1.0f - static_cast<float>(i % 7) * 0.125f);
    m.max.push_back(1.0f + static_cast<float>(i % 5) * 0.25f);
    m.w.push_back(static_cast<float>((i * 31) % 101 - 50) / 64.0f);
    if (kind == 1) {
      m.shift.push_back(static_cast<float>(i % 3) * 0.5f);
      m.scale.push_back(static_cast<float>(1 + i % 4) * 0.25f);
    }
  }
  m.delta_star = 0.375;
  m.info.date = "2026-11-30T00:00:00Z";
  m.info.data = "golden file, schema v1 (tests/metric/golden_models.hpp)";
  m.info.parameters = "{\"kind\": " + std::to_string(kind) + "}";
  m.info.evaluation = {{"precision", 0.5}, {"auc", 0.75}};
  return m;
}

inline const char* golden_model_file(int kind) {
  return kind == 0 ? "v1-minmax-backward.kata" : "v1-blockbalanced-central.kata";
}

}  // namespace kata::test
