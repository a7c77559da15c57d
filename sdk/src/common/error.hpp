// kata::Error: the one exception type of the C++ core. Thrown only off the per-frame path
// (loading files, opening streams); the C ABI turns it into a status code and a message.
#pragma once

#include <stdexcept>
#include <string>

namespace kata {

// What went wrong, for the status code the C ABI returns.
enum class ErrorKind {
  kInvalidArgument,  // a caller's value is out of range or inconsistent
  kParse,            // a file or buffer is malformed (message names file and line)
  kIo,               // a file could not be opened, read or written
  kModel,            // a model file is refused (message names the reason)
  kNotFound,         // a named thing (preset, joint, subcommand) does not exist
};

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const noexcept { return kind_; }

 private:
  ErrorKind kind_;
};

}  // namespace kata
