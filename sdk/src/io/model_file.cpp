// .kata model files on disk (the buffer format itself is metric/model.hpp's).
#include "io/model_file.hpp"

#include <cstdio>
#include <fstream>
#include <iterator>
#include <vector>

#include "common/error.hpp"

namespace kata::metric {

void save_model(const std::string& path, const Model& model) {
  const std::vector<uint8_t> bytes = serialize_model(model);
  // Write to a temporary then rename, so a reader never sees a half-written model.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(ErrorKind::kIo, path + ": cannot open for writing");
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out.flush()) throw Error(ErrorKind::kIo, path + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw Error(ErrorKind::kIo, path + ": cannot rename the temporary file into place");
  }
}

Model load_model(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::kIo, path + ": cannot open");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(ErrorKind::kIo, path + ": read failed");
  try {
    return parse_model(bytes.data(), bytes.size());
  } catch (const Error& e) {
    throw Error(e.kind(), path + ": " + e.what());
  }
}

}  // namespace kata::metric
