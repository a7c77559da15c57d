// The publisher of results, definitions and stats (zmq_io.hpp, Publisher).
#include "transport/zmq_io.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <zmq.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "common/error.hpp"
#include "common/text.hpp"
#include "transport/zmq_internal.hpp"

namespace kata::transport {

using namespace detail;

Publisher::Publisher(Context& context, const PublisherOptions& options) {
  if (options.endpoints.empty()) throw Error(ErrorKind::kInvalidArgument, "publisher: no endpoint");
  socket_ = zmq_socket(context.get(), ZMQ_XPUB);
  if (!socket_) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create an XPUB socket: " + zmq_reason());
  try {
    set_int(socket_, ZMQ_SNDHWM, options.send_hwm, "ZMQ_SNDHWM");
    set_int(socket_, ZMQ_LINGER, options.linger_ms, "ZMQ_LINGER");
    set_int(socket_, ZMQ_XPUB_VERBOSE, 1, "ZMQ_XPUB_VERBOSE");
    apply_security(socket_, options.security);
    for (const std::string& e : options.endpoints) {
      const bool connect = e.rfind("connect:", 0) == 0;
      const std::string endpoint = connect ? e.substr(8) : e;
      if ((connect ? zmq_connect(socket_, endpoint.c_str()) : zmq_bind(socket_, endpoint.c_str())) != 0)
        throw Error(ErrorKind::kIo, std::string("publisher: cannot ") + (connect ? "connect " : "bind ") + endpoint +
                                        ": " + zmq_reason());
    }
  } catch (...) {
    zmq_close(socket_);
    throw;
  }
}

std::string Publisher::endpoint() const { return last_endpoint(socket_); }

Publisher::~Publisher() { zmq_close(socket_); }

bool Publisher::send(Bytes message) {
  if (zmq_send(socket_, message.data, message.size, ZMQ_DONTWAIT) < 0) {
    ++failed_;
    return false;
  }
  ++sent_;
  return true;
}

int Publisher::descriptor() const {
  int fd = -1;
  size_t size = sizeof fd;
  if (zmq_getsockopt(socket_, ZMQ_FD, &fd, &size) != 0) throw Error(ErrorKind::kIo, "publisher: ZMQ_FD");
  return fd;
}

bool Publisher::joins_waiting() const {
  int events = 0;
  size_t size = sizeof events;
  return zmq_getsockopt(socket_, ZMQ_EVENTS, &events, &size) == 0 && (events & ZMQ_POLLIN);
}

int Publisher::poll_joins(const std::function<void(const uint8_t*, size_t)>& on_join) {
  int count = 0;
  uint8_t buffer[256];
  for (;;) {
    const int n = zmq_recv(socket_, buffer, sizeof buffer, ZMQ_DONTWAIT);
    if (n < 0) break;
    ++count;
    // 1 = subscribe, 0 = unsubscribe; the rest is the topic prefix (truncated to the buffer).
    if (n >= 1 && buffer[0] == 1) {
      const size_t size = static_cast<size_t>(n) - 1;
      on_join(buffer + 1, size < sizeof buffer - 1 ? size : sizeof buffer - 1);
    }
  }
  return count;
}

}  // namespace kata::transport
