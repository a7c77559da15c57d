// The one rule for every struct that crosses the C ABI with a leading uint32_t struct_size
// (kata.h: "structs only grow"). A caller may be built against any kata.h from 1.0 on, so its
// struct may be smaller than this library's (an older caller) or larger (a newer caller):
//   reading:  the caller's fields, up to the smaller of the two sizes, over this library's
//             defaults; a newer caller's extra fields are ignored.
//   writing:  this library's fields, up to the smaller of the two sizes, and zeros in a newer
//             caller's fields this library does not know; nothing past the caller's struct is
//             touched, and its struct_size is left as the caller set it.
// A size below the struct as 1.0 released it is refused: no released kata.h has such a struct,
// so it is an uninitialised struct (and a partial copy could take half of a pointer).
// Header-only and free of kata.h so that tests can apply it to a 1.1-sized struct of their own.
#ifndef KATA_CAPI_STRUCT_SIZE_HPP
#define KATA_CAPI_STRUCT_SIZE_HPP

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace kata::capi {

// Reads the caller's struct `in` (struct_size from `in` itself) into *out over `defaults`.
// False, with *out untouched, when in->struct_size is below `released`, the 1.0 size.
template <typename T>
bool read_sized(const T* in, const T& defaults, uint32_t released, T* out) noexcept {
  static_assert(std::is_trivially_copyable<T>::value, "C structs only");
  if (in->struct_size < released) return false;
  *out = defaults;
  std::memcpy(static_cast<void*>(out), in, std::min<size_t>(in->struct_size, sizeof(T)));
  out->struct_size = static_cast<uint32_t>(sizeof(T));
  return true;
}

// Writes `value` into the caller's struct *out (its struct_size as the caller set it). False,
// with nothing written, when out->struct_size is below `released`.
template <typename T>
bool write_sized(const T& value, uint32_t released, T* out) noexcept {
  static_assert(std::is_trivially_copyable<T>::value, "C structs only");
  const uint32_t caller = out->struct_size;
  if (caller < released) return false;
  std::memcpy(static_cast<void*>(out), &value, std::min<size_t>(caller, sizeof(T)));
  if (caller > sizeof(T)) std::memset(reinterpret_cast<unsigned char*>(out) + sizeof(T), 0, caller - sizeof(T));
  out->struct_size = caller;
  return true;
}

}  // namespace kata::capi

#endif  // KATA_CAPI_STRUCT_SIZE_HPP
