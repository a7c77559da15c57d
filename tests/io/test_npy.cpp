// Tests of the .npy writer/reader: header bytes checked by hand against the NumPy format 1.0
// description, values read back exactly, malformed files refused with the file named.
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "common/error.hpp"
#include "io/npy.hpp"

namespace fs = std::filesystem;

namespace {

using kata::test::TempDir;

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void put(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

// The preamble NumPy itself writes: magic, version 1.0, uint16 LE length, dict padded with
// spaces to a multiple of 64 bytes in total, ending in '\n'.
std::string expected_preamble(const std::string& dict) {
  std::string padded = dict;
  while ((10 + padded.size() + 1) % 64 != 0) padded += ' ';
  padded += '\n';
  std::string out = std::string("\x93NUMPY", 6) + '\x01' + '\x00';
  out += static_cast<char>(padded.size() & 0xFF);
  out += static_cast<char>(padded.size() >> 8);
  return out + padded;
}

}  // namespace

TEST(Npy, Float64HeaderBytesAndData) {
  TempDir dir;
  const double data[6] = {1.0, -2.5, 0.1, 1e300, -0.0, 3.0};
  const std::string p = dir.file("a.npy");
  kata::write_npy(p, data, {2, 3});
  const std::string b = bytes_of(p);
  const std::string pre = expected_preamble("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }");
  // 10 + 60 dict characters + '\n' > 64, so the preamble takes two 64-byte blocks.
  ASSERT_EQ(pre.size(), 128u);
  ASSERT_EQ(b.size(), 128u + 6 * 8);
  EXPECT_EQ(b.substr(0, 128), pre);
  EXPECT_EQ(static_cast<unsigned char>(b[8]), 118u);  // header length, little-endian uint16
  EXPECT_EQ(b[9], 0);
  // 1.0 is 0x3FF0000000000000, little-endian; -2.5 is 0xC004000000000000.
  EXPECT_EQ(b.substr(128, 8), std::string("\x00\x00\x00\x00\x00\x00\xF0\x3F", 8));
  EXPECT_EQ(b.substr(136, 8), std::string("\x00\x00\x00\x00\x00\x00\x04\xC0", 8));

  std::vector<size_t> shape;
  const std::vector<double> back = kata::read_npy(p, &shape);
  EXPECT_EQ(shape, (std::vector<size_t>{2, 3}));
  ASSERT_EQ(back.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(back[static_cast<size_t>(i)], data[i]);
  EXPECT_TRUE(std::signbit(back[4]));
}

TEST(Npy, Float32OneDimensionalTrailingComma) {
  TempDir dir;
  const float data[5] = {1.0f, -2.5f, 0.1f, 3e38f, 7.0f};
  const std::string p = dir.file("b.npy");
  kata::write_npy(p, data, {5});
  const std::string b = bytes_of(p);
  EXPECT_EQ(b.substr(0, 128), expected_preamble("{'descr': '<f4', 'fortran_order': False, 'shape': (5,), }"));
  ASSERT_EQ(b.size(), 128u + 5 * 4);
  // 1.0f is 0x3F800000; -2.5f is 0xC0200000.
  EXPECT_EQ(b.substr(128, 4), std::string("\x00\x00\x80\x3F", 4));
  EXPECT_EQ(b.substr(132, 4), std::string("\x00\x00\x20\xC0", 4));
  std::vector<size_t> shape;
  const auto back = kata::read_npy(p, &shape);
  EXPECT_EQ(shape, std::vector<size_t>{5});
  for (int i = 0; i < 5; ++i) EXPECT_EQ(back[static_cast<size_t>(i)], static_cast<double>(data[i]));
}

TEST(Npy, ScalarEmptyAndLongShapes) {
  TempDir dir;
  const double one = 42.0;
  kata::write_npy(dir.file("s.npy"), &one, {});
  EXPECT_EQ(bytes_of(dir.file("s.npy")).substr(0, 128),
            expected_preamble("{'descr': '<f8', 'fortran_order': False, 'shape': (), }"));
  std::vector<size_t> shape{9};
  EXPECT_EQ(kata::read_npy(dir.file("s.npy"), &shape), std::vector<double>{42.0});
  EXPECT_TRUE(shape.empty());

  kata::write_npy(dir.file("e.npy"), static_cast<const double*>(nullptr), {0, 1683});
  EXPECT_TRUE(kata::read_npy(dir.file("e.npy"), &shape).empty());
  EXPECT_EQ(shape, (std::vector<size_t>{0, 1683}));

  // A header longer than 64 bytes pads to the next multiple of 64.
  std::vector<double> many(2 * 3 * 4 * 5 * 6 * 7 * 2, 1.5);
  const std::vector<size_t> big{2, 3, 4, 5, 6, 7, 2};
  kata::write_npy(dir.file("m.npy"), many.data(), big);
  const std::string b = bytes_of(dir.file("m.npy"));
  const std::string pre = expected_preamble("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3, 4, 5, 6, 7, 2), }");
  EXPECT_EQ(pre.size() % 64, 0u);
  EXPECT_EQ(b.substr(0, pre.size()), pre);
  EXPECT_EQ(kata::read_npy(dir.file("m.npy"), &shape), many);
  EXPECT_EQ(shape, big);
  EXPECT_NO_THROW(kata::read_npy(dir.file("m.npy"), nullptr));
}

TEST(Npy, MalformedFilesNameTheFile) {
  TempDir dir;
  const double d[2] = {1, 2};
  const std::string good = dir.file("good.npy");
  kata::write_npy(good, d, {2});
  const std::string g = bytes_of(good);

  auto expect_parse_error = [&](const std::string& name, const std::string& bytes, const std::string& phrase) {
    SCOPED_TRACE(name);
    const std::string p = dir.file(name);
    put(p, bytes);
    try {
      kata::read_npy(p, nullptr);
      ADD_FAILURE() << "no error";
    } catch (const kata::Error& e) {
      EXPECT_EQ(e.kind(), kata::ErrorKind::kParse);
      EXPECT_EQ(std::string(e.what()).rfind(p + ": ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(phrase), std::string::npos) << e.what();
    }
  };
  expect_parse_error("magic.npy", "XNUMPY" + g.substr(6), "magic");
  expect_parse_error("short.npy", g.substr(0, g.size() - 3), "bytes");
  expect_parse_error("long.npy", g + "x", "bytes");
  std::string i4 = g;
  i4.replace(i4.find("<f8"), 3, "<i8");
  expect_parse_error("int.npy", i4, "'<i8'");
  std::string be = g;
  be.replace(be.find("<f8"), 3, ">f8");
  expect_parse_error("bigendian.npy", be, "'>f8'");
  std::string fortran = g;
  fortran.replace(fortran.find("False"), 5, "True ");
  expect_parse_error("fortran.npy", fortran, "fortran_order");
  expect_parse_error("header.npy", g.substr(0, 20), "truncated header");
  expect_parse_error("empty.npy", "", "magic");
  std::string v9 = g;
  v9[6] = 9;
  expect_parse_error("version.npy", v9, "version 9");

  EXPECT_THROW(kata::read_npy(dir.file("absent.npy"), nullptr), kata::Error);
  EXPECT_THROW(kata::write_npy(dir.file("no/such/dir.npy"), d, {2}), kata::Error);
}
