#include "nats_cluster.hpp"

#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nats/nats.h>

#include <chrono>
#include <random>
#include <deque>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "transport/nats/partition.hpp"

extern char** environ;

namespace kata::test {

int free_port() {
  // Below Linux's ephemeral range (32768-60999 by default): a port picked from that range can be
  // taken between our check and the server's bind by any outgoing connection on the machine (the
  // other tests' ZeroMQ clients make hundreds), which is how a server once failed with "address
  // already in use". Here only another listener could take it; start() retries when one does.
  static std::mt19937 random(static_cast<unsigned>(::getpid()) * 2654435761u ^
                              static_cast<unsigned>(std::chrono::steady_clock::now().time_since_epoch().count()));
  for (int attempt = 0; attempt < 200; ++attempt) {
    const int candidate = 20000 + static_cast<int>(random() % 12000);
    int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return -1;
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(static_cast<uint16_t>(candidate));
    const bool free = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    ::close(fd);
    if (free) return candidate;
  }
  return -1;
}

pid_t spawn(const std::vector<std::string>& argv, const std::string& log_file) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

std::string NatsCluster::server_binary() {
  std::vector<std::string> dirs;
  if (const char* path = std::getenv("PATH")) {
    std::stringstream ss(path);
    for (std::string d; std::getline(ss, d, ':');) dirs.push_back(d);
  }
  dirs.insert(dirs.end(), {"/usr/sbin", "/usr/local/sbin", "/usr/bin"});
  for (const auto& d : dirs) {
    const std::string candidate = d + "/nats-server";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

NatsCluster::NatsCluster(const std::string& dir, int servers, uint32_t partitions, const std::string& prefix)
    : dir_(dir) {
  const std::string binary = server_binary();
  if (binary.empty()) {
    problem_ = "nats-server not found (Debian package nats-server; ./build.sh deps installs it)";
    return;
  }
  // A port checked free can still be taken before the server binds it: then start again on others.
  for (int attempt = 1; attempt <= 3; ++attempt) {
    problem_.clear();
    if (start(binary, servers, partitions, prefix) || !port_taken_) return;
    stop();
  }
}

bool NatsCluster::start(const std::string& binary, int servers, uint32_t partitions, const std::string& prefix) {
  port_taken_ = false;
  client_ports_.clear();
  for (int i = 0; i < servers; ++i) {  // a previous attempt's store and log
    std::error_code ignored;
    std::filesystem::remove_all(dir_ + "/js-" + name(i), ignored);
    std::filesystem::remove(dir_ + "/" + name(i) + ".log", ignored);
  }
  std::vector<int> cluster_ports;
  for (int i = 0; i < servers; ++i) {
    client_ports_.push_back(free_port());
    cluster_ports.push_back(free_port());
  }
  std::string routes;
  for (int i = 0; i < servers; ++i)
    routes += (i ? ", " : "") + std::string("nats-route://127.0.0.1:") + std::to_string(cluster_ports[i]);
  for (int i = 0; i < servers; ++i) {
    const std::string conf = dir_ + "/" + name(i) + ".conf";
    std::ofstream out(conf);
    out << "server_name: " << name(i) << "\n"
        << "listen: 127.0.0.1:" << client_ports_[i] << "\n"
        << "jetstream { store_dir: \"" << dir_ << "/js-" << name(i)
        << "\", max_memory_store: 64MB, max_file_store: 0 }\n";
    if (servers > 1)
      out << "cluster { name: kata_test, listen: 127.0.0.1:" << cluster_ports[i] << ", routes: [" << routes << "] }\n";
    out << transport::nats::server_mapping(prefix, partitions) << "\n";
    out.close();
    const pid_t pid = spawn({binary, "-c", conf}, dir_ + "/" + name(i) + ".log");
    if (pid < 0) {
      problem_ = "cannot start " + binary;
      return false;
    }
    pids_.push_back(pid);
  }
  // Ready when JetStream answers an account-info request through every server (the meta leader is
  // elected and every server is routed).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (int i = 0; i < servers; ++i) {
    bool ready = false;
    while (!ready && std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (::waitpid(pids_[static_cast<size_t>(i)], &status, WNOHANG) == pids_[static_cast<size_t>(i)]) {
        pids_[static_cast<size_t>(i)] = -1;  // exited (a port taken, say): its log says why
        break;
      }
      natsConnection* nc = nullptr;
      if (natsConnection_ConnectTo(&nc, url(i).c_str()) == NATS_OK) {
        natsMsg* reply = nullptr;
        if (natsConnection_RequestString(&reply, nc, "$JS.API.INFO", "", 500) == NATS_OK) {
          const std::string body(natsMsg_GetData(reply), static_cast<size_t>(natsMsg_GetDataLength(reply)));
          ready = body.find("\"memory\"") != std::string::npos && body.find("\"error\"") == std::string::npos;
          natsMsg_Destroy(reply);
        }
        natsConnection_Destroy(nc);
      }
      if (!ready) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    if (!ready) {
      problem_ = "NATS server " + name(i) + " not ready in 20 s:\n" + log_tail(i);
      port_taken_ = problem_.find("address already in use") != std::string::npos;
      return false;
    }
  }
  return true;
}

NatsCluster::~NatsCluster() { stop(); }

void NatsCluster::stop() {
  for (pid_t pid : pids_)
    if (pid > 0) ::kill(pid, SIGTERM);
  for (pid_t& pid : pids_) {
    if (pid <= 0) continue;
    int status = 0;
    for (int i = 0; i < 200 && ::waitpid(pid, &status, WNOHANG) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (::waitpid(pid, &status, WNOHANG) == 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
    }
    pid = -1;
  }
  pids_.clear();
}

std::string NatsCluster::url(int i) const { return "nats://127.0.0.1:" + std::to_string(client_ports_[i]); }

std::vector<std::string> NatsCluster::urls() const {
  std::vector<std::string> out;
  for (int i = 0; i < size(); ++i) out.push_back(url(i));
  return out;
}

void NatsCluster::kill(int i) {
  if (pids_[i] <= 0) return;
  ::kill(pids_[i], SIGKILL);
  int status = 0;
  ::waitpid(pids_[i], &status, 0);
  pids_[i] = -1;
}

bool NatsCluster::restart(int i) {
  if (pids_[static_cast<size_t>(i)] > 0) return true;
  const std::string binary = server_binary();
  // Its config, store directory and log as before: it rejoins the cluster as the same server.
  const pid_t pid = spawn({binary, "-c", dir_ + "/" + name(i) + ".conf"}, dir_ + "/" + name(i) + ".log");
  if (pid < 0) return false;
  pids_[static_cast<size_t>(i)] = pid;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    natsConnection* nc = nullptr;
    bool ready = false;
    if (natsConnection_ConnectTo(&nc, url(i).c_str()) == NATS_OK) {
      natsMsg* reply = nullptr;
      if (natsConnection_RequestString(&reply, nc, "$JS.API.INFO", "", 500) == NATS_OK) {
        const std::string body(natsMsg_GetData(reply), static_cast<size_t>(natsMsg_GetDataLength(reply)));
        ready = body.find("\"memory\"") != std::string::npos && body.find("\"error\"") == std::string::npos;
        natsMsg_Destroy(reply);
      }
      natsConnection_Destroy(nc);
    }
    if (ready) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

std::string NatsCluster::log_tail(int i, int lines) const {
  std::ifstream in(dir_ + "/" + name(i) + ".log");
  std::deque<std::string> tail;
  for (std::string line; std::getline(in, line);) {
    tail.push_back(line);
    if (static_cast<int>(tail.size()) > lines) tail.pop_front();
  }
  std::string out;
  for (const auto& l : tail) out += l + "\n";
  return out;
}

}  // namespace kata::test
