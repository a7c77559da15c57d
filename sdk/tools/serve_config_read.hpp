// The typed readers of the `kata serve` config (serve_config.cpp), declared here for its tests
// (tests/cli/test_serve_config.cpp); nothing else includes this header.
#pragma once

#include <cstdint>
#include <string>

#include <toml++/toml.h>

namespace kata::serve::detail {

// The integer at `key` in `table`, which must be in [lo, hi]: a present value outside it (or not
// an integer) is refused as cli::Failure (failure.hpp) with `file`, the key's line and the key. A
// missing key gives `fallback` as it is: the program's default, which has no line to name (the
// refusal used to read the missing key's node for its line).
int64_t read_range(const std::string& file, const toml::table& table, const char* key, int64_t fallback, int64_t lo,
                   int64_t hi);

}  // namespace kata::serve::detail
