#include "io/file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "common/error.hpp"
#include "common/text.hpp"

namespace kata {

namespace {

const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

BoundedFile::BoundedFile(const std::string& path, uint64_t max_bytes, const char* what)
    : path_(bounded(path)), what_(what) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below by fstat.
  fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw Error(ErrorKind::kIo, path_ + ": cannot open " + what_ + " (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    const int e = errno;
    ::close(fd_);
    throw Error(ErrorKind::kIo, path_ + ": cannot read " + what_ + " (" + std::strerror(e) + ")");
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd_);
    throw Error(ErrorKind::kIo, path_ + ": is " + file_kind(st.st_mode) + ", not a " + what_);
  }
  size_ = static_cast<uint64_t>(st.st_size);
  if (size_ > max_bytes) {
    ::close(fd_);
    throw Error(ErrorKind::kIo, path_ + ": " + what_ + " of " + std::to_string(size_) + " bytes exceeds the " +
                                    std::to_string(max_bytes) + "-byte limit");
  }
  // Back to blocking reads for a regular file (O_NONBLOCK has no effect on them, but be plain).
  ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) & ~O_NONBLOCK);
}

BoundedFile::~BoundedFile() {
  if (fd_ >= 0) ::close(fd_);
}

void BoundedFile::read_exact(void* out, size_t n) {
  auto* p = static_cast<char*>(out);
  size_t done = 0;
  while (done < n) {
    const ssize_t r = ::read(fd_, p + done, n - done);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw Error(ErrorKind::kIo, path_ + ": cannot read " + what_ + " (" + std::strerror(errno) + ")");
    if (r == 0) throw Error(ErrorKind::kIo, path_ + ": " + what_ + " shrank while being read");
    done += static_cast<size_t>(r);
  }
  position_ += n;
}

std::string BoundedFile::read_rest() {
  std::string text(static_cast<size_t>(size_ - position_), '\0');
  read_exact(text.data(), text.size());
  return text;
}

AtomicFileWriter::AtomicFileWriter(const std::string& path) : path_(path), tmp_(path + ".XXXXXX") {
  fd_ = ::mkstemp(tmp_.data());
  if (fd_ < 0)
    throw Error(ErrorKind::kIo, bounded(path_) + ": cannot open for writing (" + std::strerror(errno) + ")");
  // mkstemp creates 0600; a saved file gets the usual permissions (0666 less the umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd_, 0666 & ~mask);
}

AtomicFileWriter::~AtomicFileWriter() { discard(); }

void AtomicFileWriter::discard() noexcept {
  if (fd_ < 0) return;
  ::close(fd_);
  ::unlink(tmp_.c_str());
  fd_ = -1;
}

void AtomicFileWriter::write(const void* data, size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd_, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const int e = errno;
      discard();
      throw Error(ErrorKind::kIo, bounded(path_) + ": write failed (" + std::strerror(e) + ")");
    }
    p += w;
    n -= static_cast<size_t>(w);
  }
}

void AtomicFileWriter::commit() {
  if (fd_ < 0) throw Error(ErrorKind::kIo, bounded(path_) + ": write failed");
  if (::close(fd_) != 0) {
    const int e = errno;
    fd_ = -1;
    ::unlink(tmp_.c_str());
    throw Error(ErrorKind::kIo, bounded(path_) + ": write failed (" + std::strerror(e) + ")");
  }
  fd_ = -1;
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp_.c_str());
    throw Error(ErrorKind::kIo, bounded(path_) + ": cannot rename the temporary file into place (" +
                                    std::strerror(e) + ")");
  }
}

std::string read_file_bounded(const std::string& path, uint64_t max_bytes, const char* what) {
  BoundedFile file(path, max_bytes, what);
  return file.read_rest();
}

}  // namespace kata
