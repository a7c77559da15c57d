// NumPy .npy files, format 1.0 (https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html):
// magic "\x93NUMPY", version bytes 1 0, little-endian uint16 header length, then an ASCII dict
// padded with spaces and ended by '\n' so that the data starts at a multiple of 64 bytes.
// Values are written little-endian byte by byte, so the files are the same on any host.
#include "io/npy.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "common/error.hpp"
#include "common/text.hpp"
#include "io/file.hpp"

namespace kata {
namespace {

// Magic string (6 bytes) + version (2) + header length (2).
constexpr size_t kPreludeV1 = 10;
// The header dict plus padding ends the preamble at a multiple of this many bytes.
constexpr size_t kAlign = 64;
// read_npy reads whole files into memory; past this size a file is refused before reading.
constexpr uint64_t kMaxNpyBytes = uint64_t{16} << 30;

size_t element_count(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t d : shape) n *= d;
  return n;
}

size_t item_size(const std::string& descr) {
  if (descr == "<f8" || descr == "<i8") return 8;
  if (descr == "<f4" || descr == "<i4") return 4;
  if (descr == "|u1") return 1;
  return 0;
}

std::string make_preamble(const std::string& descr, const std::vector<size_t>& shape) {
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + npy_shape_text(shape) + ", }";
  // Pad with spaces so that prelude + dict + '\n' is a multiple of 64.
  const size_t unpadded = kPreludeV1 + dict.size() + 1;
  dict.append((kAlign - unpadded % kAlign) % kAlign, ' ');
  dict += '\n';
  if (dict.size() > 0xFFFF) throw Error(ErrorKind::kInvalidArgument, "write_npy: shape too long for format 1.0");
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(dict.size() & 0xFF);
  out += static_cast<char>((dict.size() >> 8) & 0xFF);
  out += dict;
  return out;
}

// The unsigned integer of a value type's width (its bits are copied, then written byte by byte,
// so the files are the same on any host).
template <class T>
using Bits = std::conditional_t<sizeof(T) == 8, uint64_t, std::conditional_t<sizeof(T) == 4, uint32_t, uint8_t>>;

template <class T>
void put_le(char* out, const T* data, size_t count) {
  for (size_t i = 0; i < count; ++i) {
    Bits<T> bits;
    std::memcpy(&bits, data + i, sizeof bits);
    for (size_t b = 0; b < sizeof bits; ++b) out[i * sizeof bits + b] = static_cast<char>((bits >> (8 * b)) & 0xFF);
  }
}

template <class T>
NpyArray make_array(const std::vector<size_t>& shape, const T* data) {
  const size_t n = element_count(shape);
  if (n > 0 && data == nullptr) throw Error(ErrorKind::kInvalidArgument, "npy_array: null data");
  NpyArray a{npy_descr<T>(), shape, std::string(n * sizeof(T), '\0')};
  put_le(a.bytes.data(), data, n);
  return a;
}

template <typename Float>
void write_impl(const std::string& path, const Float* data, const std::vector<size_t>& shape) {
  const size_t n = element_count(shape);
  if (n > 0 && data == nullptr) throw Error(ErrorKind::kInvalidArgument, "write_npy: null data");
  const std::string preamble = make_preamble(npy_descr<Float>(), shape);
  // Streamed in fixed-size chunks to a temporary file renamed into place: memory stays
  // constant whatever the array's size, and a failed write leaves the target untouched.
  AtomicFileWriter file(path);
  file.write(preamble.data(), preamble.size());
  constexpr size_t kChunkValues = 8192;
  char chunk[kChunkValues * sizeof(Float)];
  for (size_t first = 0; first < n; first += kChunkValues) {
    const size_t count = std::min(kChunkValues, n - first);
    put_le(chunk, data + first, count);
    file.write(chunk, count * sizeof(Float));
  }
  file.commit();
}

// Finds `'key':` in the header dict and returns the position just after the colon.
template <class Bad>
size_t find_key(const std::string& header, const std::string& key, const Bad& bad) {
  for (const char q : {'\'', '"'}) {
    const std::string k = std::string(1, q) + key + std::string(1, q);
    size_t p = header.find(k);
    if (p == std::string::npos) continue;
    p += k.size();
    while (p < header.size() && header[p] == ' ') ++p;
    if (p >= header.size() || header[p] != ':') bad("no ':' after '" + key + "'");
    ++p;
    while (p < header.size() && header[p] == ' ') ++p;
    return p;
  }
  bad("header has no '" + key + "'");
  return 0;
}

uint64_t read_le(const unsigned char* p, size_t bytes) {
  uint64_t v = 0;
  for (size_t b = 0; b < bytes; ++b) v |= static_cast<uint64_t>(p[b]) << (8 * b);
  return v;
}

// npy_decode's work; `what_file` says what the file was expected to be and `dtypes` which dtypes
// are read, in messages.
NpyArray decode(const std::string& bytes, const std::string& path, const std::string& what_file, const std::string& dtypes) {
  const auto bad = [&](const std::string& what) { throw Error(ErrorKind::kParse, path + ": " + what_file + ": " + what); };
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());

  if (bytes.size() < kPreludeV1 || bytes.compare(0, 6, "\x93NUMPY") != 0) bad("bad magic");
  const int major = u[6];
  // Versions 2 and 3 only widen the header length to 4 bytes (3 also allows UTF-8 in it).
  size_t len_bytes = 0;
  if (major == 1) len_bytes = 2;
  else if (major == 2 || major == 3) len_bytes = 4;
  else bad("unsupported format version " + std::to_string(major));
  if (bytes.size() < 8 + len_bytes) bad("truncated header");
  const size_t header_len = static_cast<size_t>(read_le(u + 8, len_bytes));
  const size_t data_start = 8 + len_bytes + header_len;
  if (bytes.size() < data_start) bad("truncated header");
  const std::string header = bytes.substr(8 + len_bytes, header_len);

  NpyArray a;
  size_t p = find_key(header, "descr", bad);
  if (p >= header.size() || (header[p] != '\'' && header[p] != '"')) bad("descr is not a string");
  const size_t q = header.find(header[p], p + 1);
  if (q == std::string::npos) bad("unterminated descr");
  a.descr = header.substr(p + 1, q - p - 1);
  if (a.descr == "<u1" || a.descr == "u1") a.descr = "|u1";
  const size_t item = item_size(a.descr);
  if (item == 0) bad("dtype '" + a.descr + "' (" + dtypes + ")");

  p = find_key(header, "fortran_order", bad);
  if (header.compare(p, 5, "False") != 0) bad("fortran_order must be False (C order)");

  p = find_key(header, "shape", bad);
  if (p >= header.size() || header[p] != '(') bad("shape is not a tuple");
  const size_t close = header.find(')', p);
  if (close == std::string::npos) bad("unterminated shape");
  size_t i = p + 1;
  while (i < close) {
    while (i < close && (header[i] == ' ' || header[i] == ',')) ++i;
    if (i >= close) break;
    if (header[i] < '0' || header[i] > '9') bad("bad shape entry");
    size_t d = 0;
    while (i < close && header[i] >= '0' && header[i] <= '9') {
      if (d > (SIZE_MAX - 9) / 10) bad("shape entry too large");
      d = d * 10 + static_cast<size_t>(header[i] - '0');
      ++i;
    }
    while (i < close && header[i] == ' ') ++i;
    if (i < close && header[i] != ',') bad("bad shape entry");
    a.shape.push_back(d);
  }

  size_t n = 1;
  for (size_t d : a.shape) {
    if (d != 0 && n > SIZE_MAX / d / item) bad("shape too large");
    n *= d;
  }
  if (bytes.size() - data_start != n * item) {
    bad("data is " + std::to_string(bytes.size() - data_start) + " bytes, shape " + npy_shape_text(a.shape) + " needs " +
        std::to_string(n * item));
  }
  a.bytes = bytes.substr(data_start);
  return a;
}

}  // namespace

size_t NpyArray::elements() const { return element_count(shape); }

std::string npy_shape_text(const std::vector<size_t>& shape) {
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i) s += ", ";
    s += std::to_string(shape[i]);
  }
  if (shape.size() == 1) s += ",";  // Python's 1-tuple needs the trailing comma
  s += ")";
  return s;
}

NpyArray npy_array(const std::vector<size_t>& shape, const float* data) { return make_array(shape, data); }
NpyArray npy_array(const std::vector<size_t>& shape, const double* data) { return make_array(shape, data); }
NpyArray npy_array(const std::vector<size_t>& shape, const int32_t* data) { return make_array(shape, data); }
NpyArray npy_array(const std::vector<size_t>& shape, const int64_t* data) { return make_array(shape, data); }
NpyArray npy_array(const std::vector<size_t>& shape, const uint8_t* data) { return make_array(shape, data); }

template <class T>
std::vector<T> npy_values(const NpyArray& a, const std::string& name) {
  if (a.descr != npy_descr<T>())
    throw Error(ErrorKind::kParse, name + " is " + a.descr + ", expected " + npy_descr<T>());
  const size_t n = a.elements();
  if (a.bytes.size() != n * sizeof(T))
    throw Error(ErrorKind::kParse, name + ": " + std::to_string(a.bytes.size()) + " bytes for shape " + npy_shape_text(a.shape));
  std::vector<T> out(n);
  const auto* u = reinterpret_cast<const unsigned char*>(a.bytes.data());
  for (size_t k = 0; k < n; ++k) {
    const Bits<T> bits = static_cast<Bits<T>>(read_le(u + sizeof(T) * k, sizeof(T)));
    std::memcpy(&out[k], &bits, sizeof(T));
  }
  return out;
}
template std::vector<float> npy_values<float>(const NpyArray&, const std::string&);
template std::vector<double> npy_values<double>(const NpyArray&, const std::string&);
template std::vector<int32_t> npy_values<int32_t>(const NpyArray&, const std::string&);
template std::vector<int64_t> npy_values<int64_t>(const NpyArray&, const std::string&);
template std::vector<uint8_t> npy_values<uint8_t>(const NpyArray&, const std::string&);

std::string npy_encode(const NpyArray& a) { return make_preamble(a.descr, a.shape) + a.bytes; }

NpyArray npy_decode(const std::string& bytes, const std::string& name) {
  return decode(bytes, name, "not a .npy file", "read: '<f4', '<f8', '<i4', '<i8', '|u1'");
}

void write_npy(const std::string& path, const float* data, const std::vector<size_t>& shape) { write_impl(path, data, shape); }

void write_npy(const std::string& path, const double* data, const std::vector<size_t>& shape) { write_impl(path, data, shape); }

std::vector<double> read_npy(const std::string& path, std::vector<size_t>* shape) {
  return parse_npy(read_file_bounded(path, kMaxNpyBytes, ".npy file"), path, shape);
}

std::vector<double> parse_npy(const std::string& bytes, const std::string& path, std::vector<size_t>* shape) {
  const std::string what_file = "not a float32/float64 .npy file", dtypes = "only '<f4' and '<f8' are read";
  NpyArray a = decode(bytes, path, what_file, dtypes);
  std::vector<double> out;
  if (a.descr == "<f8") {
    out = npy_values<double>(a, path);
  } else if (a.descr == "<f4") {
    const std::vector<float> f = npy_values<float>(a, path);
    out.assign(f.begin(), f.end());
  } else {
    throw Error(ErrorKind::kParse, path + ": " + what_file + ": dtype '" + a.descr + "' (" + dtypes + ")");
  }
  if (shape) *shape = std::move(a.shape);
  return out;
}

}  // namespace kata
