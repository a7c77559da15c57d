// Caller text, bounded: C strings read up to a documented length, and user text (paths, preset
// names, file lines) cut to a bounded length when a message quotes it.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace kata {

// User text is cut to this many bytes in messages.
constexpr size_t kMaxQuotedBytes = 160;

// A C string from a caller, read up to kMaxCStringBytes: NULL gives "", a string without a
// terminator within the bound is refused (kata::Error(kInvalidArgument) naming `field`).
constexpr size_t kMaxCStringBytes = 4096;
std::string c_string(const char* s, const char* field);

// `text` for a message: at most max_bytes of it, followed by "... (N bytes)" when cut.
std::string bounded(std::string_view text, size_t max_bytes = kMaxQuotedBytes);

// The candidate closest to `name` for a "did you mean" hint: the smallest case-insensitive edit
// distance, accepted when it is at most a third of the longer name (a typo, not another word);
// a difference of case alone counts (find() is case-sensitive); "" when none is that close or
// when `name` itself is a candidate. Names are compared up to kMaxQuotedBytes bytes.
std::string closest_name(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace kata
