// NumPy .npz files: a zip (libzip) of .npy arrays, one entry "<name>.npy" per array, as
// numpy.savez writes them; `numpy.load(path)` reads them. Its own library (kata_npz) so that
// libkata.so does not link libzip: only the CLI writes and reads .npz.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "io/npy.hpp"

namespace kata {

// Named arrays in the order they are written.
using NpzArrays = std::vector<std::pair<std::string, NpyArray>>;

// Writes the arrays, stored uncompressed (what numpy.savez does), to a temporary file renamed into
// place (a failed write leaves `path` as it was). Throws kata::Error(kIo) naming the file.
void write_npz(const std::string& path, const NpzArrays& arrays);

// Reads every array of a .npz file (stored or deflated entries, as numpy.savez and
// numpy.savez_compressed write them), by name without ".npy". Throws kata::Error(kIo) when the file
// cannot be read, kata::Error(kParse) naming the file and the entry at fault otherwise.
std::map<std::string, NpyArray> read_npz(const std::string& path);

}  // namespace kata
