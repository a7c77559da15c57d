// kata-replay --subscriber: the process that receives every result (or bare message) and reports
// latencies as one JSON line.
#include "replay.hpp"

#include <zmq.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstring>
#include <set>

#include "common/error.hpp"
#include "transport/wire.hpp"

#ifdef KATA_HAVE_NATS
#include <nats/nats.h>

#include "transport/nats/connection.hpp"
#include "transport/nats/partition.hpp"
#include "transport/nats/results.hpp"
#endif

namespace kata::replay {

// ---- the subscriber process -------------------------------------------------------------------

int run_subscriber(const Options& o) {
  // ZeroMQ: one SUB socket connected to every endpoint of the comma-separated list (one per shard
  // when the shards publish themselves). NATS (an endpoint nats://...): the results' subjects.
  const bool over_nats = o.subscriber.rfind("nats://", 0) == 0;
  void* context = nullptr;
  void* sub = nullptr;
  if (!over_nats) {
    context = zmq_ctx_new();
    sub = zmq_socket(context, ZMQ_SUB);
    int hwm = 1 << 20;  // the subscriber keeps up or is measured as late; it never drops on purpose
    zmq_setsockopt(sub, ZMQ_RCVHWM, &hwm, sizeof hwm);
    zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "", 0);
    curve_client(sub);
    std::stringstream list(o.subscriber);
    for (std::string endpoint; std::getline(list, endpoint, ',');)
      if (zmq_connect(sub, endpoint.c_str()) != 0) {
        std::fprintf(stderr, "subscriber: cannot connect %s: %s\n", endpoint.c_str(), zmq_strerror(zmq_errno()));
        return 1;
      }
  }
  const bool kata_mode = o.mode == "kata";
  if (!kata_mode) std::printf("ready\n"), std::fflush(stdout);  // the bare publisher sees the join itself
  kata::transport::Decoder decoder(1 << 22, false);
  std::vector<uint8_t> buffer(1 << 22);
  std::vector<int64_t> total, queue_compute, publish, transport, received_at, source_to_arrival;
  std::set<uint64_t> defined;
  // Reserved up front: a vector doubling mid-run copies every sample so far inside the measured loop.
  const size_t reserve = static_cast<size_t>(std::max<int64_t>(o.expect_results + 4096, 1 << 16));
  for (auto* v : {&total, &queue_compute, &publish, &transport, &received_at}) v->reserve(reserve);
  if (o.capture_is_send) source_to_arrival.reserve(reserve);
  int64_t first_received = 0;
  std::map<uint64_t, uint64_t> received_by_stream;  // for the per-stream accounting (a node per stream, once)
  bool ready = !kata_mode;
  uint64_t received = 0, bytes = 0;
  const double cpu0 = cpu_seconds();
  const auto hard_deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(o.deadline);
  auto last_message = std::chrono::steady_clock::now();
  bool any = false;
  // One message received at t (steady clock, taken before any decoding: every path times the
  // same thing). defined_here: false for a definition that does not count towards "ready" (NATS:
  // not yet from the shard that will hold the stream's partition once the shards have settled).
  auto on_message = [&](const uint8_t* data, size_t n, int64_t t, bool defined_here) {
    if (!kata_mode) {
      if (n < 24) return;
      last_message = std::chrono::steady_clock::now();
      int64_t sent;
      std::memcpy(&sent, data + 16, 8);
      total.push_back(t - sent);
      ++received;
      bytes += static_cast<uint64_t>(n);
      any = true;
      return;
    }
    const auto kind = decoder.decode(data, n);
    if (kind == kata::transport::MessageKind::kSkeleton && !ready && defined_here) {
      defined.insert(decoder.stream_id());
      if (static_cast<int>(defined.size()) >= o.expect_definitions) {
        ready = true;
        std::printf("ready\n");
        std::fflush(stdout);
      }
    }
    if (kind != kata::transport::MessageKind::kResult) return;
    // Only results count as traffic: shards that publish themselves (--transport nats's ZeroMQ
    // phase) re-send their streams' definitions every second until they are stopped.
    last_message = std::chrono::steady_clock::now();
    const auto& r = decoder.result();
    if (first_received == 0) first_received = t;
    // The soak judge's own test: a latency that grows by this much per second of the run.
    const int64_t injected = static_cast<int64_t>(o.inject_growth_us_per_s * 1e-6 * static_cast<double>(t - first_received));
    // Shards: from the source's send (capture_ns, same clock) to here, the proxies included.
    const int64_t capture_ns = std::llround(r.capture_time * 1e9);
    total.push_back(t - (o.capture_is_send ? capture_ns : r.arrival_ns) + injected);
    if (o.capture_is_send) source_to_arrival.push_back(r.arrival_ns - capture_ns);
    if (o.window > 0) received_at.push_back(t);
    queue_compute.push_back(r.computed_ns - r.arrival_ns);
    publish.push_back(r.published_ns - r.computed_ns);
    transport.push_back(t - r.published_ns);
    ++received_by_stream[r.stream_id];
    ++received;
    bytes += static_cast<uint64_t>(n);
    any = true;
  };
  // Done after 1.5 s without a result once results flowed (the publisher has finished).
  auto finished = [&] {
    const auto now = std::chrono::steady_clock::now();
    return now > hard_deadline || (any && now - last_message > std::chrono::milliseconds(1500));
  };
  json nats_report;
  if (over_nats) {
#ifdef KATA_HAVE_NATS
    namespace kn = kata::transport::nats;
    kn::ConnectionOptions co;
    std::stringstream list(o.subscriber);
    for (std::string url; std::getline(list, url, ',');) co.servers.push_back(url);
    co.randomize = false;
    co.name = "kata-replay-subscriber";
    kn::Connection connection(co);
    natsSubscription* nsub = nullptr;
    if (natsConnection_SubscribeSync(&nsub, connection.get(), kn::all_results_subject("kata").c_str()) != NATS_OK) {
      std::fprintf(stderr, "subscriber: cannot subscribe: %s\n", kn::last_error().c_str());
      return 1;
    }
    natsSubscription_SetPendingLimits(nsub, -1, -1);  // never dropped by the client: late is measured
    connection.flush(2000);
    // The shards are named replay-0 .. replay-<shards - 1> (run_shard_processes): a stream counts as
    // announced once its definition came from the shard rendezvous hashing gives its partition,
    // i.e. once the shards have shared the partitions out among all of them.
    std::vector<std::string> names;
    for (int k = 0; k < o.shards; ++k) names.push_back("replay-" + std::to_string(k));
    kn::EpochFilter epochs;
    uint64_t stale = 0;
    while (!finished()) {
      natsMsg* msg = nullptr;
      // A synchronous subscription: libnats' reader thread queues the message, this thread takes
      // it (one hand-off, as a ZeroMQ SUB socket's I/O thread to its reader).
      if (natsSubscription_NextMsg(&msg, nsub, 100) != NATS_OK) continue;
      const int64_t t = now_ns();
      uint64_t id = 0, epoch = 0;
      const char* owner = nullptr;
      if (kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &epoch, &owner)) {
        if (epochs.accept(id, epoch)) {
          const bool settled = names.empty() ||
                               owner == names[static_cast<size_t>(kn::rendezvous_owner(names, kn::partition_of(id, kn::kDefaultPartitions)))];
          on_message(reinterpret_cast<const uint8_t*>(natsMsg_GetData(msg)),
                     static_cast<size_t>(natsMsg_GetDataLength(msg)), t, settled);
        } else {
          ++stale;
        }
      }
      natsMsg_Destroy(msg);
    }
    int64_t dropped = 0;
    natsSubscription_GetDropped(nsub, &dropped);
    natsSubscription_Destroy(nsub);
    nats_report = {{"stale_epoch", stale}, {"handovers", epochs.handovers()}, {"client_dropped", dropped}};
#else
    std::fprintf(stderr, "subscriber: this kata-replay was built without NATS (libnats-dev)\n");
    return 1;
#endif
  } else {
    while (!finished()) {
      zmq_pollitem_t item{sub, 0, ZMQ_POLLIN, 0};
      zmq_poll(&item, 1, 100);
      for (;;) {
        const int n = zmq_recv(sub, buffer.data(), buffer.size(), ZMQ_DONTWAIT);
        if (n < 0) break;
        on_message(buffer.data(), static_cast<size_t>(n), now_ns(), true);
      }
    }
  }
  json j;
  j["received"] = received;
  if (kata_mode)
    for (const auto& [id, n] : received_by_stream) j["received_by_stream"][std::to_string(id)] = n;
  j["mean_message_bytes"] = received ? static_cast<double>(bytes) / static_cast<double>(received) : 0.0;
  j["latency"] = summary(total);
  if (kata_mode) {
    if (o.capture_is_send) j["stages"]["source_to_arrival"] = summary(source_to_arrival);
    j["stages"]["arrival_to_computed"] = summary(queue_compute);
    j["stages"]["computed_to_published"] = summary(publish);
    j["stages"]["published_to_received"] = summary(transport);
  }
  j["subscriber_cpu_seconds"] = cpu_seconds() - cpu0;
  if (over_nats) j["nats"] = nats_report;
  if (o.window > 0 && !received_at.empty()) {
    // Latency per window of receive time, from the first result on.
    const int64_t window_ns = static_cast<int64_t>(o.window * 1e9);
    json windows = json::array();
    size_t begin = 0;
    while (begin < received_at.size()) {
      const int64_t window_end = received_at[0] + static_cast<int64_t>(windows.size() + 1) * window_ns;
      size_t end = begin;
      while (end < received_at.size() && received_at[end] < window_end) ++end;
      std::vector<int64_t> w(total.begin() + static_cast<long>(begin), total.begin() + static_cast<long>(end));
      json x = summary(w);
      x["count"] = end - begin;
      // Where the window's time went: the median of each stage (arrival -> computed -> published
      // -> received).
      auto stage_p50 = [&](const std::vector<int64_t>& v) {
        if (v.size() != total.size()) return 0.0;
        std::vector<int64_t> part(v.begin() + static_cast<long>(begin), v.begin() + static_cast<long>(end));
        return percentile(part, 0.5);
      };
      x["p50_arrival_to_computed_us"] = stage_p50(queue_compute);
      x["p50_computed_to_published_us"] = stage_p50(publish);
      x["p50_published_to_received_us"] = stage_p50(transport);
      windows.push_back(x);
      begin = end;
    }
    j["windows"] = windows;
  }
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  if (sub != nullptr) zmq_close(sub);
  if (context != nullptr) zmq_ctx_term(context);
  return 0;
}

}  // namespace kata::replay
