// kata-replay: the kata phase through kata serve shards (kata proxy in front and behind, or a NATS
// cluster started here on loopback).
#include "replay.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zmq.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/error.hpp"
#include "transport/wire.hpp"

#ifdef KATA_HAVE_NATS
#include <nats/nats.h>

#include "nats_cluster.hpp"
#include "transport/nats/connection.hpp"
#include "transport/nats/partition.hpp"
#include "transport/nats/results.hpp"
#endif

namespace kata::replay {

// ---- the kata phase through shards: source -> kata proxy -> N x kata serve -> kata proxy -> subscriber


json run_sharded(const Options& o, const Clips& c, int streams, double* message_bytes) {
  static int run = 0;
  const std::string dir = "/tmp/kata_replay_" + std::to_string(getpid()) + "_" + std::to_string(run++);
  std::filesystem::create_directories(dir);
  auto ep = [&](const char* name) { return "ipc://" + dir + "/" + name; };
  std::vector<pid_t> proxies, shards;
  const std::string limit = std::to_string(static_cast<int>(o.seconds + 120));
  proxies.push_back(spawn_logged({"kata", "proxy", "--frontend", ep("fin"), "--backend", ep("fout"), "--status-interval",
                                  "0", "--seconds", limit, "--hwm", "1000000"},
                                 dir + "/frames_proxy.log"));
  proxies.push_back(spawn_logged({"kata", "proxy", "--frontend", ep("rin"), "--backend", ep("rout"), "--status-interval",
                                  "0", "--seconds", limit, "--hwm", "1000000"},
                                 dir + "/results_proxy.log"));
  for (int k = 0; k < o.shards; ++k) {
    const std::string config = dir + "/shard" + std::to_string(k) + ".toml";
    std::ofstream f(config);
    f << "[ingest]\nendpoints = [\"" << ep("fout") << "\"]\nkind = \"sub\"\n"
      << "[publish]\nendpoints = [\"connect:" << ep("rin") << "\"]\nsend_hwm = 1000000\n"
      << "[shard]\ncount = " << o.shards << "\nindex = " << k << "\n"
      << "[runtime]\nworkers = " << o.workers << "\nmax_streams = " << std::max(streams, 1) << "\n"
      << "[scoring]\nmodel = \"" << absolute(o.model) << "\"\nteacher = \"" << absolute(o.data_dir + "/" + o.teacher)
      << "\"\nfirst_frame = 1\nghost = true\n[status]\ninterval_seconds = 3600\n";
    f.close();
    shards.push_back(spawn_logged({"kata", "serve", "--config", config}, dir + "/shard" + std::to_string(k) + ".log"));
  }
  void* context = zmq_ctx_new();
  void* pub = zmq_socket(context, ZMQ_PUB);
  int hwm = 1000000, linger = 0;
  zmq_setsockopt(pub, ZMQ_SNDHWM, &hwm, sizeof hwm);
  zmq_setsockopt(pub, ZMQ_LINGER, &linger, sizeof linger);
  if (zmq_connect(pub, ep("fin").c_str()) != 0) throw Error(ErrorKind::kIo, "replay: cannot connect the source");
  kata::transport::Encoder encoder;
  auto send_definitions = [&] {
    for (int s = 0; s < streams; ++s) {
      kata::transport::SkeletonDefinition d;
      d.stream_id = static_cast<uint64_t>(s);
      d.revision = 1;
      d.skeleton = c.clips[static_cast<size_t>(s) % c.clips.size()].skeleton;
      d.layout = "cmu";
      d.frame_rate = static_cast<float>(o.rate);
      const auto m = encoder.skeleton(d);
      zmq_send(pub, m.data, m.size, ZMQ_DONTWAIT);
    }
  };
  // Definitions until every stream is open on its shard and announced to the subscriber (each
  // shard loads the model and teacher first; bounded by the subscriber's own deadline).
  Child child = spawn_subscriber(ep("rout"), "kata", o.seconds + 60.0, static_cast<int64_t>(o.seconds * o.rate) * streams,
                                 0.0, streams, true);
  std::atomic<bool> ready{false};
  std::thread announcer([&] {
    while (!ready.load()) {
      send_definitions();
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  });
  const std::string line = read_line(child.out);
  ready.store(true);
  announcer.join();
  if (line != "ready") throw Error(ErrorKind::kIo, "replay: the shards never announced every stream (logs in " + dir + ")");
  const int64_t ticks = static_cast<int64_t>(o.seconds * o.rate);
  uint64_t sent = 0;
  const double cpu0 = cpu_seconds();
  const auto wall0 = std::chrono::steady_clock::now();
  paced(o, ticks, [&](int64_t t) {
    for (int s = 0; s < streams; ++s) {
      int joints = 0;
      const float* xyz = c.frame(s, t, &joints);
      const auto m = encoder.frame(static_cast<uint64_t>(s), static_cast<uint64_t>(t), now_ns(), xyz, joints);
      if (zmq_send(pub, m.data, m.size, ZMQ_DONTWAIT) >= 0) ++sent;
    }
  });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = cpu_seconds() - cpu0;
  json j = finish_child(child);
  for (pid_t p : shards) kill(p, SIGINT);
  for (pid_t p : proxies) kill(p, SIGTERM);
  // CPU seconds of each process over its whole life (start-up included: model and teacher loads).
  auto reap = [](pid_t p) {
    rusage u{};
    int status = 0;
    wait4(p, &status, 0, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  double shard_cpu = 0.0, proxy_cpu[2] = {0.0, 0.0};
  for (pid_t p : shards) shard_cpu += reap(p);
  for (size_t i = 0; i < proxies.size(); ++i) proxy_cpu[i] = reap(proxies[i]);
  zmq_close(pub);
  zmq_ctx_term(context);
  std::filesystem::remove_all(dir);
  j["sent"] = static_cast<uint64_t>(ticks) * static_cast<uint64_t>(streams);
  j["lost"] = static_cast<int64_t>(j["sent"].get<uint64_t>()) - j["received"].get<int64_t>();
  j["runtime_drops"] = 0;  // counted inside the shards (their logs); lost covers every hop
  j["source_cpu_percent_of_one_core"] = 100.0 * cpu / wall;
  j["shards"] = o.shards;
  j["cpu_seconds"] = {{"shards_total", shard_cpu}, {"frames_proxy", proxy_cpu[0]}, {"results_proxy", proxy_cpu[1]}};
  j["wall_seconds_sending"] = wall;
  (void)sent;
  *message_bytes = j["mean_message_bytes"].get<double>();
  return j;
}


// ---- --transport nats --shards N: the same N kata serve shards over ZeroMQ and over NATS --------
//
// Both phases: a source in this process sends every stream's frames paced at --rate, each stamped
// with its send time (capture_ns, CLOCK_MONOTONIC); N `kata serve` processes score them (the same
// config but for the transport); one subscriber process receives every result. ZeroMQ, one host's
// deployment: stream s goes to shard s mod N over its own PUSH -> PULL (tcp loopback), each shard
// publishes on its own PUB, the subscriber connects to all N. NATS, across hosts' deployment: a
// 3-server cluster started here on loopback (nats_cluster.hpp, JetStream in memory, the partition
// mapping; --nats-servers), the source publishes on n0, shard k connects to server k mod 3, the
// subscriber to n1;
// shards own partitions by lease. CPU per process is read from /proc over the paced seconds only
// (model and teacher loads, the cluster's start and the lease settling excluded).
#ifdef KATA_HAVE_NATS


json run_shard_processes(const Options& o, const Clips& c, int streams, bool over_nats) {
  static int run = 0;
  const std::string dir = "/tmp/kata_replay_" + std::to_string(getpid()) + "_" + (over_nats ? "nats" : "zmq") + "_" +
                          std::to_string(run++);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  namespace kn = kata::transport::nats;
  std::unique_ptr<kata::test::NatsCluster> cluster;
  if (over_nats) {
    cluster = std::make_unique<kata::test::NatsCluster>(dir, o.nats_servers);
    if (!cluster->problem().empty()) throw Error(ErrorKind::kIo, "replay: the NATS cluster: " + cluster->problem());
  }
  std::vector<pid_t> shards;
  std::vector<std::string> ingest_endpoints, result_endpoints;
  // Every child is stopped and reaped however this function ends (a throw included).
  struct Reaper {
    std::vector<pid_t>* pids;
    ~Reaper() {
      for (pid_t p : *pids) kill(p, SIGINT);
      for (pid_t p : *pids) waitpid(p, nullptr, 0);
    }
  } reaper{&shards};
  for (int k = 0; k < o.shards; ++k) {
    const std::string config = dir + "/shard" + std::to_string(k) + ".toml";
    std::ofstream f(config);
    if (over_nats) {
      f << "[transport]\nkind = \"nats\"\nservers = [\"" << cluster->url(k % cluster->size()) << "\"]\nshard = \"replay-"
        << k << "\"\nlease_replicas = " << std::min(3, o.nats_servers) << "\n[ingest]\n";
    } else {
      ingest_endpoints.push_back("tcp://127.0.0.1:" + std::to_string(kata::test::free_port()));
      result_endpoints.push_back("tcp://127.0.0.1:" + std::to_string(kata::test::free_port()));
      f << "[ingest]\nendpoints = [\"bind:" << ingest_endpoints.back() << "\"]\nkind = \"pull\"\n";
    }
    // One sender reaches each shard's ingest (the source's PUSH, or the NATS bridge): all its streams.
    f << "max_streams_per_sender = " << std::max(streams, 64) << "\n";
    if (!over_nats) f << "[publish]\nendpoints = [\"" << result_endpoints.back() << "\"]\nsend_hwm = 1000000\n";
    f << "[runtime]\nworkers = " << o.workers << "\nmax_streams = " << std::max(streams, 1) << "\n"
      << "[scoring]\nmodel = \"" << absolute(o.model) << "\"\nteacher = \"" << absolute(o.data_dir + "/" + o.teacher)
      << "\"\nfirst_frame = 1\nghost = true\n[status]\ninterval_seconds = 3600\n";
    f.close();
    shards.push_back(spawn_logged({"kata", "serve", "--config", config}, dir + "/shard" + std::to_string(k) + ".log"));
  }
  kata::transport::Encoder encoder;
  void* context = nullptr;
  std::vector<void*> pushes;  // ZeroMQ: one per shard
  std::unique_ptr<kn::Connection> source;
  std::string subject = "kata.in.";
  const size_t head = subject.size();
  if (over_nats) {
    kn::ConnectionOptions co;
    co.servers = {cluster->url(0)};
    co.name = "kata-replay-source";
    source = std::make_unique<kn::Connection>(co);
  }
  if (!over_nats) {
    context = zmq_ctx_new();
    for (const auto& endpoint : ingest_endpoints) {
      void* push = zmq_socket(context, ZMQ_PUSH);
      int hwm = 1000000, linger = 0;
      zmq_setsockopt(push, ZMQ_SNDHWM, &hwm, sizeof hwm);
      zmq_setsockopt(push, ZMQ_LINGER, &linger, sizeof linger);
      if (zmq_connect(push, endpoint.c_str()) != 0) throw Error(ErrorKind::kIo, "replay: cannot connect " + endpoint);
      pushes.push_back(push);
    }
  }
  uint64_t refused = 0;
  auto send = [&](uint64_t stream, const kata::transport::Bytes& m) {
    if (over_nats) {
      subject.replace(head, std::string::npos, reinterpret_cast<const char*>(m.data), kata::transport::kTopicBytes);
      refused += !source->publish(subject, m.data, m.size);
      return;
    }
    refused += zmq_send(pushes[stream % pushes.size()], m.data, m.size, ZMQ_DONTWAIT) < 0;
  };
  auto send_definitions = [&] {
    for (int s = 0; s < streams; ++s) {
      kata::transport::SkeletonDefinition d;
      d.stream_id = static_cast<uint64_t>(s);
      d.revision = 1;
      d.skeleton = c.clips[static_cast<size_t>(s) % c.clips.size()].skeleton;
      d.layout = "cmu";
      d.frame_rate = static_cast<float>(o.rate);
      send(d.stream_id, encoder.skeleton(d));
    }
  };
  std::string subscriber_endpoint;
  if (over_nats) subscriber_endpoint = cluster->url(1 % cluster->size());
  for (const auto& e : result_endpoints) subscriber_endpoint += (subscriber_endpoint.empty() ? "" : ",") + e;
  // Definitions until every stream is open on the shard that keeps it and announced to the
  // subscriber (each shard loads the model and teacher first; on NATS the shards share the
  // partitions out meanwhile; bounded by the subscriber's own deadline).
  Child child = spawn_subscriber(subscriber_endpoint, "kata", o.seconds + 60.0,
                                 static_cast<int64_t>(o.seconds * o.rate) * streams, 0.0, streams, true, 0.0,
                                 over_nats ? o.shards : 0);
  std::string line;
  {
    std::atomic<bool> ready{false};
    std::thread announcer([&] {
      while (!ready.load()) {
        send_definitions();
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
    });
    line = read_line(child.out);
    ready.store(true);
    announcer.join();
  }
  if (line != "ready") throw Error(ErrorKind::kIo, "replay: the shards never announced every stream (logs in " + dir + ")");
  std::vector<pid_t> servers;
  for (int i = 0; cluster && i < cluster->size(); ++i) servers.push_back(cluster->pid(i));
  auto cpu_of = [](const std::vector<pid_t>& pids) {
    std::vector<double> v;
    for (pid_t p : pids) v.push_back(process_cpu_seconds(p));
    return v;
  };
  const std::vector<double> shard_cpu0 = cpu_of(shards), server_cpu0 = cpu_of(servers);
  // Where each server's log stood when the measured seconds began (their warnings are read from here).
  std::vector<uintmax_t> log_offsets;
  for (size_t i = 0; i < servers.size(); ++i) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(dir + "/" + kata::test::NatsCluster::name(static_cast<int>(i)) + ".log", ec);
    log_offsets.push_back(ec ? 0 : size);
  }
  const int64_t ticks = static_cast<int64_t>(o.seconds * o.rate);
  std::vector<int64_t> last_stamp(static_cast<size_t>(streams), 0);
  const double cpu0 = cpu_seconds();
  const auto wall0 = std::chrono::steady_clock::now();
  paced(o, ticks, [&](int64_t t) {
    for (int s = 0; s < streams; ++s) {
      int joints = 0;
      const float* xyz = c.frame(s, t, &joints);
      // As run_sender: never closer than 20 us to the stream's previous frame (the pacer catching
      // up after a stall would stamp a stream's frames microseconds apart, which the pipeline
      // refuses, kMinTimeStep). The clamp acts only then. (A 240 Hz run without it lost 25 frames
      // in its ZeroMQ phase, none refused by the source; this is the likely cause, not a proven one.)
      const int64_t stamp = std::max(now_ns(), last_stamp[static_cast<size_t>(s)] + 20'000);
      last_stamp[static_cast<size_t>(s)] = stamp;
      send(static_cast<uint64_t>(s), encoder.frame(static_cast<uint64_t>(s), static_cast<uint64_t>(t), stamp, xyz, joints));
    }
  });
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = cpu_seconds() - cpu0;
  const std::vector<double> shard_cpu1 = cpu_of(shards), server_cpu1 = cpu_of(servers);
  json j = finish_child(child);
  const uint64_t sent = static_cast<uint64_t>(ticks) * static_cast<uint64_t>(streams);
  // The servers' warnings and errors from the measured seconds until the subscriber's end (slow
  // consumers, long read loops, raft elections; not the start-up's or the shutdown's route
  // noise): what a stall in the figures may come from.
  if (over_nats) {
    json warnings = json::array();
    for (size_t i = 0; i < log_offsets.size(); ++i) {
      std::ifstream log(dir + "/" + kata::test::NatsCluster::name(static_cast<int>(i)) + ".log");
      log.seekg(static_cast<std::streamoff>(log_offsets[i]));
      for (std::string entry; std::getline(log, entry);)
        if ((entry.find("[WRN]") != std::string::npos || entry.find("[ERR]") != std::string::npos) && warnings.size() < 20)
          warnings.push_back(kata::test::NatsCluster::name(static_cast<int>(i)) + ": " + entry);
    }
    j["nats_server_warnings"] = warnings;
  }

  j["sent"] = sent;
  j["refused_by_the_source"] = refused;
  j["lost"] = static_cast<int64_t>(sent) - j["received"].get<int64_t>();
  j["runtime_drops"] = 0;  // counted inside the shards (their logs); lost covers every hop
  // Streams that got no result, or not every frame's (one each, none twice).
  int short_streams = 0;
  for (int s = 0; s < streams; ++s) {
    const std::string key = std::to_string(s);
    const uint64_t got = j.contains("received_by_stream") && j["received_by_stream"].contains(key)
                             ? j["received_by_stream"][key].get<uint64_t>() : 0;
    short_streams += got != static_cast<uint64_t>(ticks);
  }
  j["streams_not_complete"] = short_streams;
  j["shards"] = o.shards;
  j["wall_seconds_sending"] = wall;
  json per_process = json::object();
  per_process["source (this process)"] = 100.0 * cpu / wall;
  for (size_t k = 0; k < shards.size(); ++k)
    per_process["kata serve " + std::to_string(k)] = 100.0 * (shard_cpu1[k] - shard_cpu0[k]) / wall;
  for (size_t i = 0; i < servers.size(); ++i)
    per_process["nats-server n" + std::to_string(i)] = 100.0 * (server_cpu1[i] - server_cpu0[i]) / wall;
  j["cpu_percent_of_one_core_by_process"] = per_process;
  j["path"] = over_nats ? "source -> NATS n0 -> (route) -> N kata serve on n<k mod servers> (partition leases) -> NATS -> "
                          "subscriber on n1 (" + std::to_string(o.nats_servers) + " servers)"
                        : "source -> N x (PUSH -> kata serve PULL ingest -> PUB) -> one SUB on all N (tcp loopback)";
  for (void* p : pushes) zmq_close(p);
  if (context != nullptr) zmq_ctx_term(context);
  // The shards stop (Reaper) before the cluster goes: a shard gives its leases back on SIGINT.
  for (pid_t p : shards) kill(p, SIGINT);
  for (pid_t p : shards) waitpid(p, nullptr, 0);
  shards.clear();
  source.reset();
  cluster.reset();
  // A run that lost results keeps the shards' and servers' logs (their counters by cause).
  if (j["lost"].get<int64_t>() != 0 || short_streams != 0)
    j["logs"] = dir;
  else
    std::filesystem::remove_all(dir);
  return j;
}

// --transport nats: ZeroMQ's shards, NATS's shards, bare ZeroMQ, in that order in one run.
json run_nats_comparison(const Options& o, const Clips& c, int streams) {
  json j;
  j["streams"] = streams;
  j["rate_hz"] = o.rate;
  j["seconds"] = o.seconds;
  j["shards"] = o.shards;
  j["workers"] = o.workers;
  j["nats_servers"] = o.nats_servers;
  j["zmq"] = run_shard_processes(o, c, streams, false);
  j["nats"] = run_shard_processes(o, c, streams, true);
  j["bare_zmq"] = run_bare(o, streams, static_cast<size_t>(j["nats"]["mean_message_bytes"].get<double>() + 0.5));
  json added = json::object();
  for (const char* q : {"p50_us", "p99_us"}) added[q] = j["nats"]["latency"][q].get<double>() - j["zmq"]["latency"][q].get<double>();
  j["nats_added_us"] = added;
  json hops = json::object();
  for (const auto& [stage, v] : j["nats"]["stages"].items())
    for (const char* q : {"p50_us", "p99_us"})
      hops[stage][q] = v[q].get<double>() - j["zmq"]["stages"][stage][q].get<double>();
  j["nats_added_by_hop_us"] = hops;
  j["nats_added_p50_target_us"] = 300.0;
  j["nats_added_p50_met"] = added["p50_us"].get<double>() <= 300.0;
  return j;
}

void print_nats_comparison(const json& r) {
  std::printf("%d streams x %.0f Hz for %.0f s, %d kata serve shards x %d workers | p50 / p99 / max (us), send -> received\n",
              r["streams"].get<int>(), r["rate_hz"].get<double>(), r["seconds"].get<double>(), r["shards"].get<int>(),
              r["workers"].get<int>());
  for (const char* path : {"zmq", "nats"}) {
    const json& k = r[path];
    const json& st = k["stages"];
    auto pq = [&](const json& v) {
      char b[64];
      std::snprintf(b, sizeof b, "%.0f / %.0f", v["p50_us"].get<double>(), v["p99_us"].get<double>());
      return std::string(b);
    };
    std::printf("  %-4s  total %.0f / %.0f / %.0f | lost %lld, streams incomplete %d | hops: send->arrival %s, "
                "arrival->computed %s, computed->published %s, published->received %s\n",
                path, k["latency"]["p50_us"].get<double>(), k["latency"]["p99_us"].get<double>(),
                k["latency"]["max_us"].get<double>(), static_cast<long long>(k["lost"].get<int64_t>()),
                k["streams_not_complete"].get<int>(), pq(st["source_to_arrival"]).c_str(),
                pq(st["arrival_to_computed"]).c_str(), pq(st["computed_to_published"]).c_str(),
                pq(st["published_to_received"]).c_str());
    std::string cpu;
    for (const auto& [name, v] : k["cpu_percent_of_one_core_by_process"].items()) {
      char b[96];
      std::snprintf(b, sizeof b, "%s%s %.1f", cpu.empty() ? "" : ", ", name.c_str(), v.get<double>());
      cpu += b;
    }
    std::printf("        CPU %% of one core: %s; subscriber %.2f CPU s\n", cpu.c_str(),
                k["subscriber_cpu_seconds"].get<double>());
    if (k.contains("nats_server_warnings"))
      for (const auto& w : k["nats_server_warnings"]) std::printf("        %s\n", w.get<std::string>().c_str());
  }
  std::printf("  bare ZeroMQ (one hop, same sizes and pacing): %.0f / %.0f us\n",
              r["bare_zmq"]["latency"]["p50_us"].get<double>(), r["bare_zmq"]["latency"]["p99_us"].get<double>());
  const json& h = r["nats_added_by_hop_us"];
  std::printf("  NATS added: p50 %+.0f us, p99 %+.0f us (target p50 <= 300 us: %s); by hop p50 / p99: send->arrival %+.0f / %+.0f, "
              "published->received %+.0f / %+.0f\n",
              r["nats_added_us"]["p50_us"].get<double>(), r["nats_added_us"]["p99_us"].get<double>(),
              r["nats_added_p50_met"].get<bool>() ? "met" : "MISSED", h["source_to_arrival"]["p50_us"].get<double>(),
              h["source_to_arrival"]["p99_us"].get<double>(), h["published_to_received"]["p50_us"].get<double>(),
              h["published_to_received"]["p99_us"].get<double>());
  std::fflush(stdout);
}
#endif  // KATA_HAVE_NATS

}  // namespace kata::replay
