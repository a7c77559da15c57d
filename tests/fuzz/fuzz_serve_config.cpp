// libFuzzer target: `kata serve` config files (TOML) through the parser serve uses
// (sdk/tools/serve_config.cpp), which checks everything before anything starts.
// Asserts: only the CLI's refusal (kata::cli::Failure) escapes, and it names the file and a line
// ("fuzz.toml:N: ..."); an accepted config has ingest and publish endpoints, 1..64 workers and a
// shard index below its count, and each [vmc] stream sends a performer at a rate in 0..1000.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "failure.hpp"
#include "serve_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const kata::serve::ServeConfig c =
        kata::serve::parse_config_text(std::string(reinterpret_cast<const char*>(data), size), "fuzz.toml");
    const auto& r = c.runtime;
    if (r.ingest_endpoints.empty() || r.publish_endpoints.empty()) std::abort();
    if (r.workers < 1 || r.workers > 64) std::abort();
    if (r.shard_count < 1 || r.shard_index >= r.shard_count) std::abort();
    for (const auto& v : c.vmc)  // [vmc]: each stream sends something, at a rate in 0..1000
      if ((v.ghost.empty() && v.student.empty()) || !(v.rate >= 0.0 && v.rate <= 1000.0)) std::abort();
  } catch (const kata::cli::Failure& e) {
    constexpr char kFile[] = "fuzz.toml:";
    const char* what = e.what();
    if (std::strncmp(what, kFile, sizeof kFile - 1) != 0) std::abort();
    const char* line = what + sizeof kFile - 1;
    if (*line < '1' || *line > '9') std::abort();
  }
  return 0;
}
