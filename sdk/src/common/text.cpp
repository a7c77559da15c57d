#include "common/text.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>

#include "common/error.hpp"

namespace kata {

std::string c_string(const char* s, const char* field) {
  if (!s) return {};
  const size_t n = ::strnlen(s, kMaxCStringBytes);
  if (n == kMaxCStringBytes)
    throw Error(ErrorKind::kInvalidArgument, std::string(field) + ": no terminating NUL within " +
                                                 std::to_string(kMaxCStringBytes) + " bytes");
  return std::string(s, n);
}

std::string bounded(std::string_view text, size_t max_bytes) {
  if (text.size() <= max_bytes) return std::string(text);
  return std::string(text.substr(0, max_bytes)) + "... (" + std::to_string(text.size()) + " bytes)";
}

namespace {
// Levenshtein distance, case-insensitive, on bounded prefixes (two rows, no allocation beyond them).
size_t edit_distance(std::string_view a, std::string_view b) {
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
}  // namespace

std::string closest_name(std::string_view name, const std::vector<std::string>& candidates) {
  std::string best;  // an exact match is not a typo: "" for it
  size_t best_distance = SIZE_MAX;
  for (const std::string& c : candidates) {
    const size_t d = edit_distance(name, c);
    if (d < best_distance) best_distance = d, best = c;
  }
  const size_t longer = std::max(name.size(), best.size());
  return best != name && best_distance * 3 <= longer ? best : std::string();
}

}  // namespace kata
