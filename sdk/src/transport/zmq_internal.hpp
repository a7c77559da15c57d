// Helpers shared by the transport's ZeroMQ files (zmq_socket.cpp, publisher.cpp, ingest*.cpp).
// Never included outside sdk/src/transport/.
#pragma once

#include <zmq.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

#include "common/error.hpp"

namespace kata::transport::detail {


inline std::string last_endpoint(void* socket) {
  char buffer[512];
  size_t size = sizeof buffer;
  if (zmq_getsockopt(socket, ZMQ_LAST_ENDPOINT, buffer, &size) != 0) return {};
  return std::string(buffer);
}

inline std::string zmq_reason() { return zmq_strerror(zmq_errno()); }

inline void set_int(void* socket, int option, int value, const char* what) {
  if (zmq_setsockopt(socket, option, &value, sizeof value) != 0)
    throw Error(ErrorKind::kIo, std::string("ZeroMQ: cannot set ") + what + ": " + zmq_reason());
}


inline int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Numbers each ingest's monitor endpoint: an inproc name must be unique within its context.
inline std::atomic<uint64_t> g_monitor_counter{0};

// The ZAP handler's connection number (decimal); 0 for anything else (no handler sends it).
inline uint64_t parse_number(const char* text) {
  uint64_t n = 0;
  for (int i = 0; text[i]; ++i) {
    if (text[i] < '0' || text[i] > '9' || i >= 19) return 0;
    n = n * 10 + static_cast<uint64_t>(text[i] - '0');
  }
  return n;
}

}  // namespace kata::transport::detail
