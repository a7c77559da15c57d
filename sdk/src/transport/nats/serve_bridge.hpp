// `kata serve` over NATS ([transport] kind = "nats"; docs/deploy.md): a Shard (shard.hpp) whose
// messages reach the runtime's own ingest, and whose results leave through a runtime Sink.
//
// The runtime's ingest is the one ZeroMQ uses (the same verifier, size limit, stream table,
// counters by cause, revisions and closes), made socketless (transport::IngestKind::kDirect):
// libnats' delivery thread hands each message of a held partition, in order, to Runtime::offer,
// which copies it into a bounded single-producer ring (allocated once) and wakes the runtime's
// I/O thread, the ingest's one owner, through an eventfd. Before this ring the bridge
// pushed every message over a private ipc PUSH -> PULL socket instead: two ZeroMQ I/O threads and
// three wake-ups per message (~150 us at p50 of the frames' hop, more in bursts); the ring needs
// one. All messages come from the one producer, so the ingest's per-sender ownership says nothing
// here (they count as kLocalSender): who may publish on a stream's subject is the NATS account's
// permissions' business. A message the ring cannot take (the I/O thread fell behind, or the
// runtime is stopping) is counted in bridge_dropped().
//
// Results: the sink encodes each one (the same FlatBuffers Result as ZeroMQ's) and publishes it on
// the stream's result subject under this shard's lease epoch, or drops it (counted) when the
// stream's partition is not held. Skeleton definitions of the held streams are forwarded to the
// same subjects, so that a consumer learns each stream's skeleton on NATS as on ZeroMQ.
//
// A stream whose partition moves away stays open in this runtime, idle, until the ingest's
// idle_stream_seconds closes it (or its partition comes back and it goes on). The new holder
// opens it from its next skeleton definition.
//
// Thread rules: construct, configure(), start(), stop() and destroy on one thread; the runtime
// given to start() must outlive stop() (stop() returns after libnats' last delivery, so no call
// into the runtime follows it). on_message runs on libnats' delivery thread (one: shard.hpp), the
// ring's one producer. sink() is called by the runtime (one thread at a time).
#pragma once

#include <memory>
#include <string>

#include "runtime/runtime.hpp"
#include "transport/nats/shard.hpp"

namespace kata::transport::nats {

class ServeBridge {
 public:
  explicit ServeBridge(ShardOptions options);
  // stop().
  ~ServeBridge();
  ServeBridge(const ServeBridge&) = delete;
  ServeBridge& operator=(const ServeBridge&) = delete;

  // Before the runtime is made: its ingest becomes a direct one (no endpoint, no socket) and this
  // bridge's sink is added to its sinks.
  void configure(runtime::RuntimeConfig& config);
  // The sink that publishes results (configure() adds it).
  runtime::Sink sink();
  // Connects to NATS and starts taking partitions; their messages go to runtime.offer(). Throws
  // kata::Error.
  void start(runtime::Runtime& runtime);
  // Gives every partition back (the others take them at once) and disconnects; after it returns
  // nothing reaches the runtime. Idempotent.
  void stop();

  const Shard* shard() const { return shard_.get(); }
  // Messages the runtime's ring would not take (full: the runtime fell behind; or it was stopping).
  uint64_t bridge_dropped() const { return bridge_dropped_.load(std::memory_order_relaxed); }

 private:
  void on_message(const void* data, size_t size);
  ShardOptions options_;
  runtime::Runtime* runtime_ = nullptr;  // set by start() before the first subscription exists
  std::unique_ptr<Shard> shard_;
  std::atomic<Shard*> live_shard_{nullptr};  // for the sink: null before start and after stop
  std::unique_ptr<Encoder> encoder_;          // [the sink's thread]
  std::atomic<uint64_t> bridge_dropped_{0};
};

}  // namespace kata::transport::nats
