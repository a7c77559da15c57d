// kata_nats_hop: the latency NATS adds to one hop of a kata message on loopback, for
// docs/deploy.md: a 3-server cluster (nats_cluster.hpp) started here, a publisher on server n0
// sending frame-sized messages (the wire bytes of a 31-joint frame) at --rate per second for
// --seconds, and two subscribers, one on n0 (same server) and one on n1 (one route hop further,
// as a shard on another server of the cluster), each stamping arrival with the steady clock. It
// prints p50 / p99 / max of publish -> delivery per path, beside the same messages over a ZeroMQ
// PUB -> SUB pair on loopback TCP in the same run (kata's one-host transport; a receiving thread
// of its own, as NATS's delivery thread), and a third NATS subscriber on n0 that hands each
// message on as a `kata serve` shard does (serve_bridge.cpp: from libnats' delivery thread over
// an ipc PUSH to a PULL in another ZeroMQ context, read by a thread of its own as the runtime's
// ingest reads), stamped where the PULL reader gets it: the bridge's share of a frame's hop until
// the direct ingest. A fourth subscriber on n0 hands each message on as the shard does now
// (Runtime::offer: copied into a MessageRing, an eventfd written; a thread of its own sleeping in
// zmq_poll on that eventfd, as the runtime's I/O thread, drains the ring), stamped where that
// reader gets it. A measurement tool, not a test.
//   kata_nats_hop [--rate 1000] [--seconds 10]
#include <nats/nats.h>
#include <zmq.h>

#include <atomic>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <sys/eventfd.h>
#include <unistd.h>

#include "nats_cluster.hpp"
#include "transport/nats/connection.hpp"
#include "transport/nats/partition.hpp"
#include "transport/message_ring.hpp"
#include "transport/wire.hpp"

namespace {

int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct Path {
  std::mutex mutex;
  std::vector<int64_t> latency_ns;
};

void on_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
  const int64_t now = steady_ns();
  auto* path = static_cast<Path*>(closure);
  int64_t sent = 0;
  // The send time rides in the frame's capture_ns field's place: the first 8 payload bytes after the topic.
  if (natsMsg_GetDataLength(msg) >= static_cast<int>(kata::transport::kTopicBytes + 8))
    std::memcpy(&sent, natsMsg_GetData(msg) + kata::transport::kTopicBytes, 8);
  std::lock_guard<std::mutex> lock(path->mutex);
  path->latency_ns.push_back(now - sent);
  natsMsg_Destroy(msg);
}

double percentile(std::vector<int64_t> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return static_cast<double>(v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))]) / 1e3;
}

// The shard's bridge: the message's bytes on to the ingest's socket, as ServeBridge::on_message.
void on_bridge_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* push) {
  zmq_send(push, natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)), ZMQ_DONTWAIT);
  natsMsg_Destroy(msg);
}

// The shard's path now: the message's bytes into the runtime's ring, its I/O thread woken
// (Runtime::offer).
struct Direct {
  kata::transport::MessageRing ring{4 << 20};
  int fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
};
void on_direct_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
  auto* d = static_cast<Direct*>(closure);
  if (d->ring.push(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)))) {
    const uint64_t one = 1;
    (void)!write(d->fd, &one, sizeof one);
  }
  natsMsg_Destroy(msg);
}

}  // namespace

int main(int argc, char** argv) {
  double rate = 1000, seconds = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--rate") == 0) rate = std::atof(argv[i + 1]);
    if (std::strcmp(argv[i], "--seconds") == 0) seconds = std::atof(argv[i + 1]);
  }
  const auto dir = std::filesystem::temp_directory_path() / ("kata_nats_hop_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  int rc = 0;
  {
    kata::test::NatsCluster cluster(dir.string(), 3);
    if (!cluster.problem().empty()) {
      std::fprintf(stderr, "%s\n", cluster.problem().c_str());
      rc = 1;
    } else {
      namespace kn = kata::transport::nats;
      auto connect = [&](int server) {
        kn::ConnectionOptions o;
        o.servers = {cluster.url(server)};
        return std::make_unique<kn::Connection>(o);
      };
      auto pub = connect(0), same = connect(0), other = connect(1);
      Path same_path, other_path;
      natsSubscription *s1 = nullptr, *s2 = nullptr;
      natsConnection_Subscribe(&s1, same->get(), "kata.in.*.*", on_msg, &same_path);
      natsConnection_Subscribe(&s2, other->get(), "kata.in.*.*", on_msg, &other_path);
      // The bridge: PUSH (its own context, hwm 100000, as the shard's) -> ipc -> PULL (another
      // context, as the runtime's ingest has), read by a thread of its own.
      auto bridged = connect(0);
      void* push_ctx = zmq_ctx_new();
      void* pull_ctx = zmq_ctx_new();
      void* bpush = zmq_socket(push_ctx, ZMQ_PUSH);
      void* bpull = zmq_socket(pull_ctx, ZMQ_PULL);
      const int bridge_hwm = 100000;
      zmq_setsockopt(bpush, ZMQ_SNDHWM, &bridge_hwm, sizeof bridge_hwm);
      const std::string bridge_endpoint = "ipc://" + (dir / "bridge.sock").string();
      zmq_bind(bpull, bridge_endpoint.c_str());
      zmq_connect(bpush, bridge_endpoint.c_str());
      Path bridge_path;
      std::atomic<bool> bstop{false};
      std::thread breader([&] {
        int timeout = 100;
        zmq_setsockopt(bpull, ZMQ_RCVTIMEO, &timeout, sizeof timeout);
        uint8_t buffer[4096];
        while (!bstop.load()) {
          const int n = zmq_recv(bpull, buffer, sizeof buffer, 0);
          if (n < static_cast<int>(kata::transport::kTopicBytes + 8)) continue;
          const int64_t now = steady_ns();
          int64_t sent = 0;
          std::memcpy(&sent, buffer + kata::transport::kTopicBytes, 8);
          std::lock_guard<std::mutex> lock(bridge_path.mutex);
          bridge_path.latency_ns.push_back(now - sent);
        }
      });
      auto directed = connect(0);
      Direct direct;
      Path direct_path;
      std::atomic<bool> dstop{false};
      std::thread dreader([&] {
        while (!dstop.load()) {
          zmq_pollitem_t item{nullptr, direct.fd, ZMQ_POLLIN, 0};
          zmq_poll(&item, 1, 100);
          uint64_t value;
          (void)!read(direct.fd, &value, sizeof value);
          const uint8_t* data = nullptr;
          size_t size = 0;
          while (direct.ring.front(&data, &size)) {
            if (size >= kata::transport::kTopicBytes + 8) {
              const int64_t now = steady_ns();
              int64_t sent = 0;
              std::memcpy(&sent, data + kata::transport::kTopicBytes, 8);
              std::lock_guard<std::mutex> lock(direct_path.mutex);
              direct_path.latency_ns.push_back(now - sent);
            }
            direct.ring.pop();
          }
        }
      });
      natsSubscription* s4 = nullptr;
      natsConnection_Subscribe(&s4, directed->get(), "kata.in.*.*", on_direct_msg, &direct);
      directed->flush(2000);
      natsSubscription* s3 = nullptr;
      natsConnection_Subscribe(&s3, bridged->get(), "kata.in.*.*", on_bridge_msg, bpush);
      bridged->flush(2000);
      same->flush(2000);
      other->flush(2000);
      // The ZeroMQ pair: PUB bound on an ephemeral port, SUB connected, read by its own thread.
      void* zctx = zmq_ctx_new();
      void* zpub = zmq_socket(zctx, ZMQ_PUB);
      void* zsub = zmq_socket(zctx, ZMQ_SUB);
      zmq_bind(zpub, "tcp://127.0.0.1:*");
      char zendpoint[128];
      size_t zlen = sizeof zendpoint;
      zmq_getsockopt(zpub, ZMQ_LAST_ENDPOINT, zendpoint, &zlen);
      zmq_setsockopt(zsub, ZMQ_SUBSCRIBE, "", 0);
      zmq_connect(zsub, zendpoint);
      Path zmq_path;
      std::atomic<bool> zstop{false};
      std::thread zreader([&] {
        int timeout = 100;
        zmq_setsockopt(zsub, ZMQ_RCVTIMEO, &timeout, sizeof timeout);
        uint8_t buffer[4096];
        while (!zstop.load()) {
          const int n = zmq_recv(zsub, buffer, sizeof buffer, 0);
          if (n < static_cast<int>(kata::transport::kTopicBytes + 8)) continue;
          const int64_t now = steady_ns();
          int64_t sent = 0;
          std::memcpy(&sent, buffer + kata::transport::kTopicBytes, 8);
          std::lock_guard<std::mutex> lock(zmq_path.mutex);
          zmq_path.latency_ns.push_back(now - sent);
        }
      });
      std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the subscriptions reach every server
      kata::transport::Encoder encoder;
      std::vector<float> xyz(31 * 3, 0.5f);
      const auto frame = encoder.frame(0x1234, 0, 0, xyz.data(), 31);
      std::vector<uint8_t> message(frame.data, frame.data + frame.size);
      const std::string subject = kn::ingest_subject("kata", 0x1234);
      const int64_t period = static_cast<int64_t>(1e9 / rate);
      const int64_t start = steady_ns();
      const int64_t count = static_cast<int64_t>(rate * seconds);
      for (int64_t n = 0; n < count; ++n) {
        const int64_t due = start + n * period;
        while (steady_ns() < due) std::this_thread::sleep_for(std::chrono::microseconds(50));
        const int64_t now = steady_ns();
        std::memcpy(message.data() + kata::transport::kTopicBytes, &now, 8);
        pub->publish(subject, message.data(), message.size());
        const int64_t znow = steady_ns();
        std::memcpy(message.data() + kata::transport::kTopicBytes, &znow, 8);
        zmq_send(zpub, message.data(), message.size(), ZMQ_DONTWAIT);
      }
      pub->flush(2000);
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      zstop.store(true);
      zreader.join();
      int linger = 0;
      zmq_setsockopt(zpub, ZMQ_LINGER, &linger, sizeof linger);
      zmq_setsockopt(zsub, ZMQ_LINGER, &linger, sizeof linger);
      zmq_close(zpub);
      zmq_close(zsub);
      zmq_ctx_term(zctx);
      natsSubscription_Destroy(s1);
      natsSubscription_Destroy(s2);
      natsSubscription_Unsubscribe(s3);  // no callback sends on bpush after the 500 ms of quiet above
      natsSubscription_Destroy(s3);
      bstop.store(true);
      breader.join();
      natsSubscription_Unsubscribe(s4);
      natsSubscription_Destroy(s4);
      dstop.store(true);
      dreader.join();
      close(direct.fd);
      zmq_setsockopt(bpush, ZMQ_LINGER, &linger, sizeof linger);
      zmq_setsockopt(bpull, ZMQ_LINGER, &linger, sizeof linger);
      zmq_close(bpush);
      zmq_close(bpull);
      zmq_ctx_term(push_ctx);
      zmq_ctx_term(pull_ctx);
      std::printf("NATS hop, %zu-byte frame messages at %.0f/s for %.0f s (publish -> delivery, steady clock):\n",
                  message.size(), rate, seconds);
      for (auto* p : {&zmq_path, &same_path, &other_path, &bridge_path, &direct_path}) {
        std::lock_guard<std::mutex> lock(p->mutex);
        std::printf("  %-52s %6zu received  p50 %7.1f us  p99 %7.1f us  max %8.1f us\n",
                    p == &zmq_path     ? "ZeroMQ PUB -> SUB (tcp, loopback):"
                    : p == &same_path  ? "NATS, subscriber on the same server:"
                    : p == &other_path ? "NATS, subscriber one route away:"
                    : p == &bridge_path ? "NATS same server + the former ipc bridge (PUSH -> PULL):"
                                        : "NATS same server + the shard's ring (Runtime::offer):",
                    p->latency_ns.size(), percentile(p->latency_ns, 0.5), percentile(p->latency_ns, 0.99),
                    percentile(p->latency_ns, 1.0));
      }
    }
  }
  std::filesystem::remove_all(dir);
  return rc;
}
