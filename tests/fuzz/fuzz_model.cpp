// libFuzzer target: the .kata model loader (size prefix, verifier, content checks, checksum,
// canonical layout) on arbitrary bytes. Anything but a valid model ends in kata::Error(kModel).
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "common/error.hpp"
#include "metric/model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const kata::metric::Model m = kata::metric::parse_model(data, size);
    kata::metric::validate_model(m);  // what was accepted passes the content checks again
  } catch (const kata::Error& e) {
    if (e.kind() != kata::ErrorKind::kModel) std::abort();  // a bad buffer is a model refusal
  }
  return 0;
}
