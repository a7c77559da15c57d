// CURVE keys and the ZAP handler (curve.hpp).
#include "transport/curve.hpp"

#include <sys/stat.h>
#include <zmq.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/error.hpp"

namespace kata::transport {

namespace {

std::string zmq_reason() { return zmq_strerror(zmq_errno()); }

void set_string(void* socket, int option, const std::string& value, const char* what) {
  if (zmq_setsockopt(socket, option, value.data(), value.size()) != 0)
    throw Error(ErrorKind::kIo, std::string("ZeroMQ: cannot set ") + what + ": " + zmq_reason());
}

}  // namespace

bool valid_z85_key(const std::string& key) {
  if (key.size() != 40) return false;
  uint8_t binary[32];
  return zmq_z85_decode(binary, key.c_str()) != nullptr;
}

KeyPair generate_key_pair() {
  char public_key[41], secret_key[41];
  if (zmq_curve_keypair(public_key, secret_key) != 0)
    throw Error(ErrorKind::kIo, "ZeroMQ: cannot make a CURVE key pair (libzmq built without CURVE?): " + zmq_reason());
  return KeyPair{public_key, secret_key};
}

void write_key_files(const std::string& base, const KeyPair& keys) {
  const std::string pub = base + ".pub", secret = base + ".secret";
  {
    std::ofstream out(pub, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(ErrorKind::kIo, pub + ": cannot write");
    out << "# kata CURVE public key: give it to the other side (a server's client key directory, or a client's\n"
           "# server_key).\npublic = \"" << keys.public_key << "\"\n";
    if (!out) throw Error(ErrorKind::kIo, pub + ": cannot write");
  }
  // The secret file is created 0600 before anything is written to it.
  std::filesystem::remove(secret);
  {
    std::ofstream touch(secret, std::ios::binary | std::ios::trunc);
    if (!touch) throw Error(ErrorKind::kIo, secret + ": cannot write");
  }
  if (chmod(secret.c_str(), S_IRUSR | S_IWUSR) != 0) throw Error(ErrorKind::kIo, secret + ": cannot make it private");
  std::ofstream out(secret, std::ios::binary | std::ios::trunc);
  out << "# kata CURVE key pair: keep it private.\npublic = \"" << keys.public_key << "\"\nsecret = \""
      << keys.secret_key << "\"\n";
  if (!out) throw Error(ErrorKind::kIo, secret + ": cannot write");
}

KeyPair read_key_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::kIo, path + ": cannot open the key file");
  KeyPair keys;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const size_t start = line.find_first_not_of(" \t");
    if (start == std::string::npos || line[start] == '#') continue;
    const size_t eq = line.find('=', start);
    if (eq == std::string::npos)
      throw Error(ErrorKind::kParse, path + ":" + std::to_string(number) + ": expected key = \"value\"");
    std::string name = line.substr(start, eq - start);
    name.erase(name.find_last_not_of(" \t") + 1);
    const size_t open = line.find('"', eq), close = open == std::string::npos ? open : line.find('"', open + 1);
    if (close == std::string::npos)
      throw Error(ErrorKind::kParse, path + ":" + std::to_string(number) + ": '" + name + "' needs a quoted value");
    const std::string value = line.substr(open + 1, close - open - 1);
    if (name != "public" && name != "secret")
      throw Error(ErrorKind::kParse, path + ":" + std::to_string(number) + ": unknown key '" + name + "'");
    if (!valid_z85_key(value))
      throw Error(ErrorKind::kParse, path + ":" + std::to_string(number) + ": '" + name +
                                         "' is not a CURVE key (40 Z85 characters)");
    (name == "public" ? keys.public_key : keys.secret_key) = value;
  }
  if (keys.public_key.empty()) throw Error(ErrorKind::kParse, path + ":1: no public key");
  if (!keys.secret_key.empty()) {
    // The secret must belong to the public key beside it.
    char derived[41];
    if (zmq_curve_public(derived, keys.secret_key.c_str()) != 0 || keys.public_key != derived)
      throw Error(ErrorKind::kParse, path + ":1: the secret key does not match the public key");
  }
  return keys;
}

std::vector<std::string> read_key_directory(const std::string& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) throw Error(ErrorKind::kIo, dir + ": not a key directory");
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec))
    if (entry.is_regular_file() && entry.path().extension() == ".pub") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  std::vector<std::string> keys;
  for (const std::string& f : files) keys.push_back(read_key_file(f).public_key);
  return keys;
}

bool reachable_beyond_host(const std::string& endpoint) {
  if (endpoint.rfind("tcp://", 0) != 0) return false;
  std::string host = endpoint.substr(6);
  const size_t colon = host.rfind(':');
  if (colon != std::string::npos) host = host.substr(0, colon);
  // "tcp://source;host:port" names the local interface after the ';'.
  if (const size_t semi = host.find(';'); semi != std::string::npos) host = host.substr(semi + 1);
  if (host == "localhost" || host == "[::1]" || host == "::1" || host == "lo") return false;
  return host.rfind("127.", 0) != 0;
}

void apply_curve(void* socket, const CurveOptions& o) {
  if (!o.enabled()) return;
  if (o.remote_server.empty()) {
    const int server = 1;
    if (zmq_setsockopt(socket, ZMQ_CURVE_SERVER, &server, sizeof server) != 0)
      throw Error(ErrorKind::kIo, "ZeroMQ: cannot make a CURVE server: " + zmq_reason());
    set_string(socket, ZMQ_CURVE_SECRETKEY, o.own.secret_key, "ZMQ_CURVE_SECRETKEY");
    set_string(socket, ZMQ_ZAP_DOMAIN, "kata", "ZMQ_ZAP_DOMAIN");
  } else {
    set_string(socket, ZMQ_CURVE_SERVERKEY, o.remote_server, "ZMQ_CURVE_SERVERKEY");
    set_string(socket, ZMQ_CURVE_PUBLICKEY, o.own.public_key, "ZMQ_CURVE_PUBLICKEY");
    set_string(socket, ZMQ_CURVE_SECRETKEY, o.own.secret_key, "ZMQ_CURVE_SECRETKEY");
  }
}

// ---------------------------------------------------------------------------------------------

ZapHandler::ZapHandler(void* context, std::vector<std::string> allowed_z85) : allowed_(std::move(allowed_z85)) {
  void* socket = zmq_socket(context, ZMQ_REP);
  if (!socket) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create the ZAP socket: " + zmq_reason());
  const int linger = 0;
  zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof linger);
  if (zmq_bind(socket, "inproc://zeromq.zap.01") != 0) {
    const std::string reason = zmq_reason();
    zmq_close(socket);
    throw Error(ErrorKind::kIo, "ZeroMQ: cannot bind the ZAP handler: " + reason);
  }
  thread_ = std::thread([this, socket] { run(socket); });
}

void ZapHandler::allow(std::vector<std::string> allowed_z85) {
  std::lock_guard<std::mutex> lock(allowed_mutex_);
  allowed_ = std::move(allowed_z85);
}

ZapHandler::~ZapHandler() {
  stop_.store(true);
  thread_.join();
}

void ZapHandler::run(void* socket) {
  // A request (RFC 27): version, request id, domain, address, routing id, mechanism, credentials.
  char frames[7][256];
  size_t sizes[7];
  while (!stop_.load()) {
    zmq_pollitem_t item{socket, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&item, 1, 50) <= 0) continue;
    int parts = 0, more = 1;
    bool ok = true;
    while (more) {
      char scratch[256];
      const int n = zmq_recv(socket, parts < 7 ? frames[parts] : scratch, 256, 0);
      if (n < 0) {
        ok = false;
        break;
      }
      if (parts < 7) sizes[parts] = static_cast<size_t>(std::min(n, 256));
      ++parts;
      size_t more_size = sizeof more;
      zmq_getsockopt(socket, ZMQ_RCVMORE, &more, &more_size);
    }
    if (!ok) continue;
    bool allow = false;
    char user[41] = "";
    const bool curve = parts == 7 && sizes[5] == 5 && std::memcmp(frames[5], "CURVE", 5) == 0 && sizes[6] == 32;
    const bool numbered = parts == 6 && sizes[5] == 4 && std::memcmp(frames[5], "NULL", 4) == 0 &&
                          sizes[2] == std::strlen(kConnectionDomain) &&
                          std::memcmp(frames[2], kConnectionDomain, sizes[2]) == 0;
    if (curve && zmq_z85_encode(user, reinterpret_cast<const uint8_t*>(frames[6]), 32)) {
      std::lock_guard<std::mutex> lock(allowed_mutex_);
      allow = std::find(allowed_.begin(), allowed_.end(), user) != allowed_.end();
      (allow ? allowed_count_ : denied_count_).fetch_add(1);
    } else if (numbered) {
      // This thread alone numbers connections, in the order it answers. A number that reaches
      // messages was answered before its connection's handshake ended, so before that connection
      // closed and its descriptor could carry the next one: on one descriptor, a later connection
      // always has the larger number (ingest_connections.cpp relies on it).
      std::snprintf(user, sizeof user, "%llu", static_cast<unsigned long long>(numbered_count_.fetch_add(1) + 1));
      allow = true;
    } else {
      denied_count_.fetch_add(1);
    }
    const char* status = allow ? "200" : "400";
    const char* text = allow ? "OK" : "key not allowed";
    zmq_send(socket, "1.0", 3, ZMQ_SNDMORE);
    zmq_send(socket, frames[1], parts > 1 ? sizes[1] : 0, ZMQ_SNDMORE);
    zmq_send(socket, status, 3, ZMQ_SNDMORE);
    zmq_send(socket, text, std::strlen(text), ZMQ_SNDMORE);
    zmq_send(socket, user, allow ? std::strlen(user) : 0, ZMQ_SNDMORE);
    zmq_send(socket, "", 0, 0);
  }
  zmq_close(socket);
}

}  // namespace kata::transport
