// libFuzzer target: user name maps (JSON or "Gpd = joint" lines) through the parser the file
// loader uses. Anything but a complete map ends in kata::Error(kParse).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/error.hpp"
#include "io/name_map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const auto names = kata::parse_name_map(std::string(reinterpret_cast<const char*>(data), size), "fuzz.map");
    for (const std::string& n : names)
      if (n.empty()) std::abort();  // an accepted map names every GPD joint
  } catch (const kata::Error& e) {
    if (e.kind() != kata::ErrorKind::kParse) std::abort();
  }
  return 0;
}
