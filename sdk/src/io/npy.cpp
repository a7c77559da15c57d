// NumPy .npy files, format 1.0 (https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html):
// magic "\x93NUMPY", version bytes 1 0, little-endian uint16 header length, then an ASCII dict
// padded with spaces and ended by '\n' so that the data starts at a multiple of 64 bytes.
// Values are written little-endian byte by byte, so the files are the same on any host.
#include "io/npy.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

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

std::string shape_text(const std::vector<size_t>& shape) {
  std::string s = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i) s += ", ";
    s += std::to_string(shape[i]);
  }
  if (shape.size() == 1) s += ",";  // Python's 1-tuple needs the trailing comma
  s += ")";
  return s;
}

size_t element_count(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t d : shape) n *= d;
  return n;
}

std::string make_preamble(const char* descr, const std::vector<size_t>& shape) {
  std::string dict = std::string("{'descr': '") + descr + "', 'fortran_order': False, 'shape': " + shape_text(shape) + ", }";
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

template <typename Float, typename Bits>
void write_impl(const std::string& path, const Float* data, const std::vector<size_t>& shape, const char* descr) {
  static_assert(sizeof(Float) == sizeof(Bits), "bit width");
  const size_t n = element_count(shape);
  if (n > 0 && data == nullptr) throw Error(ErrorKind::kInvalidArgument, "write_npy: null data");
  const std::string preamble = make_preamble(descr, shape);
  // Streamed in fixed-size chunks to a temporary file renamed into place: memory stays
  // constant whatever the array's size, and a failed write leaves the target untouched.
  AtomicFileWriter file(path);
  file.write(preamble.data(), preamble.size());
  constexpr size_t kChunkValues = 8192;
  char chunk[kChunkValues * sizeof(Float)];
  for (size_t first = 0; first < n; first += kChunkValues) {
    const size_t count = std::min(kChunkValues, n - first);
    for (size_t i = 0; i < count; ++i) {
      Bits bits;
      std::memcpy(&bits, data + first + i, sizeof bits);
      for (size_t b = 0; b < sizeof bits; ++b) chunk[i * sizeof bits + b] = static_cast<char>((bits >> (8 * b)) & 0xFF);
    }
    file.write(chunk, count * sizeof(Float));
  }
  file.commit();
}

[[noreturn]] void bad(const std::string& path, const std::string& what) {
  throw Error(ErrorKind::kParse, path + ": not a float32/float64 .npy file: " + what);
}

// Finds `'key':` in the header dict and returns the position just after the colon.
size_t find_key(const std::string& header, const std::string& key, const std::string& path) {
  for (const char q : {'\'', '"'}) {
    const std::string k = std::string(1, q) + key + std::string(1, q);
    size_t p = header.find(k);
    if (p == std::string::npos) continue;
    p += k.size();
    while (p < header.size() && header[p] == ' ') ++p;
    if (p >= header.size() || header[p] != ':') bad(path, "no ':' after '" + key + "'");
    ++p;
    while (p < header.size() && header[p] == ' ') ++p;
    return p;
  }
  bad(path, "header has no '" + key + "'");
}

uint64_t read_le(const unsigned char* p, size_t bytes) {
  uint64_t v = 0;
  for (size_t b = 0; b < bytes; ++b) v |= static_cast<uint64_t>(p[b]) << (8 * b);
  return v;
}

}  // namespace

void write_npy(const std::string& path, const float* data, const std::vector<size_t>& shape) {
  write_impl<float, uint32_t>(path, data, shape, "<f4");
}

void write_npy(const std::string& path, const double* data, const std::vector<size_t>& shape) {
  write_impl<double, uint64_t>(path, data, shape, "<f8");
}

std::vector<double> read_npy(const std::string& path, std::vector<size_t>* shape) {
  return parse_npy(read_file_bounded(path, kMaxNpyBytes, ".npy file"), path, shape);
}

std::vector<double> parse_npy(const std::string& bytes, const std::string& path, std::vector<size_t>* shape) {
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());

  if (bytes.size() < kPreludeV1 || bytes.compare(0, 6, "\x93NUMPY") != 0) bad(path, "bad magic");
  const int major = u[6];
  // Versions 2 and 3 only widen the header length to 4 bytes (3 also allows UTF-8 in it).
  size_t len_bytes = 0;
  if (major == 1) len_bytes = 2;
  else if (major == 2 || major == 3) len_bytes = 4;
  else bad(path, "unsupported format version " + std::to_string(major));
  if (bytes.size() < 8 + len_bytes) bad(path, "truncated header");
  const size_t header_len = static_cast<size_t>(read_le(u + 8, len_bytes));
  const size_t data_start = 8 + len_bytes + header_len;
  if (bytes.size() < data_start) bad(path, "truncated header");
  const std::string header = bytes.substr(8 + len_bytes, header_len);

  size_t p = find_key(header, "descr", path);
  if (p >= header.size() || (header[p] != '\'' && header[p] != '"')) bad(path, "descr is not a string");
  const size_t q = header.find(header[p], p + 1);
  if (q == std::string::npos) bad(path, "unterminated descr");
  const std::string descr = header.substr(p + 1, q - p - 1);
  size_t item = 0;
  if (descr == "<f4") item = 4;
  else if (descr == "<f8") item = 8;
  else bad(path, "dtype '" + descr + "' (only '<f4' and '<f8' are read)");

  p = find_key(header, "fortran_order", path);
  if (header.compare(p, 5, "False") != 0) bad(path, "fortran_order must be False (C order)");

  p = find_key(header, "shape", path);
  if (p >= header.size() || header[p] != '(') bad(path, "shape is not a tuple");
  const size_t close = header.find(')', p);
  if (close == std::string::npos) bad(path, "unterminated shape");
  std::vector<size_t> dims;
  size_t i = p + 1;
  while (i < close) {
    while (i < close && (header[i] == ' ' || header[i] == ',')) ++i;
    if (i >= close) break;
    if (header[i] < '0' || header[i] > '9') bad(path, "bad shape entry");
    size_t d = 0;
    while (i < close && header[i] >= '0' && header[i] <= '9') {
      if (d > (SIZE_MAX - 9) / 10) bad(path, "shape entry too large");
      d = d * 10 + static_cast<size_t>(header[i] - '0');
      ++i;
    }
    while (i < close && header[i] == ' ') ++i;
    if (i < close && header[i] != ',') bad(path, "bad shape entry");
    dims.push_back(d);
  }

  size_t n = 1;
  for (size_t d : dims) {
    if (d != 0 && n > SIZE_MAX / d / item) bad(path, "shape too large");
    n *= d;
  }
  if (bytes.size() - data_start != n * item) {
    bad(path, "data is " + std::to_string(bytes.size() - data_start) + " bytes, shape " + shape_text(dims) + " needs " +
                  std::to_string(n * item));
  }
  std::vector<double> out(n);
  const unsigned char* d = u + data_start;
  for (size_t k = 0; k < n; ++k) {
    if (item == 4) {
      const uint32_t bits = static_cast<uint32_t>(read_le(d + 4 * k, 4));
      float v;
      std::memcpy(&v, &bits, 4);
      out[k] = v;
    } else {
      const uint64_t bits = read_le(d + 8 * k, 8);
      std::memcpy(&out[k], &bits, 8);
    }
  }
  if (shape) *shape = dims;
  return out;
}

}  // namespace kata
