// .kata model files on disk: the file versions of metric::serialize_model / parse_model.
#pragma once

#include <string>

#include "metric/model.hpp"

namespace kata::metric {

// Writes a model to `path` through a temporary file renamed into place. Throws kata::Error(kIo)
// when it cannot be written, kModel when the model is invalid.
void save_model(const std::string& path, const Model& model);
// Reads and verifies a model file (parse_model). Throws kata::Error(kIo) naming the path when the
// file cannot be read, kModel with the path and the reason when it is refused.
Model load_model(const std::string& path);

}  // namespace kata::metric
