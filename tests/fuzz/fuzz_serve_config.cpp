// libFuzzer target: `kata serve` config files (TOML) through the parser serve uses
// (sdk/tools/serve_config.cpp), which checks everything before anything starts.
// Asserts: only kata::Error(kParse) escapes; an accepted config has ingest and publish endpoints,
// 1..64 workers and a shard index below its count.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/error.hpp"
#include "serve_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const kata::serve::ServeConfig c =
        kata::serve::parse_config_text(std::string(reinterpret_cast<const char*>(data), size), "fuzz.toml");
    const auto& r = c.runtime;
    if (r.ingest_endpoints.empty() || r.publish_endpoints.empty()) std::abort();
    if (r.workers < 1 || r.workers > 64) std::abort();
    if (r.shard_count < 1 || r.shard_index >= r.shard_count) std::abort();
  } catch (const kata::Error& e) {
    if (e.kind() != kata::ErrorKind::kParse) std::abort();
  }
  return 0;
}
