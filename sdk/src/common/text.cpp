#include "common/text.hpp"

#include <cstring>

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

}  // namespace kata
