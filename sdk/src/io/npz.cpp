// .npz on libzip (Debian libzip-dev): the zip container is libzip's; each entry's bytes are a .npy
// file (npy.cpp).
#include "io/npz.hpp"

#include <zip.h>

#include <cstdint>
#include <memory>

#include "common/error.hpp"

namespace kata {
namespace {

// An entry larger than this is refused before it is read (read_npy's bound for one .npy file).
constexpr zip_uint64_t kMaxEntryBytes = zip_uint64_t{16} << 30;

std::string zip_error_text(int code) {
  zip_error_t error;
  zip_error_init_with_code(&error, code);
  std::string text = zip_error_strerror(&error);
  zip_error_fini(&error);
  return text;
}

struct ZipDiscard {
  void operator()(zip_t* z) const { zip_discard(z); }
};
using Zip = std::unique_ptr<zip_t, ZipDiscard>;

struct ZipFileClose {
  void operator()(zip_file_t* f) const { zip_fclose(f); }
};

bool ends_with_npy(const std::string& name) { return name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0; }

}  // namespace

void write_npz(const std::string& path, const NpzArrays& arrays) {
  int code = 0;
  // libzip writes the archive to a temporary file beside `path` at zip_close and renames it into place.
  Zip z(zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code));
  if (!z) throw Error(ErrorKind::kIo, path + ": cannot open for writing: " + zip_error_text(code));
  // The sources point into these until zip_close has written them.
  std::vector<std::string> files;
  files.reserve(arrays.size());
  for (const auto& [name, array] : arrays) {
    files.push_back(npy_encode(array));
    const std::string& bytes = files.back();
    zip_source_t* source = zip_source_buffer(z.get(), bytes.data(), bytes.size(), 0);
    if (!source) throw Error(ErrorKind::kIo, path + ": " + name + ": " + zip_strerror(z.get()));
    const zip_int64_t index = zip_file_add(z.get(), (name + ".npy").c_str(), source, ZIP_FL_ENC_UTF_8);
    if (index < 0) {
      zip_source_free(source);
      throw Error(ErrorKind::kIo, path + ": " + name + ": " + zip_strerror(z.get()));
    }
    if (zip_set_file_compression(z.get(), static_cast<zip_uint64_t>(index), ZIP_CM_STORE, 0) != 0)
      throw Error(ErrorKind::kIo, path + ": " + name + ": " + zip_strerror(z.get()));
  }
  if (zip_close(z.get()) != 0) throw Error(ErrorKind::kIo, path + ": write failed: " + zip_strerror(z.get()));
  z.release();  // closed
}

std::map<std::string, NpyArray> read_npz(const std::string& path) {
  int code = 0;
  Zip z(zip_open(path.c_str(), ZIP_RDONLY | ZIP_CHECKCONS, &code));
  if (!z) {
    const ErrorKind kind = code == ZIP_ER_OPEN || code == ZIP_ER_READ || code == ZIP_ER_NOENT ? ErrorKind::kIo : ErrorKind::kParse;
    throw Error(kind, path + ": not a readable .npz (zip) file: " + zip_error_text(code));
  }
  std::map<std::string, NpyArray> arrays;
  const zip_int64_t entries = zip_get_num_entries(z.get(), 0);
  for (zip_int64_t i = 0; i < entries; ++i) {
    const auto index = static_cast<zip_uint64_t>(i);
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(z.get(), index, 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME) || !(st.valid & ZIP_STAT_SIZE))
      throw Error(ErrorKind::kParse, path + ": entry " + std::to_string(i) + ": " + zip_strerror(z.get()));
    std::string name = st.name;
    if (st.size > kMaxEntryBytes) throw Error(ErrorKind::kParse, path + ": " + name + ": entry larger than 16 GiB");
    std::unique_ptr<zip_file_t, ZipFileClose> file(zip_fopen_index(z.get(), index, 0));
    if (!file) throw Error(ErrorKind::kParse, path + ": " + name + ": " + zip_strerror(z.get()));
    std::string bytes(static_cast<size_t>(st.size), '\0');
    const zip_int64_t got = zip_fread(file.get(), bytes.data(), st.size);
    // One more read reaches the entry's end, where libzip checks its CRC.
    char past;
    if (got < 0 || static_cast<zip_uint64_t>(got) != st.size || zip_fread(file.get(), &past, 1) != 0)
      throw Error(ErrorKind::kParse, path + ": " + name + ": damaged entry: " + zip_file_strerror(file.get()));
    if (ends_with_npy(name)) name.resize(name.size() - 4);
    arrays[name] = npy_decode(bytes, path + ": " + name);
  }
  return arrays;
}

}  // namespace kata
