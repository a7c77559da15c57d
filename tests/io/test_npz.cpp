// Tests of the .npz writer/reader (libzip): every dtype kata writes read back exactly, the file as
// NumPy itself reads it (numpy.load in Debian's /usr/bin/python3), files NumPy writes (savez and
// savez_compressed) read by kata, damaged files refused naming the file and the entry.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "common/error.hpp"
#include "io/npz.hpp"

namespace {

using kata::test::TempDir;

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Runs a Python program (Debian's python3 with numpy) and returns its standard output.
std::string python(const std::string& program, int* code) {
  const std::string command = "/usr/bin/python3 -c '" + program + "' 2>&1";
  std::FILE* p = popen(command.c_str(), "r");
  std::string out;
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  *code = pclose(p);
  return out;
}

const float kFloats[6] = {1.5f, -2.25f, 0.0f, 3e38f, -1e-30f, 7.0f};
const double kDoubles[3] = {0.1, -1e300, 2.0};
const int32_t kInts[4] = {-1, 0, 2147483647, 0x11223344};
const int64_t kLongs[2] = {-9007199254740993LL, 123456789012345LL};
const uint8_t kBytes[5] = {'a', 'b', '\n', 0, 255};

kata::NpzArrays sample() {
  return {{"f", kata::npy_array({2, 1, 3}, kFloats)}, {"d", kata::npy_array({3}, kDoubles)},
          {"i", kata::npy_array({2, 2}, kInts)},      {"l", kata::npy_array({2}, kLongs)},
          {"u", kata::npy_array({5}, kBytes)},        {"empty", kata::npy_array({0, 3}, kFloats)}};
}

}  // namespace

TEST(Npz, EveryDtypeReadsBackExactly) {
  TempDir dir;
  const std::string p = dir.file("a.npz");
  kata::write_npz(p, sample());
  const auto back = kata::read_npz(p);
  ASSERT_EQ(back.size(), 6u);
  EXPECT_EQ(back.at("f").shape, (std::vector<size_t>{2, 1, 3}));
  EXPECT_EQ(kata::npy_values<float>(back.at("f"), "f"), std::vector<float>(kFloats, kFloats + 6));
  EXPECT_EQ(kata::npy_values<double>(back.at("d"), "d"), std::vector<double>(kDoubles, kDoubles + 3));
  EXPECT_EQ(kata::npy_values<int32_t>(back.at("i"), "i"), std::vector<int32_t>(kInts, kInts + 4));
  EXPECT_EQ(kata::npy_values<int64_t>(back.at("l"), "l"), std::vector<int64_t>(kLongs, kLongs + 2));
  EXPECT_EQ(kata::npy_values<uint8_t>(back.at("u"), "u"), std::vector<uint8_t>(kBytes, kBytes + 5));
  EXPECT_EQ(back.at("empty").shape, (std::vector<size_t>{0, 3}));
  EXPECT_TRUE(kata::npy_values<float>(back.at("empty"), "empty").empty());
  // A value read as another dtype is refused naming what it is.
  try {
    kata::npy_values<double>(back.at("f"), p + ": f");
    FAIL() << "a float32 array read as float64";
  } catch (const kata::Error& e) {
    EXPECT_NE(std::string(e.what()).find("is <f4, expected <f8"), std::string::npos) << e.what();
  }
}

TEST(Npz, NumpyReadsWhatKataWrites) {
  TempDir dir;
  const std::string p = dir.file("k.npz");
  kata::write_npz(p, sample());
  int code = -1;
  const std::string out = python(
      "import numpy as np\n"
      "z = np.load(\"" + p + "\")\n"
      "for k in z.files:\n"
      "    a = z[k]\n"
      "    print(k, a.dtype.str, a.shape, a.ravel().tolist())\n",
      &code);
  ASSERT_EQ(code, 0) << out;
  // numpy's own reading: names in the order written, dtypes, shapes and values.
  EXPECT_EQ(out,
            "f <f4 (2, 1, 3) [1.5, -2.25, 0.0, 3.0000000054977558e+38, -1.0000000031710769e-30, 7.0]\n"
            "d <f8 (3,) [0.1, -1e+300, 2.0]\n"
            "i <i4 (2, 2) [-1, 0, 2147483647, 287454020]\n"
            "l <i8 (2,) [-9007199254740993, 123456789012345]\n"
            "u |u1 (5,) [97, 98, 10, 0, 255]\n"
            "empty <f4 (0, 3) []\n");
}

TEST(Npz, KataReadsWhatNumpyWrites) {
  TempDir dir;
  for (const char* how : {"savez", "savez_compressed"}) {
    const std::string p = dir.file(std::string(how) + ".npz");
    int code = -1;
    const std::string out = python(
        "import numpy as np\n"
        "np." + std::string(how) + "(\"" + p + "\", x=np.arange(12, dtype=np.float32).reshape(3, 4), "
        "t=np.array([0.5, 1.5]), s=np.array([3, 0, 1], dtype=np.uint8), n=np.array([-7, 8], dtype=np.int64))\n",
        &code);
    ASSERT_EQ(code, 0) << out;
    const auto z = kata::read_npz(p);
    ASSERT_EQ(z.size(), 4u) << how;
    EXPECT_EQ(z.at("x").shape, (std::vector<size_t>{3, 4})) << how;
    const std::vector<float> x = kata::npy_values<float>(z.at("x"), "x");
    for (size_t k = 0; k < 12; ++k) EXPECT_EQ(x[k], static_cast<float>(k)) << how;
    EXPECT_EQ(kata::npy_values<double>(z.at("t"), "t"), (std::vector<double>{0.5, 1.5})) << how;
    EXPECT_EQ(kata::npy_values<uint8_t>(z.at("s"), "s"), (std::vector<uint8_t>{3, 0, 1})) << how;
    EXPECT_EQ(kata::npy_values<int64_t>(z.at("n"), "n"), (std::vector<int64_t>{-7, 8})) << how;
  }
}

TEST(Npz, DamagedFilesNameTheFileAndTheEntry) {
  TempDir dir;
  const std::string p = dir.file("a.npz");
  kata::write_npz(p, sample());
  std::string bytes = bytes_of(p);
  // One value of the int32 array changed: the entry's CRC no longer matches.
  const size_t at = bytes.find(std::string("\x44\x33\x22\x11", 4));
  ASSERT_NE(at, std::string::npos);
  bytes[at] = 0x45;
  const std::string crc = dir.file("crc.npz");
  std::ofstream(crc, std::ios::binary) << bytes;
  try {
    kata::read_npz(crc);
    FAIL() << "a damaged entry was read";
  } catch (const kata::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(crc + ": i.npy: ", 0), 0u) << e.what();
  }
  // Not a zip at all, a truncated one, and none at all.
  const std::string junk = dir.file("junk.npz"), cut = dir.file("cut.npz");
  std::ofstream(junk, std::ios::binary) << "PK\x03\x04 not really a zip";
  std::ofstream(cut, std::ios::binary) << bytes_of(p).substr(0, 300);
  for (const std::string& bad : {junk, cut, dir.file("absent.npz")}) {
    try {
      kata::read_npz(bad);
      FAIL() << bad << " was read";
    } catch (const kata::Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(bad + ": ", 0), 0u) << e.what();
    }
  }
  // A .npy entry that is not a .npy file names the entry.
  const std::string wrong = dir.file("wrong.npz");
  kata::NpzArrays arrays = sample();
  arrays[0].second.bytes.pop_back();  // 23 bytes for 6 float32 values
  kata::write_npz(wrong, arrays);
  try {
    kata::read_npz(wrong);
    FAIL() << "a short entry was read";
  } catch (const kata::Error& e) {
    EXPECT_NE(std::string(e.what()).find(wrong + ": f: not a .npy file: data is 23 bytes"), std::string::npos) << e.what();
  }
  // A write that cannot happen leaves no file and says where.
  EXPECT_THROW(kata::write_npz(dir.file("no/such/dir.npz"), sample()), kata::Error);
}
