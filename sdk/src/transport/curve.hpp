// ZeroMQ CURVE: key pairs, key files and the allow-list every kata server socket checks.
//
// A server socket (kata serve's ingest and publisher, kata proxy's two sides) holds the
// server's secret key and asks ZAP (ZeroMQ's authentication protocol, RFC 27) about every
// client: a ZAP handler thread of the socket's context answers from an allow-list of client
// public keys (as CZMQ's zauth does with a key directory), replying with the key as the
// connection's User-Id, so the ingest binds a stream to the key that defined it. A client
// (kata send, a subscriber) holds its own key pair and the server's public key; an unknown key
// never completes its handshake: nothing in, nothing out.
//
// Key files (written by `kata keygen`, read by the configs and the CLI):
//   NAME.pub     public = "<40 Z85 characters>"                       (share it)
//   NAME.secret  public = "...", secret = "<40 Z85 characters>"       (mode 0600)
// A client key directory holds *.pub files; anything else in it is ignored.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace kata::transport {

struct KeyPair {
  std::string public_key;  // Z85, 40 characters
  std::string secret_key;  // Z85, 40 characters (empty in a public key file)
};

// A new key pair (zmq_curve_keypair). Throws kata::Error(kIo) when libzmq lacks CURVE.
KeyPair generate_key_pair();
// Writes NAME.pub and NAME.secret (0600). Throws kata::Error(kIo) naming the file.
void write_key_files(const std::string& base, const KeyPair& keys);
// Reads a .pub or .secret file; refusals (kParse / kIo) name the file and line.
KeyPair read_key_file(const std::string& path);
// The public keys of every *.pub file in a directory (sorted by file name). Throws naming the file.
std::vector<std::string> read_key_directory(const std::string& dir);
// True when the text is 40 Z85 characters that decode to a 32-byte key.
bool valid_z85_key(const std::string& key);

// CURVE settings of one socket. server: the socket's own key pair, clients must be in
// allowed_clients. client: remote_server is the server's public key, own is this client's pair.
struct CurveOptions {
  KeyPair own;                           // empty: no CURVE on this socket
  std::string remote_server;             // set: this socket is a client of that server
  std::vector<std::string> allowed_clients;  // server: the allow-list (may be empty: nobody)
  bool enabled() const { return !own.secret_key.empty(); }
};

// True when a bind endpoint is reachable from beyond this host: tcp:// on a host other than
// 127.x.x.x, localhost or [::1] ("*" and 0.0.0.0 included). ipc:// and inproc:// are local.
bool reachable_beyond_host(const std::string& endpoint);

// Applies CURVE options to a socket before it binds / connects (server: ZAP domain "kata").
// Throws kata::Error(kIo) with ZeroMQ's reason.
void apply_curve(void* socket, const CurveOptions& options);

// The ZAP domain of a keyless ingest (zmq_io.hpp): ZeroMQ asks ZAP about each of its connections
// too (the NULL mechanism does when a domain is set), and the handler answers with a number of its
// own for the connection, which ZeroMQ then attaches to every message the connection carries
// ("User-Id"): the ingest tells its senders apart by it, not by a descriptor the kernel reuses.
inline constexpr const char* kConnectionDomain = "kata-connection";

// The ZAP handler of one ZeroMQ context: a thread answering inproc://zeromq.zap.01. CURVE clients
// are let in when their public key is on the allow-list (its User-Id: the key); NULL connections
// of kConnectionDomain always, each with the next connection number (decimal, from 1; unique in
// the context). Everything else is refused. Start it before any socket that asks binds.
class ZapHandler {
 public:
  ZapHandler(void* context, std::vector<std::string> allowed_z85);
  ~ZapHandler();  // stops the thread (its socket closes before the context terminates)
  ZapHandler(const ZapHandler&) = delete;
  ZapHandler& operator=(const ZapHandler&) = delete;
  // Replaces the allow-list (a handler started for keyless ingests, then given keys).
  void allow(std::vector<std::string> allowed_z85);
  uint64_t allowed() const { return allowed_count_.load(); }
  uint64_t denied() const { return denied_count_.load(); }
  uint64_t numbered() const { return numbered_count_.load(); }  // keyless connections numbered

 private:
  void run(void* socket);
  std::mutex allowed_mutex_;  // the handler thread reads the list once per CURVE handshake
  std::vector<std::string> allowed_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> allowed_count_{0}, denied_count_{0}, numbered_count_{0};
  std::thread thread_;
};

}  // namespace kata::transport
