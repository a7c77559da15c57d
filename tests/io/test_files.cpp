// Bounded reads and atomic writes (common/file.hpp) under the loaders and writers.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "io/file.hpp"
#include "io/npy.hpp"
#include "support/temp_paths.hpp"

namespace kata {
namespace {

namespace fs = std::filesystem;

using test::TempDir;

// Names of the entries in a directory.
std::vector<std::string> entries(const TempDir& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir.path())) out.push_back(e.path().filename().string());
  return out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

ErrorKind kind_of(void (*f)(const std::string&), const std::string& arg, std::string* message) {
  try {
    f(arg);
  } catch (const Error& e) {
    *message = e.what();
    return e.kind();
  }
  ADD_FAILURE() << "no error for " << arg;
  return ErrorKind::kInvalidArgument;
}

TEST(Files, DirectoriesFifosAndOversizedFilesAreIoErrors) {
  TempDir dir;
  const std::string fifo = dir.file("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string msg;
  auto read = [](const std::string& p) { read_file_bounded(p, 16, "test file"); };
  EXPECT_EQ(kind_of(read, dir.file(""), &msg), ErrorKind::kIo);
  EXPECT_NE(msg.find("is a directory"), std::string::npos) << msg;
  EXPECT_EQ(kind_of(read, fifo, &msg), ErrorKind::kIo);  // must not block waiting for a writer
  EXPECT_NE(msg.find("FIFO"), std::string::npos) << msg;
  EXPECT_EQ(kind_of(read, dir.file("missing"), &msg), ErrorKind::kIo);
  EXPECT_NE(msg.find("missing"), std::string::npos) << msg;
  std::ofstream(dir.file("17")) << std::string(17, 'x');
  std::ofstream(dir.file("16")) << std::string(16, 'y');
  EXPECT_EQ(kind_of(read, dir.file("17"), &msg), ErrorKind::kIo);
  EXPECT_NE(msg.find("17 bytes exceeds the 16-byte limit"), std::string::npos) << msg;
  EXPECT_EQ(read_file_bounded(dir.file("16"), 16, "test file"), std::string(16, 'y'));
}

TEST(Files, TwoWritersOfOneTargetNeverCollide) {
  TempDir dir;
  const std::string target = dir.file("out.bin");
  {
    AtomicFileWriter a(target), b(target);
    a.write("first", 5);
    b.write("second", 6);
    EXPECT_EQ(entries(dir).size(), 2u) << "each writer has its own temporary";
    b.commit();
    EXPECT_EQ(slurp(target), "second");
    a.commit();
  }
  EXPECT_EQ(slurp(target), "first");
  EXPECT_EQ(entries(dir), std::vector<std::string>{"out.bin"}) << "no temporary is left behind";
}

TEST(Files, AnAbandonedWriteLeavesTheTargetAsItWas) {
  TempDir dir;
  const std::string target = dir.file("keep.npy");
  const float old_values[3] = {1, 2, 3};
  write_npy(target, old_values, {3});
  const std::string before = slurp(target);
  {
    AtomicFileWriter w(target);
    w.write("partial", 7);
  }  // destroyed without commit: an error was thrown between write and commit
  EXPECT_EQ(slurp(target), before);
  EXPECT_EQ(entries(dir), std::vector<std::string>{"keep.npy"});
}

TEST(Files, NpyIsStreamedInChunksAndReadsBack) {
  TempDir dir;
  // Several 8192-value chunks plus a partial one.
  std::vector<double> values(3 * 8192 + 17);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>(i) * 0.5 - 3.0;
  write_npy(dir.file("big.npy"), values.data(), {values.size()});
  std::vector<size_t> shape;
  EXPECT_EQ(read_npy(dir.file("big.npy"), &shape), values);
  EXPECT_EQ(shape, std::vector<size_t>{values.size()});
  EXPECT_EQ(entries(dir), std::vector<std::string>{"big.npy"});
}

TEST(Files, LongUserTextIsCutInMessages) {
  const std::string long_path = "/nonexistent/" + std::string(1 << 20, 'p');
  try {
    read_file_bounded(long_path, 16, "test file");
    FAIL();
  } catch (const Error& e) {
    EXPECT_LT(std::string(e.what()).size(), 400u);
    EXPECT_NE(std::string(e.what()).find("bytes)"), std::string::npos) << "the cut says how long the text was";
  }
}

}  // namespace
}  // namespace kata
