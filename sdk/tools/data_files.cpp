#include "data_files.hpp"

#include <unistd.h>

#include <filesystem>

namespace kata::cli {

std::string share_dir() {
  char exe[4096];
  const ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return "share/kata";
  const std::filesystem::path bin = std::filesystem::path(std::string(exe, static_cast<size_t>(n))).parent_path();
  return (bin.parent_path() / "share" / "kata").lexically_normal().string();
}

std::string default_data_file(const std::string& relative) {
  std::error_code ec;
  if (relative.empty() || std::filesystem::path(relative).is_absolute() || std::filesystem::exists(relative, ec)) return relative;
  const std::filesystem::path shipped = std::filesystem::path(share_dir()) / relative;
  if (std::filesystem::exists(shipped, ec)) return shipped.string();
  return relative;
}

std::string doc_file(const std::string& page) {
  return (std::filesystem::path(share_dir()).parent_path() / "doc" / "kata" / page).lexically_normal().string();
}

}  // namespace kata::cli
