#include "nats_agent.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <thread>

#include "transport/nats/connection.hpp"
#include "transport/nats/lease.hpp"
#include "transport/nats/partition.hpp"
#include "transport/nats/results.hpp"

namespace kata::test {

namespace {
std::atomic<bool> g_stop{false};
void on_term(int) { g_stop.store(true); }

int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void write_line(int fd, const std::string& line) {
  const std::string l = line + "\n";
  // One write per line on an O_APPEND descriptor: a kill -9 never leaves half a line.
  [[maybe_unused]] ssize_t n = ::write(fd, l.data(), l.size());
}
}  // namespace

std::vector<std::string> agent_argv(const AgentOptions& o) {
  std::string servers;
  for (const auto& s : o.servers) servers += (servers.empty() ? "" : ",") + s;
  return {std::filesystem::read_symlink("/proc/self/exe").string(), "--agent", servers, o.member, o.bucket, o.log_file,
          o.prefix, std::to_string(o.partitions), std::to_string(o.ttl_ms), std::to_string(o.renew_ms),
          std::to_string(o.guard_ms)};
}

uint64_t probe_stream(uint32_t partition, uint32_t partitions) {
  for (uint64_t id = 1;; ++id)
    if (transport::nats::partition_of(id, partitions) == partition) return id;
}

int run_agent(int argc, char** argv) {
  if (argc != 9) {
    std::fprintf(stderr, "agent: servers member bucket log prefix partitions ttl renew guard\n");
    return 2;
  }
  AgentOptions o;
  std::stringstream ss(argv[0]);
  for (std::string s; std::getline(ss, s, ',');) o.servers.push_back(s);
  o.member = argv[1];
  o.bucket = argv[2];
  o.log_file = argv[3];
  o.prefix = argv[4];
  o.partitions = static_cast<uint32_t>(std::stoul(argv[5]));
  o.ttl_ms = std::stoll(argv[6]);
  o.renew_ms = std::stoll(argv[7]);
  o.guard_ms = std::stoll(argv[8]);
  ::signal(SIGTERM, on_term);
  const int fd = ::open(o.log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (fd < 0) return 3;
  try {
    transport::nats::ConnectionOptions co;
    co.servers = o.servers;
    co.randomize = false;
    co.name = o.member;
    transport::nats::Connection connection(co);
    write_line(fd, "U " + connection.connected_url());
    transport::nats::LeaseOptions lo;
    lo.bucket = o.bucket;
    lo.member = o.member;
    lo.partitions = o.partitions;
    lo.ttl_ms = o.ttl_ms;
    lo.renew_ms = o.renew_ms;
    lo.guard_ms = o.guard_ms;
    // The connection's options for the witnesses (one connection pinned to each server), as kata serve's shard.
    transport::nats::LeaseManager leases(
        connection, lo,
        [fd](const transport::nats::LeaseEvent& e) {
          char line[160];
          std::snprintf(line, sizeof line, "E %s %u %llu %lld %lld", transport::nats::lease_event_name(e.kind), e.partition,
                        static_cast<unsigned long long>(e.epoch), static_cast<long long>(e.at_ns),
                        static_cast<long long>(e.valid_until_ns));
          write_line(fd, line);
        },
        &co);
    std::vector<uint64_t> streams(o.partitions);
    for (uint32_t p = 0; p < o.partitions; ++p) streams[p] = probe_stream(p, o.partitions);
    uint64_t reconnects = 0;
    char subject[256];
    while (!g_stop.load()) {
      for (uint32_t p = 0; p < o.partitions; ++p) {
        Probe probe{streams[p], steady_ns(), 0};
        uint64_t epoch = 0;
        if (!leases.may_publish(p, &epoch)) continue;
        probe.after_ns = steady_ns();
        if (transport::nats::format_result_subject(subject, sizeof subject, o.prefix, probe.stream_id, epoch, o.member))
          connection.publish(subject, &probe, sizeof probe);
      }
      if (connection.reconnects() != reconnects) {
        reconnects = connection.reconnects();
        write_line(fd, "R " + std::to_string(reconnects) + " " + connection.connected_url());
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    leases.stop(true);
    connection.flush(1000);
    write_line(fd, "S stopped");
  } catch (const std::exception& e) {
    write_line(fd, std::string("X ") + e.what());
    ::close(fd);
    return 1;
  }
  ::close(fd);
  return 0;
}

}  // namespace kata::test
