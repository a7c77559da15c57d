// NumPy .npy writer/reader (format 1.0, little-endian, C order) for features and positions.
#pragma once

#include <string>
#include <vector>

namespace kata {

// Writes data (row-major, product of shape elements) as a .npy file. Throws kata::Error(kIo).
void write_npy(const std::string& path, const float* data, const std::vector<size_t>& shape);
void write_npy(const std::string& path, const double* data, const std::vector<size_t>& shape);

// Reads a float32 or float64 .npy file into doubles. Throws kata::Error(kParse) naming the file.
std::vector<double> read_npy(const std::string& path, std::vector<size_t>* shape);
// The same from the bytes of a .npy file held in memory; `name` stands for the file in messages.
std::vector<double> parse_npy(const std::string& bytes, const std::string& name, std::vector<size_t>* shape);

}  // namespace kata
