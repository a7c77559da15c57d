// The ZeroMQ context (its ZAP handler) and the options every kata socket shares (zmq_io.hpp).
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

Context::Context(int io_threads) : context_(zmq_ctx_new()) {
  if (!context_) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create a context: " + zmq_reason());
  zmq_ctx_set(context_, ZMQ_IO_THREADS, io_threads);
}

Context::~Context() {
  zap_.reset();  // its socket closes before the context terminates
  zmq_ctx_term(context_);
}

void Context::authenticate(std::vector<std::string> allowed_client_keys) {
  if (zap_) return zap_->allow(std::move(allowed_client_keys));
  zap_ = std::make_unique<ZapHandler>(context_, std::move(allowed_client_keys));
}

void Context::number_connections() {
  if (!zap_) zap_ = std::make_unique<ZapHandler>(context_, std::vector<std::string>{});
}

void apply_security(void* socket, const SocketSecurity& security) {
  const int64_t max_size = security.max_message_bytes > 0 ? security.max_message_bytes : -1;
  if (zmq_setsockopt(socket, ZMQ_MAXMSGSIZE, &max_size, sizeof max_size) != 0)
    throw Error(ErrorKind::kIo, "ZeroMQ: cannot set ZMQ_MAXMSGSIZE: " + zmq_reason());
  set_int(socket, ZMQ_HANDSHAKE_IVL, security.handshake_ms, "ZMQ_HANDSHAKE_IVL");
  apply_curve(socket, security.curve);
}

}  // namespace kata::transport
