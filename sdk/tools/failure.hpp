// How a CLI command reports a failure without the core's kata::Error: the commands that are
// clients of the public C ABI (kata.h) see only libkata. main.cpp prints it as it prints
// kata::Error, "kata: message", exit 1.
#pragma once

#include <stdexcept>
#include <string>

namespace kata::cli {

class Failure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] inline void fail(const std::string& message) { throw Failure(message); }

}  // namespace kata::cli
