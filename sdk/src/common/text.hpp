// Caller text, bounded: C strings read up to a documented length, and user text (paths, preset
// names, file lines) cut to a bounded length when a message quotes it.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "common/quote.hpp"  // bounded, closest_name, kMaxQuotedBytes

namespace kata {

// A C string from a caller, read up to kMaxCStringBytes: NULL gives "", a string without a
// terminator within the bound is refused (kata::Error(kInvalidArgument) naming `field`).
constexpr size_t kMaxCStringBytes = 4096;
std::string c_string(const char* s, const char* field);

}  // namespace kata
