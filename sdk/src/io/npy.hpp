// NumPy .npy arrays (format 1.0 written; 1.0-3.0 read; little-endian, C order): the one place the
// project writes and reads the format. npz.hpp puts several of them in one .npz (a zip, libzip).
#pragma once

#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace kata {

// One array as a .npy file holds it: its dtype ("<f4", "<f8", "<i4", "<i8", "|u1"), its shape and
// its values' bytes, little-endian in C order.
struct NpyArray {
  std::string descr;
  std::vector<size_t> shape;
  std::string bytes;

  size_t elements() const;
};

// The dtype of a C++ value type in a .npy header.
template <class T>
constexpr const char* npy_descr() {
  if constexpr (std::is_same_v<T, float>) return "<f4";
  else if constexpr (std::is_same_v<T, double>) return "<f8";
  else if constexpr (std::is_same_v<T, int32_t>) return "<i4";
  else if constexpr (std::is_same_v<T, int64_t>) return "<i8";
  else {
    static_assert(std::is_same_v<T, uint8_t>, "a .npy dtype kata writes: float, double, int32_t, int64_t, uint8_t");
    return "|u1";
  }
}

// An array of the product of `shape` values of T from `data` (row-major).
NpyArray npy_array(const std::vector<size_t>& shape, const float* data);
NpyArray npy_array(const std::vector<size_t>& shape, const double* data);
NpyArray npy_array(const std::vector<size_t>& shape, const int32_t* data);
NpyArray npy_array(const std::vector<size_t>& shape, const int64_t* data);
NpyArray npy_array(const std::vector<size_t>& shape, const uint8_t* data);

// An array's values as T; the array's dtype must be T's. Throws kata::Error(kParse) naming
// `name` (file or array) and the dtype it has.
template <class T>
std::vector<T> npy_values(const NpyArray& a, const std::string& name);

// The bytes of a .npy file holding `a`.
std::string npy_encode(const NpyArray& a);
// A .npy file's bytes as an array (any dtype). Throws kata::Error(kParse) naming `name`.
NpyArray npy_decode(const std::string& bytes, const std::string& name);
// "(3, 4)", "(5,)": a shape as Python prints it (for messages).
std::string npy_shape_text(const std::vector<size_t>& shape);

// Writes data (row-major, product of shape elements) as a .npy file. Throws kata::Error(kIo).
void write_npy(const std::string& path, const float* data, const std::vector<size_t>& shape);
void write_npy(const std::string& path, const double* data, const std::vector<size_t>& shape);

// Reads a float32 or float64 .npy file into doubles. Throws kata::Error(kParse) naming the file.
std::vector<double> read_npy(const std::string& path, std::vector<size_t>* shape);
// The same from the bytes of a .npy file held in memory; `name` stands for the file in messages.
std::vector<double> parse_npy(const std::string& bytes, const std::string& name, std::vector<size_t>* shape);

}  // namespace kata
