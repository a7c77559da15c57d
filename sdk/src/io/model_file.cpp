// .kata model files on disk (the buffer format itself is metric/model.hpp's).
#include "io/model_file.hpp"

#include <algorithm>
#include <vector>

#include "common/error.hpp"
#include "common/text.hpp"
#include "io/file.hpp"

namespace kata::metric {

void save_model(const std::string& path, const Model& model) {
  const std::vector<uint8_t> bytes = serialize_model(model);
  // A unique temporary renamed into place: a reader never sees a half-written model, and two
  // saves of one target never write the same temporary.
  AtomicFileWriter file(path);
  file.write(bytes.data(), bytes.size());
  file.commit();
}

Model load_model(const std::string& path) {
  // Directories, FIFOs, devices and files over kMaxModelBytes are refused from their metadata.
  BoundedFile file(path, kMaxModelBytes, "model file");
  try {
    // The 12-byte header (size prefix, root offset, identifier) is checked against the file size
    // before the rest is read: a foreign or truncated file costs 12 bytes of I/O.
    const size_t size = static_cast<size_t>(file.size());
    std::vector<uint8_t> bytes(std::max<size_t>(size, 12));
    file.read_exact(bytes.data(), std::min<size_t>(size, 12));
    if (size == 0) return parse_model(bytes.data(), 0);  // refused: empty
    check_model_header(bytes.data(), size);
    file.read_exact(bytes.data() + 12, size - 12);
    return parse_model(bytes.data(), size);
  } catch (const Error& e) {
    if (e.kind() == ErrorKind::kIo) throw;
    throw Error(e.kind(), bounded(path) + ": " + e.what());
  }
}

}  // namespace kata::metric
