// Shipped files by a relative name ("models/default.kata", "data/cmu/05_18.bvh"), found as the
// CLI (sdk/tools/data_files.hpp) and the Python binding (kata.find_data) find them.
#include <dlfcn.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "capi/capi_internal.hpp"
#include "common/quote.hpp"

#ifndef KATA_SHARE_FROM_LIBDIR
#define KATA_SHARE_FROM_LIBDIR "../share/kata"
#endif

namespace kata::capi {

namespace {

// The share/kata folders beside this library: <libdir>/../share/kata (a build tree, an install
// into lib/), the install's own relative path (lib/<multiarch>/ installs), and the library's own
// folder (the Python wheel, which carries libkata.so beside models/ and data/).
std::vector<std::filesystem::path> share_dirs() {
  std::vector<std::filesystem::path> dirs;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&kata_version), &info) == 0 || !info.dli_fname) return dirs;
  std::error_code ec;
  const std::filesystem::path lib = std::filesystem::weakly_canonical(info.dli_fname, ec).parent_path();
  for (const std::filesystem::path& d : {(lib / KATA_SHARE_FROM_LIBDIR).lexically_normal(),
                                         (lib / ".." / "share" / "kata").lexically_normal(), lib.lexically_normal()})
    if (std::find(dirs.begin(), dirs.end(), d) == dirs.end()) dirs.push_back(d);
  return dirs;
}

}  // namespace

std::string shipped_file(const char* path) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (p.empty() || p.is_absolute() || std::filesystem::exists(p, ec)) return path;
  std::string looked = std::filesystem::current_path(ec).string();
  for (const std::filesystem::path& d : share_dirs()) {
    if (std::filesystem::is_regular_file(d / p, ec)) return (d / p).string();
    looked += ", " + d.string();
  }
  throw Error(ErrorKind::kIo, kata::bounded(path) + ": no such file (looked in " + looked + ")");
}

}  // namespace kata::capi
