// One `kata serve` shard on NATS: its connection, its partition leases (lease.hpp), a subscription
// to each partition it holds (`<prefix>.in.<p>.*`, so it receives only its own streams' traffic),
// and the gate on its results (published on `<prefix>.out.<topic>.<epoch>.<owner>` only while the
// stream's partition is held: results.hpp).
//
// What it does not do is read the messages: on_message hands each one's bytes (the ZeroMQ wire
// format: topic + verified-later FlatBuffer, wire.hpp) to the receiver, which verifies, counts and
// scores them as the ZeroMQ ingest does. Before that it drops, and counts, what a shard must not
// take: a message larger than max_message_bytes, one whose subject does not name a stream of the
// partition it arrived on (published to a partition subject directly, around the servers'
// mapping), one whose topic differs from its subject's, and one that arrived after the partition
// was given up.
//
// Thread rules: on_message runs on one thread (libnats' delivery thread: every subscription of the
// shard is delivered by the library's shared pool of one thread), so a stream's messages arrive in
// order. on_acquired / on_dropped run on the lease thread (on_dropped after the partition's
// results stopped and before its subscription ends). publish_result: [one thread at a time],
// allocation-free. counters(): [any thread].
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "transport/nats/connection.hpp"
#include "transport/nats/lease.hpp"

typedef struct __natsSubscription natsSubscription;
typedef struct __natsMsg natsMsg;

namespace kata::transport::nats {

struct ShardOptions {
  ConnectionOptions connection;
  LeaseOptions lease;              // lease.member names this shard
  std::string prefix = kDefaultPrefix;
  size_t max_message_bytes = 1 << 20;
  // Messages a partition's subscription may hold undelivered before libnats drops (counted in
  // slow_consumer) rather than grow.
  int pending_messages = 65536;
};

struct ShardCounters {
  uint64_t received = 0;          // messages delivered to this shard
  uint64_t handed_on = 0;         // passed to on_message
  uint64_t oversized = 0;         // larger than max_message_bytes
  uint64_t wrong_partition = 0;   // subject or topic not a stream of the partition it came on
  uint64_t not_held = 0;          // arrived after the partition was given up
  uint64_t slow_consumer = 0;     // dropped by libnats: the receiver fell behind
  uint64_t results_published = 0;
  uint64_t results_not_held = 0;  // results of a stream whose partition this shard does not hold now
  uint64_t results_failed = 0;    // refused by libnats (closed; its reconnect buffer full)
  uint64_t partitions_held = 0;   // now
  uint64_t disconnects = 0, reconnects = 0;
  LeaseCounters leases;
};

class Shard {
 public:
  struct Handlers {
    std::function<void(const void* data, size_t size)> on_message;         // [delivery thread]
    std::function<void(uint32_t partition, uint64_t epoch)> on_acquired;   // [lease thread]
    std::function<void(uint32_t partition)> on_dropped;                    // [lease thread]
  };
  // Connects and starts the lease thread. Throws Error (connection.hpp) as Connection and LeaseManager do.
  Shard(ShardOptions options, Handlers handlers);
  // stop(true).
  ~Shard();
  Shard(const Shard&) = delete;
  Shard& operator=(const Shard&) = delete;

  // Gives every partition back (give_back) or lets the leases lapse, and ends every subscription.
  void stop(bool give_back = true);

  // Publishes one result message (wire bytes) of a stream if its partition is held now; false
  // otherwise (counted). Allocation-free.
  bool publish_result(uint64_t stream_id, const void* data, size_t size);
  // The same for a stream's skeleton definition, from on_message's thread (its own subject buffer).
  bool publish_definition(uint64_t stream_id, const void* data, size_t size);

  ShardCounters counters() const;
  const LeaseManager& leases() const { return *leases_; }
  Connection& connection() { return *connection_; }
  const ShardOptions& options() const { return options_; }

 private:
  struct Partition {
    Shard* shard = nullptr;
    uint32_t index = 0;
    natsSubscription* subscription = nullptr;  // [lease thread] subscriptions_mutex_
    std::atomic<bool> open{false};             // messages are handed on
  };
  static void on_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* closure);
  static void on_complete(void* closure);
  void on_lease(const LeaseEvent& event);
  void drop(uint32_t partition);

  ShardOptions options_;
  Handlers handlers_;
  std::unique_ptr<Connection> connection_;
  std::unique_ptr<Partition[]> partitions_;
  std::unique_ptr<LeaseManager> leases_;
  std::atomic<uint64_t> received_{0}, handed_on_{0}, oversized_{0}, wrong_partition_{0}, not_held_{0};
  std::atomic<uint64_t> results_published_{0}, results_not_held_{0}, results_failed_{0};
  // Subscriptions whose message handler may still run: nats.c may deliver one last message after
  // natsSubscription_Unsubscribe returns (its delivery thread had already taken it), so a
  // subscription counts until its completion callback says the handler has returned for good;
  // stop() waits for none before the shard (which every handler reaches) may go away.
  std::atomic<int> live_subscriptions_{0};
  mutable std::mutex subscriptions_mutex_;  // the subscriptions (lease thread) against counters()
  uint64_t slow_consumer_ended_ = 0;        // drops of subscriptions ended; subscriptions_mutex_
  char subject_[256] = {};             // publish_result's subject [publishing thread]
  char definition_subject_[256] = {};  // publish_definition's [delivery thread]
  // 0 published, 1 the partition is not held, 2 refused by libnats.
  int publish(uint64_t stream_id, const void* data, size_t size, char* subject, size_t capacity);
  bool stopped_ = false;
};

}  // namespace kata::transport::nats
