#include "transport/nats/connection.hpp"

#include <nats/nats.h>

#include <chrono>
#include <memory>

namespace kata::transport::nats {

std::string last_error() {
  natsStatus status = NATS_OK;
  const char* text = nats_GetLastError(&status);
  if (text != nullptr && *text != '\0') return text;
  return natsStatus_GetText(status);
}

std::string options_problem(const ConnectionOptions& o) {
  if (o.servers.empty()) return "no NATS server given (servers = [\"nats://host:4222\", ...])";
  for (const auto& s : o.servers)
    if (s.empty() || s.find(',') != std::string::npos) return "a NATS server URL is empty or holds a comma: \"" + s + "\"";
  if (!o.credentials_file.empty() && (!o.nkey.empty() || !o.nkey_seed_file.empty()))
    return "give either a credentials file or an NKEY and its seed file, not both";
  if (o.nkey.empty() != o.nkey_seed_file.empty()) return "an NKEY needs both its public key and its seed file";
  if (!o.nkey.empty() && o.nkey[0] != 'U') return "the NKEY must be a user public key (it starts with U)";
  if (o.tls_cert_file.empty() != o.tls_key_file.empty())
    return "a TLS client certificate needs both its certificate and its key file";
  if (o.connect_timeout_ms <= 0 || o.reconnect_wait_ms < 0 || o.ping_interval_ms <= 0 || o.max_pings_out <= 0 ||
      o.jetstream_wait_ms <= 0)
    return "NATS timeouts must be positive";
  return {};
}

std::vector<std::string> split_servers(const std::string& list) {
  std::vector<std::string> out;
  size_t begin = 0;
  while (begin <= list.size()) {
    size_t end = list.find(',', begin);
    if (end == std::string::npos) end = list.size();
    size_t a = begin, b = end;
    while (a < b && (list[a] == ' ' || list[a] == '\t')) ++a;
    while (b > a && (list[b - 1] == ' ' || list[b - 1] == '\t')) --b;
    if (b > a) out.push_back(list.substr(a, b - a));
    begin = end + 1;
  }
  return out;
}

namespace {
struct OptionsDeleter {
  void operator()(natsOptions* o) const { natsOptions_Destroy(o); }
};

void check(natsStatus s, const char* what) {
  if (s != NATS_OK) throw Error(std::string("NATS option ") + what + ": " + last_error());
}
}  // namespace

Connection::Connection(const ConnectionOptions& o) {
  if (auto problem = options_problem(o); !problem.empty()) throw Error(problem);
  natsOptions* raw = nullptr;
  if (natsOptions_Create(&raw) != NATS_OK) throw Error("NATS: " + last_error());
  std::unique_ptr<natsOptions, OptionsDeleter> opts(raw);
  std::vector<const char*> urls;
  for (const auto& s : o.servers) urls.push_back(s.c_str());
  check(natsOptions_SetServers(raw, urls.data(), static_cast<int>(urls.size())), "servers");
  check(natsOptions_SetNoRandomize(raw, !o.randomize), "randomize");
  if (!o.name.empty()) check(natsOptions_SetName(raw, o.name.c_str()), "name");
  if (!o.credentials_file.empty())
    check(natsOptions_SetUserCredentialsFromFiles(raw, o.credentials_file.c_str(), nullptr), "credentials file");
  if (!o.nkey.empty()) check(natsOptions_SetNKeyFromSeed(raw, o.nkey.c_str(), o.nkey_seed_file.c_str()), "nkey");
  if (o.tls || !o.tls_ca_file.empty() || !o.tls_cert_file.empty()) check(natsOptions_SetSecure(raw, true), "tls");
  if (!o.tls_ca_file.empty()) check(natsOptions_LoadCATrustedCertificates(raw, o.tls_ca_file.c_str()), "tls ca file");
  if (!o.tls_cert_file.empty())
    check(natsOptions_LoadCertificatesChain(raw, o.tls_cert_file.c_str(), o.tls_key_file.c_str()), "tls certificate");
  check(natsOptions_SetTimeout(raw, o.connect_timeout_ms), "connect timeout");
  check(natsOptions_SetReconnectWait(raw, o.reconnect_wait_ms), "reconnect wait");
  // Jitter spreads many clients' reconnections; kept small next to reconnect_wait_ms.
  check(natsOptions_SetReconnectJitter(raw, o.reconnect_wait_ms / 4, o.reconnect_wait_ms / 2), "reconnect jitter");
  check(natsOptions_SetMaxReconnect(raw, o.max_reconnect), "max reconnect");
  check(natsOptions_SetPingInterval(raw, o.ping_interval_ms), "ping interval");
  check(natsOptions_SetMaxPingsOut(raw, o.max_pings_out), "max pings out");
  check(natsOptions_SetSendAsap(raw, o.send_asap), "send asap");
  if (o.single_delivery_thread) check(natsOptions_UseGlobalMessageDelivery(raw, true), "global message delivery");
  if (o.only_given_servers) check(natsOptions_SetIgnoreDiscoveredServers(raw, true), "ignore discovered servers");
  if (o.connect_in_background)  // A callback makes the first connect asynchronous (without one, libnats blocks until connected).
    check(natsOptions_SetRetryOnFailedConnect(raw, true, &Connection::on_reconnected, this), "retry on failed connect");
  check(natsOptions_SetDisconnectedCB(raw, &Connection::on_disconnected, this), "disconnected callback");
  check(natsOptions_SetReconnectedCB(raw, &Connection::on_reconnected, this), "reconnected callback");
  check(natsOptions_SetClosedCB(raw, &Connection::on_closed, this), "closed callback");
  natsStatus s = natsConnection_Connect(&connection_, raw);
  if (s == NATS_NOT_YET_CONNECTED && o.connect_in_background) s = NATS_OK;
  if (s != NATS_OK) {
    std::string all;
    for (const auto& u : o.servers) all += (all.empty() ? "" : ", ") + u;
    throw Error("NATS: cannot connect to " + all + ": " + last_error());
  }
  jsOptions js;
  jsOptions_Init(&js);
  js.Wait = o.jetstream_wait_ms;
  if (natsConnection_JetStream(&jetstream_, connection_, &js) != NATS_OK) {
    std::string why = last_error();
    close_and_wait();
    natsConnection_Destroy(connection_);
    throw Error("NATS: JetStream context: " + why);
  }
}

Connection::~Connection() {
  if (jetstream_ != nullptr) jsCtx_Destroy(jetstream_);
  if (connection_ != nullptr) {
    if (connected()) natsConnection_FlushTimeout(connection_, 1000);  // not while reconnecting: nothing to wait for
    close_and_wait();
    natsConnection_Destroy(connection_);
  }
}

bool Connection::publish(const std::string& subject, const void* data, size_t size) {
  return natsConnection_Publish(connection_, subject.c_str(), data, static_cast<int>(size)) == NATS_OK;
}

bool Connection::flush(int timeout_ms) { return natsConnection_FlushTimeout(connection_, timeout_ms) == NATS_OK; }

bool Connection::connected() const { return natsConnection_Status(connection_) == NATS_CONN_STATUS_CONNECTED; }

std::string Connection::connected_url() const {
  char buffer[256] = {};
  if (natsConnection_GetConnectedUrl(connection_, buffer, sizeof buffer) != NATS_OK) return {};
  return buffer;
}

std::string Connection::connected_server_id() const {
  char buffer[128] = {};
  if (natsConnection_GetConnectedServerId(connection_, buffer, sizeof buffer) != NATS_OK) return {};
  return buffer;
}

void Connection::on_disconnected(natsConnection*, void* self) {
  static_cast<Connection*>(self)->disconnects_.fetch_add(1, std::memory_order_relaxed);
}

void Connection::on_closed(natsConnection*, void* self) {
  auto& c = *static_cast<Connection*>(self);
  std::lock_guard<std::mutex> lock(c.closed_mutex_);
  c.closed_ = true;
  c.closed_cv_.notify_all();
}

void Connection::close_and_wait() {
  natsConnection_Close(connection_);
  std::unique_lock<std::mutex> lock(closed_mutex_);
  closed_cv_.wait_for(lock, std::chrono::seconds(5), [this] { return closed_; });
}

void Connection::on_reconnected(natsConnection*, void* self) {
  static_cast<Connection*>(self)->reconnects_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace kata::transport::nats
