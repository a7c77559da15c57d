// The ingest's socket and its connection bookkeeping (zmq_io.hpp, Ingest): the monitor's events,
// who holds which descriptor, numbered (ZAP) connections.
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

bool read_socket_event(void* monitor, uint16_t* kind, uint32_t* value) {
  // Two parts: (uint16 event, uint32 value) and the endpoint.
  uint8_t event[6];
  if (zmq_recv(monitor, event, sizeof event, ZMQ_DONTWAIT) < 0) return false;
  char endpoint[256];
  zmq_recv(monitor, endpoint, sizeof endpoint, 0);
  std::memcpy(kind, event, 2);
  std::memcpy(value, event + 2, 4);
  return true;
}

Ingest::Ingest(Context& context, const IngestOptions& options, Handlers handlers)
    : decoder_(options.max_message_bytes, options.require_checksum),
      people_decoder_(options.max_message_bytes, options.require_checksum), handlers_(std::move(handlers)),
      table_(options.limits) {
  const bool direct = options.kind == IngestKind::kDirect;
  if (direct != options.endpoints.empty())
    throw Error(ErrorKind::kInvalidArgument, direct ? "ingest: a direct ingest has no endpoint" : "ingest: no endpoint");
  if (options.shard_count > 1 && options.shard_index >= options.shard_count)
    throw Error(ErrorKind::kInvalidArgument, "ingest: shard index must be below the shard count");
  shard_count_ = options.shard_count;
  shard_index_ = options.shard_index;
  max_connections_ = options.max_connections;
  log_refusals_ = options.log_refusals;
  if (direct) return;  // no socket, no connections: receive() takes its messages
  socket_ = zmq_socket(context.get(), options.kind == IngestKind::kSub ? ZMQ_SUB : ZMQ_PULL);
  if (!socket_) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create an ingest socket: " + zmq_reason());
  try {
    set_int(socket_, ZMQ_RCVHWM, options.receive_hwm, "ZMQ_RCVHWM");
    set_int(socket_, ZMQ_LINGER, 0, "ZMQ_LINGER");
    // ZeroMQ's limit sits above ours: a message a little too large is read, counted as oversized
    // and dropped (its sender stays connected); one past 4 x the limit drops its sender before it
    // is buffered, so no message can cost more memory than that.
    SocketSecurity security = options.security;
    security.max_message_bytes = std::max<int64_t>(4 * static_cast<int64_t>(options.max_message_bytes), 1 << 16);
    apply_security(socket_, security);
    // Keyless: ZeroMQ asks the context's ZAP handler about each connection, which numbers it;
    // the number comes with every message of the connection (poll). A descriptor cannot tell
    // senders apart: the kernel gives a closed connection's descriptor to the next one, and the
    // close is seen on the monitor socket, maybe after that next connection's first messages.
    numbered_ = !security.curve.enabled();
    if (numbered_) {
      context.number_connections();
      if (zmq_setsockopt(socket_, ZMQ_ZAP_DOMAIN, kConnectionDomain, std::strlen(kConnectionDomain)) != 0)
        throw Error(ErrorKind::kIo, "ingest: cannot set ZMQ_ZAP_DOMAIN: " + zmq_reason());
    }
    if (options.kind == IngestKind::kSub && zmq_setsockopt(socket_, ZMQ_SUBSCRIBE, "", 0) != 0)
      throw Error(ErrorKind::kIo, "ingest: cannot subscribe: " + zmq_reason());
    // Connection events: the limit on connections, and a closed connection's streams orphaned.
    const std::string monitor_endpoint = "inproc://kata-ingest-monitor-" + std::to_string(g_monitor_counter++);
    if (zmq_socket_monitor(socket_, monitor_endpoint.c_str(),
                           ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_CONNECTED | ZMQ_EVENT_DISCONNECTED |
                               ZMQ_EVENT_HANDSHAKE_SUCCEEDED | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                               ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) != 0)
      throw Error(ErrorKind::kIo, "ingest: cannot monitor the socket: " + zmq_reason());
    monitor_ = zmq_socket(context.get(), ZMQ_PAIR);
    if (!monitor_) throw Error(ErrorKind::kIo, "ingest: cannot read the socket's events: " + zmq_reason());
    set_int(monitor_, ZMQ_LINGER, 0, "ZMQ_LINGER");
    // No high-water mark on the events: a lost DISCONNECTED would count a connection forever
    // (a flood of connections brings thousands of events between two reads).
    set_int(monitor_, ZMQ_RCVHWM, 0, "ZMQ_RCVHWM");
    if (zmq_connect(monitor_, monitor_endpoint.c_str()) != 0)
      throw Error(ErrorKind::kIo, "ingest: cannot read the socket's events: " + zmq_reason());
    for (const std::string& e : options.endpoints) {
      const bool bind = e.rfind("bind:", 0) == 0;
      const std::string endpoint = bind ? e.substr(5) : e;
      if ((bind ? zmq_bind(socket_, endpoint.c_str()) : zmq_connect(socket_, endpoint.c_str())) != 0)
        throw Error(ErrorKind::kIo,
                    std::string("ingest: cannot ") + (bind ? "bind " : "connect ") + endpoint + ": " + zmq_reason());
    }
  } catch (...) {
    if (monitor_) zmq_close(monitor_);
    zmq_close(socket_);
    throw;
  }
}

std::string Ingest::endpoint() const { return socket_ ? last_endpoint(socket_) : std::string("direct"); }

Ingest::~Ingest() {
  if (socket_ == nullptr) return;  // kDirect
  zmq_socket_monitor(socket_, nullptr, 0);
  zmq_close(monitor_);
  zmq_close(socket_);
}

void Ingest::read_connection_events() {
  // Connection events (the value is the descriptor for these kinds).
  uint16_t kind;
  uint32_t value;
  for (int guard = 0; monitor_ && guard < 4096 && read_socket_event(monitor_, &kind, &value); ++guard) {
    const int fd = static_cast<int>(value);
    if (kind == ZMQ_EVENT_ACCEPTED || kind == ZMQ_EVENT_CONNECTED) {
      ++counters_.connections;
      ++open_connections_;
      Connection& c = connections_[fd];
      c.open = true;
      holder_gone(c);  // the descriptor's previous connection closed (its event came before)
      handshaking_.push_back(fd);
      if (kind == ZMQ_EVENT_ACCEPTED && max_connections_ > 0 && open_connections_ > max_connections_) {
        // Closing the descriptor is ZeroMQ's; shutting it down makes ZeroMQ see the end and
        // close it (a DISCONNECTED event follows).
        ++counters_.connections_refused;
        handshaking_.pop_back();  // counted as refused, not as a failed handshake
        ::shutdown(fd, SHUT_RDWR);
      }
    } else if (kind == ZMQ_EVENT_HANDSHAKE_SUCCEEDED) {
      // The event carries no descriptor: handshakes finish about in the order they began, so the
      // oldest connection still in its handshake is taken to be the one that finished.
      if (!handshaking_.empty()) handshaking_.erase(handshaking_.begin());
    } else if (kind == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL || kind == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
      // The value is the protocol error (or ZAP status), not a descriptor; the DISCONNECTED that
      // follows counts the failure.
      counters_.last_handshake_error = value;
    } else if (kind == ZMQ_EVENT_DISCONNECTED) {
      // Closed before its handshake finished: refused by ZeroMQ (socket kinds that cannot talk,
      // e.g. a PUSH sender on a SUB ingest, which libzmq 4.3 reports with no failure event; CURVE
      // on one side only), refused by max_connections, or a peer that never spoke ZeroMQ.
      const auto pending = std::find(handshaking_.begin(), handshaking_.end(), fd);
      if (pending != handshaking_.end()) {
        handshaking_.erase(pending);
        ++counters_.handshake_failures;
      }
      ++counters_.disconnections;
      if (open_connections_ > 0) --open_connections_;
      Connection& c = connections_[fd];
      // The descriptor's connection closed. A holder taken to be open was named after this
      // connection's open was read (numbered_connection reads the events first), so it is this
      // connection or an earlier one: either way it is gone.
      holder_gone(c);
      if (c.by_descriptor) table_.sender_gone(connection_sender(fd, c.generation));
      ++c.generation;
      c.open = false;
    }
  }
}

void Ingest::holder_gone(Connection& c) {
  if (!c.holder_open) return;
  c.holder_open = false;
  table_.sender_gone(numbered_sender(c.holder));
}

SenderToken Ingest::numbered_connection(int fd, uint64_t number) {
  auto it = connections_.find(fd);
  if (it != connections_.end()) {
    const Connection& c = it->second;
    if (number == c.holder) return c.holder_open ? numbered_sender(number) : kClosedConnection;
    // An earlier connection of the descriptor (its messages waited in the socket's queue): the
    // holder's connection came after it closed.
    if (number < c.holder) return kClosedConnection;
  }
  // A connection's first message read. ZeroMQ reported the connection (and the close of the
  // descriptor's previous one) before it read anything from it: the events up to there are
  // waiting, so after reading them the descriptor's state is at least this connection's.
  read_connection_events();
  Connection& c = connections_[fd];
  holder_gone(c);  // the previous holder closed: the descriptor carried this connection since
  c.holder = number;
  // Open: this connection is taken to hold the descriptor still. If it closed already and the
  // descriptor carries a later connection (whose messages are not read yet), that one's first
  // message or close ends this one (holder_gone); closed: so did every connection it had.
  c.holder_open = c.open;
  return c.holder_open ? numbered_sender(number) : kClosedConnection;
}

SenderToken Ingest::connection_of(int fd) {
  auto it = connections_.find(fd);
  if (it == connections_.end() || !it->second.open) {
    // ZeroMQ reports a connection (from its I/O thread) before it reads anything from it, so a
    // connection that is not open yet has its event waiting; one that stays closed after the
    // events are read sent this message before it closed.
    read_connection_events();
    it = connections_.find(fd);
    if (it == connections_.end() || !it->second.open) return kClosedConnection;
  }
  it->second.by_descriptor = true;
  return connection_sender(fd, it->second.generation);
}

}  // namespace kata::transport
