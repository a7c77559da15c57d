// A lease-holding shard in a process of its own, for the tests that kill one (kill -9): the test
// executable run as `test_nats --agent ...` (test_nats.cpp's main). It holds partitions through a
// LeaseManager, writes every lease event to a log file (one line each, written before the lease
// thread acts on it), and for every partition it may publish for, publishes a probe result every
// 50 ms on the stream chosen for that partition (probe_stream), stamped with the steady clock just
// before and after may_publish() said yes. SIGTERM: it gives its partitions back and exits 0.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace kata::test {

struct AgentOptions {
  std::vector<std::string> servers;  // tried in this order
  std::string member, bucket, log_file, prefix = "kata";
  uint32_t partitions = 64;
  int64_t ttl_ms = 3000, renew_ms = 500, guard_ms = 750;  // kata serve's (ttl / 6, ttl / 4)
};

// argv for running the agent from the test executable (argv[0] = /proc/self/exe's target).
std::vector<std::string> agent_argv(const AgentOptions& options);
// Runs the agent (argv after "--agent"); returns the exit code.
int run_agent(int argc, char** argv);

// The probe stream of a partition: the smallest id >= 1 that the servers' mapping puts there.
uint64_t probe_stream(uint32_t partition, uint32_t partitions);

// What a probe result carries (little-endian host layout; one host).
struct Probe {
  uint64_t stream_id;
  int64_t before_ns, after_ns;  // steady clock around may_publish() == true
};

}  // namespace kata::test
