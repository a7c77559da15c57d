// A NATS cluster for one process: `servers` nats-server processes (Debian's nats-server)
// on loopback, each with its own free ports, JetStream in memory, full-mesh routes, and the
// partition subject mapping of kata's NATS transport (partition.hpp) in every server's config, as
// docs/deploy.md deploys it. Started by the constructor (it returns once JetStream answers),
// stopped by the destructor; kill() stops one server with SIGKILL.
//
// Shared by the NATS tests (tests/transport/nats) and kata-replay's `--transport nats` (which
// starts its own cluster on loopback): the library kata_nats_cluster (bench/replay/CMakeLists.txt),
// here because kata-replay is built with or without the tests.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace kata::test {

class NatsCluster {
 public:
  // dir: an empty directory of the caller's own (configs, logs, JetStream store directories).
  // problem() says why not when nats-server is missing or a server did not come up.
  NatsCluster(const std::string& dir, int servers = 3, uint32_t partitions = 64, const std::string& prefix = "kata");
  ~NatsCluster();
  NatsCluster(const NatsCluster&) = delete;
  NatsCluster& operator=(const NatsCluster&) = delete;

  // Empty when every server runs and JetStream answers; else why not (with the servers' log tails).
  const std::string& problem() const { return problem_; }
  int size() const { return static_cast<int>(pids_.size()); }
  // nats://127.0.0.1:PORT of server i, and of all servers.
  std::string url(int i) const;
  std::vector<std::string> urls() const;
  // Server i's name (n0, n1, ...), as JetStream reports stream leaders.
  static std::string name(int i) { return "n" + std::to_string(i); }
  // Server i's process id (-1 once killed), e.g. to read its CPU time from /proc.
  pid_t pid(int i) const { return pids_[static_cast<size_t>(i)]; }
  // SIGKILL server i and reap it.
  void kill(int i);
  // Starts server i again after kill(i), with its config and store directory: it rejoins the
  // cluster as the same server. Returns once JetStream answers through it (false: not in 20 s).
  bool restart(int i);
  // The last lines of server i's log (for failure messages).
  std::string log_tail(int i, int lines = 20) const;

  // The path of nats-server ("" when not found on PATH, /usr/sbin or /usr/local/sbin).
  static std::string server_binary();

 private:
  // One try at starting the servers; false with problem_ set (port_taken_ when a port was taken).
  bool start(const std::string& binary, int servers, uint32_t partitions, const std::string& prefix);
  void stop();  // SIGTERM every server (SIGKILL after 2 s) and reap it

  std::string dir_;
  bool port_taken_ = false;
  std::vector<pid_t> pids_;
  std::vector<int> client_ports_;
  std::string problem_;
};

// A free TCP port on 127.0.0.1 below the ephemeral range (bound and released: another listener
// could take it meanwhile; NatsCluster starts again on other ports when that happens).
int free_port();

// A child process started with execv (argv[0] the program); -1 when it could not start.
pid_t spawn(const std::vector<std::string>& argv, const std::string& log_file);

}  // namespace kata::test
