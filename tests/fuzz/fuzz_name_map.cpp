// libFuzzer target: user name-map files (JSON or "Gpd = joint" lines) through the real loader,
// read from an in-memory file so no disk I/O slows the run.
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/error.hpp"
#include "skeleton/skeleton.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const int fd = ::memfd_create("kata_fuzz_name_map", 0);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (fd < 0 || ::ftruncate(fd, 0) != 0 || ::pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) std::abort();
  try {
    const auto names = kata::load_name_map(path);
    for (const std::string& n : names)
      if (n.empty()) std::abort();  // an accepted map names every GPD joint
  } catch (const kata::Error& e) {
    if (e.kind() != kata::ErrorKind::kParse && e.kind() != kata::ErrorKind::kIo) std::abort();
  }
  return 0;
}
