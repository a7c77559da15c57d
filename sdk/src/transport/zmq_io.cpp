// ZeroMQ publisher and ingest (see zmq_io.hpp).
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

namespace kata::transport {

namespace {

std::string last_endpoint(void* socket) {
  char buffer[512];
  size_t size = sizeof buffer;
  if (zmq_getsockopt(socket, ZMQ_LAST_ENDPOINT, buffer, &size) != 0) return {};
  return std::string(buffer);
}

std::string zmq_reason() { return zmq_strerror(zmq_errno()); }

void set_int(void* socket, int option, int value, const char* what) {
  if (zmq_setsockopt(socket, option, &value, sizeof value) != 0)
    throw Error(ErrorKind::kIo, std::string("ZeroMQ: cannot set ") + what + ": " + zmq_reason());
}

}  // namespace

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

// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------

uint64_t IngestCounters::malformed_total() const {
  uint64_t sum = 0;
  for (uint64_t m : malformed) sum += m;
  return sum;
}

uint64_t IngestCounters::dropped_total() const {
  return malformed_total() + refused_skeletons + unknown_stream + wrong_joint_count + out_of_order + other_kind +
         not_owner + refused_limit + out_of_window + stale + practice_bad_values + practice_outside_clip +
         practice_no_clip + practice_queue_full;
}

namespace {

int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::atomic<uint64_t> g_monitor_counter{0};

// The ZAP handler's connection number (decimal); 0 for anything else (no handler sends it).
uint64_t parse_number(const char* text) {
  uint64_t n = 0;
  for (int i = 0; text[i]; ++i) {
    if (text[i] < '0' || text[i] > '9' || i >= 19) return 0;
    n = n * 10 + static_cast<uint64_t>(text[i] - '0');
  }
  return n;
}

}  // namespace

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
    : decoder_(options.max_message_bytes, options.require_checksum), handlers_(std::move(handlers)),
      table_(options.limits) {
  if (options.endpoints.empty()) throw Error(ErrorKind::kInvalidArgument, "ingest: no endpoint");
  if (options.shard_count > 1 && options.shard_index >= options.shard_count)
    throw Error(ErrorKind::kInvalidArgument, "ingest: shard index must be below the shard count");
  shard_count_ = options.shard_count;
  shard_index_ = options.shard_index;
  max_connections_ = options.max_connections;
  log_refusals_ = options.log_refusals;
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

std::string Ingest::endpoint() const { return last_endpoint(socket_); }

Ingest::~Ingest() {
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

void Ingest::housekeeping(int64_t now_ns) {
  if (now_ns < 0) now_ns = steady_now_ns();
  read_connection_events();
  if (now_ns >= next_expiry_ns_) {
    next_expiry_ns_ = now_ns + 1'000'000'000;  // idleness is judged once a second
    expired_.clear();
    table_.expire(now_ns, &expired_);
    for (uint64_t id : expired_) {
      ++counters_.expired;
      if (handlers_.on_close) handlers_.on_close(id);
    }
  }
}

void Ingest::reset() {
  table_ = IngestTable(table_.limits());
  counters_ = IngestCounters{};
  connections_.clear();
  open_connections_ = 0;
  next_expiry_ns_ = 0;
  logged_definition_refusals_.clear();
  handshaking_.clear();
}

int Ingest::poll(int max_messages) {
  housekeeping();
  int count = 0;
  zmq_msg_t message;
  zmq_msg_init(&message);
  while (count < max_messages) {
    // ZeroMQ refuses a message above ZMQ_MAXMSGSIZE before buffering it (and drops its sender).
    if (zmq_msg_recv(&message, socket_, ZMQ_DONTWAIT) < 0) break;
    ++count;
    ++counters_.received;
    // Who sent it: the CURVE key the ZAP handler vouched for, or the connection the ZAP handler
    // numbered (a keyless ingest), else (a CURVE client) the connection's descriptor.
    SenderToken sender = kLocalSender;
    if (const char* user = zmq_msg_gets(&message, "User-Id"); user && *user) {
      sender = numbered_ ? numbered_connection(zmq_msg_get(&message, ZMQ_SRCFD), parse_number(user)) : key_sender(user);
    } else {
      const int fd = zmq_msg_get(&message, ZMQ_SRCFD);
      if (fd >= 0) sender = connection_of(fd);
    }
    // A multi-part message: only the first part is a kata message; drain the rest.
    bool multipart = zmq_msg_more(&message) != 0;
    if (multipart) {
      zmq_msg_t rest;
      zmq_msg_init(&rest);
      int more = 1;
      while (more) {
        if (zmq_msg_recv(&rest, socket_, 0) < 0) break;
        more = zmq_msg_more(&rest);
      }
      zmq_msg_close(&rest);
      ++counters_.malformed[static_cast<int>(DecodeError::kUnknownIdentifier)];
      continue;
    }
    handle(zmq_msg_data(&message), zmq_msg_size(&message), sender, steady_now_ns());
  }
  zmq_msg_close(&message);
  return count;
}

std::string Ingest::describe(SenderToken sender) const {
  if (sender == kLocalSender) return "local";
  if (sender == kClosedConnection) return "(a connection closed since)";
  if (is_key_sender(sender)) {
    char text[32];
    std::snprintf(text, sizeof text, "key %016llx", static_cast<unsigned long long>(sender));
    return text;
  }
  int fd = static_cast<int>(sender & 0xffffffffu) - 1;
  if (sender & kNumberedConnection) {
    // The descriptor the connection holds (a scan: only a first refusal is described).
    fd = -1;
    for (const auto& [descriptor, c] : connections_)
      if (c.holder_open && numbered_sender(c.holder) == sender) fd = descriptor;
  }
  sockaddr_storage address{};
  socklen_t size = sizeof address;
  char text[INET6_ADDRSTRLEN + 16] = "connection";
  if (getpeername(fd, reinterpret_cast<sockaddr*>(&address), &size) == 0) {
    char host[INET6_ADDRSTRLEN] = "";
    if (address.ss_family == AF_INET) {
      const auto* a = reinterpret_cast<const sockaddr_in*>(&address);
      inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
      std::snprintf(text, sizeof text, "%s:%u", host, ntohs(a->sin_port));
    } else if (address.ss_family == AF_INET6) {
      const auto* a = reinterpret_cast<const sockaddr_in6*>(&address);
      inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
      std::snprintf(text, sizeof text, "[%s]:%u", host, ntohs(a->sin6_port));
    } else {
      std::snprintf(text, sizeof text, "local socket %d", fd);
    }
  }
  return text;
}

void Ingest::refused(SenderToken sender, TableVerdict cause, uint64_t stream_id, const std::string& reason) {
  const char* why = "";
  switch (cause) {
    case TableVerdict::kPracticeValues: ++counters_.practice_bad_values; why = "sends a practice setting that cannot be"; break;
    case TableVerdict::kPracticeOutsideClip: ++counters_.practice_outside_clip; why = "sends a practice setting outside the teacher clip"; break;
    case TableVerdict::kPracticeNoClip: ++counters_.practice_no_clip; why = "sends a practice setting for a stream without a clip teacher"; break;
    case TableVerdict::kPracticeQueueFull: ++counters_.practice_queue_full; why = "sends a practice setting its stream's queue had no room for"; break;
    case TableVerdict::kNotOwner: ++counters_.not_owner; why = "sends for a stream another sender owns"; break;
    case TableVerdict::kLimit: ++counters_.refused_limit; why = "defines streams beyond a limit"; break;
    case TableVerdict::kUnknownStream: ++counters_.unknown_stream; return;
    case TableVerdict::kWrongJoints: ++counters_.wrong_joint_count; return;
    case TableVerdict::kOutOfOrder: ++counters_.out_of_order; return;
    case TableVerdict::kOutOfWindow: ++counters_.out_of_window; why = "sends sequence numbers far outside the window"; break;
    case TableVerdict::kStale: {
      ++counters_.stale;
      // A backlog after an outage is dropped without a word; a stream that stays stale with its
      // frames ever later is a source to fix (its clock, or its pace), and said once.
      double growth = 0.0;
      int64_t age_ns = 0;
      if (!log_refusals_ || !table_.stale_run_to_explain(stream_id, &growth, &age_ns)) return;
      char text[400];
      if (growth < 1.0)
        std::snprintf(text, sizeof text,
                      "%d in a row dropped as stale, the last %.2f s old (max_frame_age_ms %lld), their age growing "
                      "%.2f s per second: a capture clock at %.2fx this host's, or a source falling behind (a replay "
                      "slower than recorded? kata send --live-clock)",
                      IngestTable::kStaleRunToExplain, static_cast<double>(age_ns) * 1e-9,
                      static_cast<long long>(table_.limits().max_frame_age_ns / 1'000'000), growth, 1.0 - growth);
      else
        std::snprintf(text, sizeof text,
                      "%d in a row dropped as stale, the last %.2f s old (max_frame_age_ms %lld): its capture times "
                      "do not advance with this host's clock (a unit other than nanoseconds?)",
                      IngestTable::kStaleRunToExplain, static_cast<double>(age_ns) * 1e-9,
                      static_cast<long long>(table_.limits().max_frame_age_ns / 1'000'000));
      if (table_.first_refusal(sender, cause))
        std::fprintf(stderr, "\nkata ingest: sender %s sends frames ever later behind their capture times (stream %llu: %s); "
                     "counted, not logged again\n", describe(sender).c_str(), static_cast<unsigned long long>(stream_id), text);
      return;
    }
    case TableVerdict::kAccepted:
    case TableVerdict::kRepeated: return;
  }
  if (log_refusals_ && table_.first_refusal(sender, cause))
    std::fprintf(stderr, "\nkata ingest: sender %s %s (stream %llu%s%s); counted, not logged again\n",
                 describe(sender).c_str(), why, static_cast<unsigned long long>(stream_id), reason.empty() ? "" : ": ",
                 bounded(reason).c_str());
}

void Ingest::handle_practice(SenderToken sender, int64_t now_ns) {
  const PracticeSetting p = decoder_.practice();
  const TableVerdict v = table_.judge_practice(sender, p.stream_id, p.revision);
  if (v != TableVerdict::kAccepted && v != TableVerdict::kRepeated) return refused(sender, v, p.stream_id);
  // Values no clip can hold are the verifier's to refuse, with the reason; the clip's bounds are
  // the receiver's (it knows the stream's teacher).
  char why[192];
  if (practice_values_problem(p, why, sizeof why)) return refused(sender, TableVerdict::kPracticeValues, p.stream_id, why);
  if (v == TableVerdict::kRepeated) {
    ++counters_.repeated_practices;
    return;
  }
  std::string reason;
  const TableVerdict taken = handlers_.on_practice ? handlers_.on_practice(p, &reason) : TableVerdict::kPracticeNoClip;
  if (taken != TableVerdict::kAccepted) return refused(sender, taken, p.stream_id, reason);
  table_.commit_practice(p.stream_id, p.revision, now_ns);
  ++counters_.practices;
}

void Ingest::handle(const void* data, size_t size, SenderToken sender, int64_t now_ns) {
  if (now_ns < 0) now_ns = steady_now_ns();
  uint64_t topic_stream = 0;
  if (shard_count_ > 1 && size >= kTopicBytes && parse_topic(static_cast<const uint8_t*>(data), &topic_stream) &&
      shard_of(topic_stream, shard_count_) != shard_index_) {
    ++counters_.other_shard;
    return;
  }
  const MessageKind kind = decoder_.decode(data, size);
  switch (kind) {
    case MessageKind::kNone:
      ++counters_.malformed[static_cast<int>(decoder_.error())];
      return;
    case MessageKind::kResult:
    case MessageKind::kStats:
      ++counters_.other_kind;
      return;
    case MessageKind::kPractice:
      return handle_practice(sender, now_ns);
    case MessageKind::kSkeleton: {
      const uint64_t id = decoder_.stream_id();
      // Ownership and limits first: a refused definition allocates nothing.
      if (decoder_.skeleton_closed()) {
        const TableVerdict v = table_.judge_close(sender, id);
        if (v != TableVerdict::kAccepted) return refused(sender, v, id);
        table_.forget(id);
        ++counters_.closes;
        if (handlers_.on_close) handlers_.on_close(id);
        return;
      }
      bool is_new = false;
      const TableVerdict v = table_.judge_definition(sender, id, decoder_.skeleton_revision(), &is_new);
      if (v == TableVerdict::kRepeated) {
        ++counters_.repeated_skeletons;
        return;
      }
      if (v != TableVerdict::kAccepted) return refused(sender, v, id);
      SkeletonDefinition definition;
      try {
        definition = decoder_.skeleton();
      } catch (const Error&) {
        ++counters_.refused_skeletons;
        return;
      }
      bool accepted = false;
      try {
        if (is_new) accepted = handlers_.on_skeleton ? handlers_.on_skeleton(definition) : true;
        else accepted = handlers_.on_revision ? handlers_.on_revision(definition) : false;
      } catch (const Error& e) {
        accepted = false;
        // Why, once per stream (the first 64 streams): a skeleton that does not fit its preset
        // would otherwise show only as dropped frames.
        if (log_refusals_ && logged_definition_refusals_.size() < 64 &&
            std::find(logged_definition_refusals_.begin(), logged_definition_refusals_.end(), id) ==
                logged_definition_refusals_.end()) {
          logged_definition_refusals_.push_back(id);
          std::fprintf(stderr,
                       "\nkata ingest: stream %llu's skeleton definition (preset '%s') refused: %s; its frames are "
                       "dropped (counted as unknown stream) until a definition is accepted; not logged again\n",
                       static_cast<unsigned long long>(id), bounded(definition.preset).c_str(), e.what());
        }
      }
      if (!accepted) {
        ++counters_.refused_skeletons;
        return;
      }
      table_.commit_definition(sender, id, definition.revision, definition.skeleton.joint_count(), now_ns);
      ++counters_.skeletons;
      if (!is_new) ++counters_.revisions;
      return;
    }
    case MessageKind::kFrame: {
      const FrameView& f = decoder_.frame();
      bool restarted = false;
      uint64_t gap = 0;
      int64_t age_ns = -1;
      const TableVerdict v =
          table_.judge_frame(sender, f.stream_id, f.sequence, f.capture_ns, f.joints, now_ns, &restarted, &gap, &age_ns);
      if (v != TableVerdict::kAccepted) {
        if (v != TableVerdict::kUnknownStream && handlers_.on_refused_frame) handlers_.on_refused_frame(f.stream_id, v);
        return refused(sender, v, f.stream_id);
      }
      if (restarted) ++counters_.restarts;
      counters_.sequence_gaps += gap;
      if (age_ns >= 0) {
        const int bucket = age_ns < 1 ? 0 : static_cast<int>(8.0 * std::log2(static_cast<double>(age_ns)));
        ++counters_.age_histogram[std::min(std::max(bucket, 0), IngestCounters::kAgeBuckets - 1)];
      }
      ++counters_.frames;
      if (handlers_.on_frame) handlers_.on_frame(f, restarted);
      return;
    }
  }
}

}  // namespace kata::transport
