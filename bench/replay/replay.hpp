// kata-replay (`kata replay` forwards to it; a measurement tool of its own, built from bench/):
// K CMU clips replayed as K live streams at their recorded rate through the whole
// runtime (features + score + ghost + FlatBuffers + ZeroMQ PUB) to a subscriber in another
// process, and, in the same run, a bare ZeroMQ PUB/SUB sending messages of the same size with
// the same pacing (sleeping between ticks, not spinning). End-to-end latency = frame pushed ->
// message received, both ends on CLOCK_MONOTONIC (one host). Every phase is bounded in time.
// --ingest: the frames come from a sender process (`kata replay --sender`) over ZeroMQ through the
// runtime's Ingest instead of the in-process push; latency from the frame's send. Every run also
// prints the burst bound (bare p99 + streams x the push / workers, the push timed in this run).
//
// --soak: one long kata phase (no bare phase): the subscriber reports the latency per --window
// seconds, this process samples its resident memory every second; the run fails unless nothing
// was lost, the RSS after the first window stayed within 1 % (max - min over min) and the last
// windows' p50 and p99 are within --p50-growth (1.15) and --p99-growth (1.25) x the first windows'
// (medians over --judge-windows windows at each end; 0: reported, not judged).
//
// --transport nats --shards N: N `kata serve` shards over ZeroMQ (one host's
// deployment) and then over a NATS cluster this process starts on loopback (across hosts'), the
// same source and subscriber, then bare ZeroMQ: latency per hop (send -> arrival -> computed ->
// published -> received) and CPU per process, and what NATS adds at p50 / p99 (run_shard_processes).
//
// The subscriber is this executable again (`kata-replay --subscriber ENDPOINT --mode kata|bare`),
// spawned per phase; it prints "ready" once subscribed and one JSON line of latencies at the end.
//
// The tool's rooms: replay.cpp (the command, its runs and reports), phases.cpp (the kata and bare
// ZeroMQ phases in this process), shards.cpp (the phases through kata serve shards, over ZeroMQ
// and NATS), subscriber.cpp and sender.cpp (the child processes), processes.cpp (spawning them,
// the run's CURVE keys), measure.cpp (CPU, memory and percentiles).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/bvh.hpp"
#include "metric/metric.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/runtime.hpp"
#include "transport/curve.hpp"

namespace kata::replay {

using json = nlohmann::json;

struct Options {
  int streams = 64;
  double seconds = 30.0;
  double rate = 120.0;
  std::string transport = "tcp";
  std::string out;
  bool find_max = false;
  bool soak = false;
  double window = 60.0;  // soak: seconds per latency window
  double p99_growth = 1.25;  // soak: last windows' p99 <= this x the first's; 0: reported only
  double p50_growth = 1.15;  // soak: last windows' p50 <= this x the first's; 0: reported only
  double p50_slack_us = 0.0;  // soak: a p50 growth within this many us passes whatever its ratio
  int judge_windows = 1;     // soak: first / last figures are medians over this many windows
  double inject_growth_us_per_s = 0.0;  // internal (the judge's own test): added latency per second
  double p99_bound_us = 0.0;  // 0: only the 1.25 x bare ratio bounds --find-max
  int workers = 2;
  std::string idle = "park";  // the runtime's idle strategy: park | backoff
  std::string data_dir = "data/cmu";
  std::string model = "models/default.kata";
  std::string teacher = "02_01.bvh";
  // Subscriber mode (internal).
  std::string subscriber;
  std::string mode = "kata";
  double deadline = 60.0;
  int expect_definitions = 1;   // subscriber: "ready" once this many streams' definitions came
  int64_t expect_results = 0;   // subscriber: sample vectors reserved for this many (no reallocation mid-run)
  bool capture_is_send = false; // subscriber: capture_ns is the source's send time (shards mode)
  int shards = 0;               // > 0: the kata phase runs through kata proxy + this many kata serve
  bool ingest = false;          // the frames come from a sender process over ZeroMQ through Ingest
  bool batch = false;           // --ingest: the sender sends each tick's frames as frame batches
  int result_batch = 8;         // RuntimeConfig::result_batch
  int drain_burst = 1;         // RuntimeConfig::drain_burst
  std::string sender;           // internal: the sender process (PUSH to this endpoint)
  int nats_servers = 3;         // --transport nats: servers in the cluster (1: no route hop, R1 leases)
  bool curve = false;           // CURVE on every socket of both phases
};


struct Clips {
  std::vector<kata::BvhClip> clips;
  std::vector<std::vector<float>> positions;
  std::shared_ptr<const kata::pipeline::Teacher> teacher;
  std::shared_ptr<const kata::metric::Metric> metric;
  // Stream s's frame at tick t (its clip is s mod the clips, offset by s so streams differ):
  // joint positions, and *joints their count.
  const float* frame(int s, int64_t t, int* joints) const {
    const size_t clip = static_cast<size_t>(s) % clips.size();
    *joints = clips[clip].skeleton.joint_count();
    const size_t per_frame = 3 * static_cast<size_t>(*joints);
    const int64_t frames = static_cast<int64_t>(positions[clip].size() / per_frame);
    return positions[clip].data() + static_cast<size_t>((t + s) % frames) * per_frame;
  }
};


// ---- measure.cpp: CPU, memory, percentiles ----------------------------------------------------

int64_t now_ns();
double cpu_seconds();       // this process, user + system
double thread_cpu_us();     // the calling thread
double resident_mib();      // this process's resident set
double process_cpu_seconds(pid_t pid);  // another process's user + system; 0 when it is gone
// CPU time of every thread of this process by the thread's name, with its wake-ups.
struct ThreadUse {
  double ns = 0.0;
  double sleeps = 0.0;
  double preempted = 0.0;  // involuntary context switches: the CPU taken away while it ran
};
std::map<std::string, ThreadUse> thread_cpu_ns();
double quantile_of_sorted(const std::vector<int64_t>& sorted, double q);
double percentile(const std::vector<int64_t>& v, double q);
json summary(const std::vector<int64_t>& ns);

// ---- processes.cpp: the child processes and the run's CURVE keys -------------------------------

struct CurveKeys {
  kata::transport::KeyPair server, client;
};
const CurveKeys& curve_keys();
kata::transport::CurveOptions curve_server();
void curve_client(void* socket);

struct Child {
  pid_t pid = -1;
  FILE* out = nullptr;
};
Child spawn_subscriber(const std::string& endpoint, const std::string& mode, double deadline, int64_t expect_results,
                       double window = 0.0, int expect_definitions = 1, bool capture_is_send = false,
                       double inject_growth_us_per_s = 0.0, int nats_shards = 0);
std::string read_line(FILE* f);
json finish_child(Child& c);
std::string endpoint_for(const Options& o, const char* tag);
// The sender process, with a pipe to its stdin ("go") and one from its stdout.
struct SenderChild {
  pid_t pid = -1;
  FILE* in = nullptr;
  FILE* out = nullptr;
};
SenderChild spawn_sender(const Options& o, const std::string& endpoint, int streams);
pid_t spawn_logged(const std::vector<std::string>& args, const std::string& log);
std::string absolute(const std::string& p);

// ---- the child processes ----------------------------------------------------------------------

int run_subscriber(const Options& o);  // subscriber.cpp
int run_sender(const Options& o);      // sender.cpp

// ---- phases.cpp: the phases in this process ----------------------------------------------------

Clips load_clips(const Options& o);
kata::runtime::StreamSetup setup_for(const Clips& c, size_t clip);
// The pipeline's own cost in this run: a hot push loop (as BM_PipelinePush: one stream with the
// teacher, results read in blocks) timed by this thread's CPU clock, the median of 7 blocks of
// 300 frames after 300 warm-up frames (us per frame).
double measure_push_us(const Clips& c);
json run_kata(const Options& o, const Clips& c, int streams, double* message_bytes);
json run_bare(const Options& o, int streams, size_t message_bytes);

// ---- shards.cpp: through kata serve shards -----------------------------------------------------

json run_sharded(const Options& o, const Clips& c, int streams, double* message_bytes);
#ifdef KATA_HAVE_NATS
json run_shard_processes(const Options& o, const Clips& c, int streams, bool over_nats);
json run_nats_comparison(const Options& o, const Clips& c, int streams);
void print_nats_comparison(const json& r);
#endif

// Sleeps to each tick (absolute deadlines: no drift) and calls send(tick) for every tick.
template <typename Send>
void paced(const Options& o, int64_t ticks, Send send) {
  const auto start = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(1.0 / o.rate);
  for (int64_t t = 0; t < ticks; ++t) {
    std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period * t));
    send(t);
  }
}


}  // namespace kata::replay
