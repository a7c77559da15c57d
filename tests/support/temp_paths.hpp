// Unique temporary paths per test process: ctest runs every test as its own process, in
// parallel, so two tests must never share a file. A TempDir is a fresh directory named after the
// running test, the process id and a counter, removed with everything in it at scope exit.
#pragma once

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

namespace kata::test {

class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    std::string name = "kata_test";
    if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info())
      name += std::string("_") + info->test_suite_name() + "_" + info->name();
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = std::filesystem::temp_directory_path() /
            (name + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // A path inside the directory (the file is not created).
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // Writes `content` (binary) to a file inside the directory and returns its path.
  std::string write(const std::string& name, const std::string& content) const {
    const std::string p = file(name);
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }

 private:
  std::filesystem::path path_;
};

// A file path unique to this test process and test: <tmp>/kata_test_<pid>/<suite>.<test>.<name>.
// The directory is made on first use (it stays after the process; files are small).
inline std::string temp_path(const std::string& name) {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("kata_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  std::string prefix;
  if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info())
    prefix = std::string(info->test_suite_name()) + "." + info->name() + ".";
  for (char& c : prefix)
    if (c == '/') c = '_';
  return (dir / (prefix + name)).string();
}

}  // namespace kata::test
