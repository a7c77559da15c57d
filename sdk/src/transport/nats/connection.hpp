// One client connection to a NATS cluster (libnats, the C client), with the options a kata
// deployment sets: the servers to try, credentials (a .creds file holding a user JWT and NKEY
// seed, or an NKEY public key and its seed file), TLS, and reconnection. The client reconnects
// and resubscribes by itself after a server is lost; the counters say how often.
//
// Thread rules: a Connection is thread-safe as libnats' natsConnection is (publish from any
// thread); create and destroy it on one thread. Message callbacks of its subscriptions run on
// libnats' threads.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

// libnats' types, declared here so that this header does not pull nats.h into its includers.
typedef struct __natsConnection natsConnection;
typedef struct __jsCtx jsCtx;

namespace kata::transport::nats {

// What the NATS layer throws when it cannot start (options, connection, lease bucket); never on a
// message's path. Its own type rather than the core's kata::Error: this library is a client of
// libkata's public C ABI (kata/kata.h) and of libnats only, as the `kata serve` and `kata send`
// that link it are (sdk/tools/CMakeLists.txt); `kata` prints it as "kata: <message>".
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ConnectionOptions {
  // nats://host:port (tls://host:port for TLS); every server of the cluster, or some of them (the
  // others are learnt from the first one reached). At least one.
  std::vector<std::string> servers;
  // Try the servers in a random order (spreads clients over the cluster); false: in the given order.
  bool randomize = true;
  // The connection's name, shown by the servers' monitoring (e.g. "kata-serve-shard-a").
  std::string name;
  // Authentication, at most one of: a credentials file (user JWT + NKEY seed, as `nsc` writes
  // it), or an NKEY user (public key "U..." and the file holding its seed "SU...").
  std::string credentials_file;
  std::string nkey;
  std::string nkey_seed_file;
  // TLS: required when set or when a server URL says tls://. ca_file verifies the servers;
  // cert_file + key_file are this client's certificate (servers that verify clients).
  bool tls = false;
  std::string tls_ca_file, tls_cert_file, tls_key_file;
  // Time to connect to one server, and between two rounds of reconnection attempts.
  int connect_timeout_ms = 2000;
  int reconnect_wait_ms = 100;
  // Reconnection rounds before giving up (-1: never give up).
  int max_reconnect = -1;
  // PING interval and unanswered PINGs before the connection counts as lost: a server that
  // vanished without closing its sockets (a host down) is noticed within their product.
  int ping_interval_ms = 1000;
  int max_pings_out = 2;
  // Write each publish to the socket at once (a send per message, as ZeroMQ does) instead of
  // leaving it to libnats' flusher thread, whose wake-up costs a hop about half a millisecond on a
  // loaded host (kata_nats_hop). false batches: fewer system calls at high message rates.
  bool send_asap = true;
  // Deliver every subscription's messages on one thread (libnats' shared delivery pool, one thread
  // by default) instead of a thread per subscription: a shard's partitions then reach its ingest
  // one at a time, in order.
  bool single_delivery_thread = false;
  // Timeout of each JetStream request (the lease loop's KV operations), milliseconds.
  int jetstream_wait_ms = 500;
  // Return from the constructor even when no server answers yet, and keep trying in the background
  // (libnats' retry on failed connect): a connection that must exist whether or not its one
  // server is up now (the lease loop's witnesses, lease.hpp).
  bool connect_in_background = false;
  // Only ever the servers given: not those the cluster announces (libnats adds them to its list and
  // may move there when the given one is lost). For a connection that must stay on its one server.
  bool only_given_servers = false;
};

// The servers of a list as the docs write it: URLs separated by commas
// ("nats://n0:4222,nats://n1:4222,nats://n2:4222"), blanks around them ignored; empty entries
// dropped. What every kata NATS client (kata serve, kata send, the sample subscribers) accepts.
std::vector<std::string> split_servers(const std::string& list);

// A description of the options' problem (an empty list of servers, credentials given twice, an
// NKEY without its seed file, ...), or empty when they are usable.
std::string options_problem(const ConnectionOptions& options);

// libnats' last error text for the calling thread, after a failed call (e.g. "wrong last sequence: 12").
std::string last_error();

class Connection {
 public:
  // Connects (trying every server). Throws Error for unusable options, and naming the servers and
  // libnats' reason when none can be reached.
  explicit Connection(const ConnectionOptions& options);
  // Flushes what was published (up to 1 s), then closes.
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  natsConnection* get() const { return connection_; }
  // The connection's JetStream context (requests time out after jetstream_wait_ms).
  jsCtx* jetstream() const { return jetstream_; }

  // Publishes bytes on a subject without waiting; false when libnats refused them (closed, or its
  // reconnect buffer full while disconnected). [any thread]
  bool publish(const std::string& subject, const void* data, size_t size);
  // Waits until the server processed what was published before (false: timeout or not connected).
  bool flush(int timeout_ms);

  // Connected now (not reconnecting, not closed). [any thread]
  bool connected() const;
  // The URL of the server connected now ("" while reconnecting). [any thread]
  std::string connected_url() const;
  // The id the connected server announced ("" while reconnecting): tells two URLs of one server apart
  // from two servers. [any thread]
  std::string connected_server_id() const;

  // Times the connection was lost, and re-established. [any thread]
  uint64_t disconnects() const { return disconnects_.load(std::memory_order_relaxed); }
  uint64_t reconnects() const { return reconnects_.load(std::memory_order_relaxed); }

 private:
  static void on_disconnected(natsConnection*, void* self);
  static void on_reconnected(natsConnection*, void* self);
  static void on_closed(natsConnection*, void* self);
  // Closes the connection and waits (up to 5 s) for libnats' closed callback: its callbacks run on
  // a thread of its own and reach this object, so it may not go away before the last one (closed
  // is always the last) has returned.
  void close_and_wait();
  natsConnection* connection_ = nullptr;
  std::mutex closed_mutex_;
  std::condition_variable closed_cv_;
  bool closed_ = false;  // closed_mutex_
  jsCtx* jetstream_ = nullptr;
  std::atomic<uint64_t> disconnects_{0}, reconnects_{0};
};

}  // namespace kata::transport::nats
