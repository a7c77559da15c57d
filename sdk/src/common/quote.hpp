// User text quoted in messages, bounded, and the "did you mean" hint. Header-only and std-only:
// the commands that are clients of the public C ABI (`kata serve`'s config, sdk/tools) quote
// text as the core does without linking it (sdk/tools/CMakeLists.txt); text.hpp includes it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace kata {

// User text is cut to this many bytes in messages.
constexpr size_t kMaxQuotedBytes = 160;

// `text` for a message: at most max_bytes of it, followed by "... (N bytes)" when cut.
inline std::string bounded(std::string_view text, size_t max_bytes = kMaxQuotedBytes) {
  if (text.size() <= max_bytes) return std::string(text);
  return std::string(text.substr(0, max_bytes)) + "... (" + std::to_string(text.size()) + " bytes)";
}

namespace detail {
// Levenshtein distance, case-insensitive, on bounded prefixes (two rows, no allocation beyond them).
inline size_t edit_distance(std::string_view a, std::string_view b) {
  a = a.substr(0, kMaxQuotedBytes), b = b.substr(0, kMaxQuotedBytes);
  auto lower = [](char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; };
  std::vector<size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t substitute = prev[j - 1] + (lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, substitute});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}
}  // namespace detail

// The candidate closest to `name` for a "did you mean" hint: the smallest case-insensitive edit
// distance, accepted when it is at most a third of the longer name (a typo, not another word);
// a difference of case alone counts (find() is case-sensitive); "" when none is that close or
// when `name` itself is a candidate. Names are compared up to kMaxQuotedBytes bytes.
inline std::string closest_name(std::string_view name, const std::vector<std::string>& candidates) {
  std::string best;  // an exact match is not a typo: "" for it
  size_t best_distance = SIZE_MAX;
  for (const std::string& c : candidates) {
    const size_t d = detail::edit_distance(name, c);
    if (d < best_distance) best_distance = d, best = c;
  }
  const size_t longer = std::max(name.size(), best.size());
  return best != name && best_distance * 3 <= longer ? best : std::string();
}

}  // namespace kata
