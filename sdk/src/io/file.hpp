// Bounded whole-file reads for every loader (BVH, models, name maps): a path that is not a
// regular file, or larger than the caller's bound, is refused from its metadata before a byte
// is read, with kata::Error(kIo) naming the path. Atomic writes through unique temporaries.
#pragma once

#include <cstdint>
#include <string>

namespace kata {

// Size bounds of the loaders (documented in kata.h; models: metric::kMaxModelBytes).
constexpr uint64_t kMaxBvhBytes = uint64_t{2} << 30;        // 2 GiB
constexpr uint64_t kMaxNameMapBytes = uint64_t{1} << 20;    // 1 MiB

// An open regular file for reading, checked by fstat before any read. Throws kata::Error(kIo)
// naming `path` ("what" says what it should be, e.g. "BVH file") when it cannot be opened, is a
// directory, a FIFO, a device or socket, or is larger than max_bytes.
class BoundedFile {
 public:
  BoundedFile(const std::string& path, uint64_t max_bytes, const char* what);
  ~BoundedFile();
  BoundedFile(const BoundedFile&) = delete;
  BoundedFile& operator=(const BoundedFile&) = delete;

  uint64_t size() const { return size_; }
  // Reads exactly n bytes at the current position; throws kIo on a read error or a file that
  // shrank underneath.
  void read_exact(void* out, size_t n);
  // The rest of the file (size() - position bytes), into a string.
  std::string read_rest();

 private:
  std::string path_;
  const char* what_;
  int fd_ = -1;
  uint64_t size_ = 0;
  uint64_t position_ = 0;
};

// Writes a file atomically: the bytes go to a unique temporary file beside the target
// ("TARGET.XXXXXX", so two writers of one target never collide), renamed over the target by
// commit(). A reader sees the old file or the whole new one, never a truncated one; a writer
// that fails or is destroyed without commit() removes its temporary and leaves the target as
// it was. Throws kata::Error(kIo) naming the target.
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(const std::string& path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  void write(const void* data, size_t n);
  // Flushes, closes and renames the temporary over the target.
  void commit();

 private:
  void discard() noexcept;
  std::string path_;
  std::string tmp_;
  int fd_ = -1;
};

// Reads a whole regular file of at most max_bytes (see BoundedFile).
std::string read_file_bounded(const std::string& path, uint64_t max_bytes, const char* what);

}  // namespace kata
