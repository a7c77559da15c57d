// The one struct-size rule of the C ABI (sdk/src/capi/struct_size.hpp), as a 1.1 library would
// apply it to a caller built against 1.0: the library's struct has grown by a field, the
// caller's has not. The header is free of kata.h, so the 1.1 struct is declared here as 1.1's
// kata.h would declare it (fields only added at the end). Every reader and writer of libkata goes
// through these two functions with its 1.0 size (capi_internal.hpp, kStreamDesc10 ...);
// test_api_misuse's DescriptorStructSizeFromTheReleasedSizeUp checks them on the real structs.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <vector>

#include "capi/struct_size.hpp"

namespace {

// 1.0's desc, as a 1.0 caller compiled it.
struct Desc10 {
  uint32_t struct_size;
  int32_t workers;
  const char* name;
  double seconds;
};
// 1.1's desc, as the 1.1 library is compiled: one field added.
struct Desc11 {
  uint32_t struct_size;
  int32_t workers;
  const char* name;
  double seconds;
  double added_in_11;
};
constexpr uint32_t kReleased = static_cast<uint32_t>(offsetof(Desc11, seconds) + sizeof(double));
static_assert(sizeof(Desc10) == kReleased, "1.0's struct ends where 1.1's addition starts");

Desc11 defaults() {
  Desc11 d{};
  d.struct_size = sizeof d;
  d.workers = 2;
  d.name = "default";
  d.seconds = 1.0;
  d.added_in_11 = 42.0;
  return d;
}

TEST(StructSize, OneZeroCallerReadByAOneOneLibraryGetsTheDefaultOfTheNewField) {
  // The caller's struct sits at the end of its memory, followed by bytes that are not its own.
  std::vector<unsigned char> memory(sizeof(Desc10) + sizeof(double), 0xA5);
  Desc10 caller{sizeof(Desc10), 7, "mine", 0.5};
  std::memcpy(memory.data(), &caller, sizeof caller);
  Desc11 read{};
  ASSERT_TRUE(kata::capi::read_sized(reinterpret_cast<const Desc11*>(memory.data()), defaults(), kReleased, &read));
  EXPECT_EQ(read.workers, 7);
  EXPECT_STREQ(read.name, "mine");
  EXPECT_EQ(read.seconds, 0.5);
  EXPECT_EQ(read.added_in_11, 42.0);  // the default, not the 0xA5 bytes past the caller's struct
  EXPECT_EQ(read.struct_size, sizeof(Desc11));
}

TEST(StructSize, OneOneCallerReadByTheOneOneLibraryKeepsEveryField) {
  Desc11 caller = defaults();
  caller.added_in_11 = -3.0;
  Desc11 read{};
  ASSERT_TRUE(kata::capi::read_sized(&caller, defaults(), kReleased, &read));
  EXPECT_EQ(read.added_in_11, -3.0);
}

TEST(StructSize, BelowTheReleasedSizeIsRefusedAndNothingRead) {
  Desc11 caller = defaults();
  Desc11 read{};
  read.workers = 99;
  for (const uint32_t size : {0u, 4u, kReleased - 1}) {
    caller.struct_size = size;
    EXPECT_FALSE(kata::capi::read_sized(&caller, defaults(), kReleased, &read)) << size;
    EXPECT_EQ(read.workers, 99);
  }
}

TEST(StructSize, WriterFillsAOneZeroCallerAndNotOneBytePast) {
  std::vector<unsigned char> memory(sizeof(Desc10) + 16, 0xA5);
  auto* out = reinterpret_cast<Desc11*>(memory.data());
  out->struct_size = sizeof(Desc10);
  Desc11 value = defaults();
  ASSERT_TRUE(kata::capi::write_sized(value, kReleased, out));
  Desc10 got;
  std::memcpy(&got, memory.data(), sizeof got);
  EXPECT_EQ(got.struct_size, sizeof(Desc10));  // the caller's size stays
  EXPECT_EQ(got.workers, 2);
  EXPECT_EQ(got.seconds, 1.0);
  for (size_t i = sizeof(Desc10); i < memory.size(); ++i) EXPECT_EQ(memory[i], 0xA5) << i;
  out->struct_size = kReleased - 1;
  EXPECT_FALSE(kata::capi::write_sized(value, kReleased, out));
}

TEST(StructSize, WriterZeroesANewerCallersUnknownFields) {
  std::vector<unsigned char> memory(sizeof(Desc11) + 16, 0xA5);
  auto* out = reinterpret_cast<Desc11*>(memory.data());
  out->struct_size = static_cast<uint32_t>(memory.size());
  ASSERT_TRUE(kata::capi::write_sized(defaults(), kReleased, out));
  EXPECT_EQ(out->struct_size, memory.size());
  EXPECT_EQ(out->added_in_11, 42.0);
  for (size_t i = sizeof(Desc11); i < memory.size(); ++i) EXPECT_EQ(memory[i], 0) << i;
}

}  // namespace
