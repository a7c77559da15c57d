// `kata serve` over NATS ([transport] kind = "nats"; docs/deploy.md): a Shard (shard.hpp) whose
// messages reach the runtime's own ingest (kata_runtime_offer, through the offer function start()
// is given), and whose results leave through publish() (called from kata_runtime_desc.on_result).
// It knows the runtime only through those two: serve runs its runtime on the C ABI.
//
// The runtime's ingest is the one ZeroMQ uses (the same verifier, size limit, stream table,
// counters by cause, revisions and closes), made socketless (transport::IngestKind::kDirect):
// libnats' delivery thread hands each message of a held partition, in order, to the offer function
// (kata_runtime_offer: Runtime::offer),
// which copies it into a bounded single-producer ring (allocated once) and wakes the runtime's
// I/O thread, the ingest's one owner, through an eventfd. Before this ring the bridge
// pushed every message over a private ipc PUSH -> PULL socket instead: two ZeroMQ I/O threads and
// three wake-ups per message (~150 us at p50 of the frames' hop, more in bursts); the ring needs
// one. All messages come from the one producer, so the ingest's per-sender ownership says nothing
// here (they count as kLocalSender): who may publish on a stream's subject is the NATS account's
// permissions' business. A message the ring cannot take (the I/O thread fell behind, or the
// runtime is stopping) is counted in bridge_dropped().
//
// Results: publish() encodes each one with kata_message_write_result (the same FlatBuffers Result
// as ZeroMQ's, byte for byte) and publishes it on
// the stream's result subject under this shard's lease epoch, or drops it (counted) when the
// stream's partition is not held; publish_repetition() does the same with a Repetition message
// (kata_runtime_desc.on_repetition), as the runtime's ZeroMQ publisher sends it beside the results. Skeleton definitions of the held streams are forwarded to the
// same subjects, so that a consumer learns each stream's skeleton on NATS as on ZeroMQ.
//
// A stream whose partition moves away stays open in this runtime, idle, until the ingest's
// idle_stream_seconds closes it (or its partition comes back and it goes on). The new holder
// opens it from its next skeleton definition.
//
// Thread rules: construct, start(), stop() and destroy on one thread; the runtime the offer
// function reaches must outlive stop() (stop() returns after libnats' last delivery, so no call
// into the runtime follows it). on_message runs on libnats' delivery thread (one: shard.hpp), the
// ring's one producer. publish() is called by the runtime's on_result (one thread at a time).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kata/kata.h"
#include "transport/nats/shard.hpp"
#include "transport/nats/topic.hpp"

namespace kata::transport::nats {

class ServeBridge {
 public:
  explicit ServeBridge(ShardOptions options);
  // stop().
  ~ServeBridge();
  ServeBridge(const ServeBridge&) = delete;
  ServeBridge& operator=(const ServeBridge&) = delete;

  // Takes a message into the runtime's direct ingest (kata_runtime_offer == KATA_OK): false when
  // the runtime would not take it (counted in bridge_dropped()).
  using Offer = std::function<bool(const void* message, size_t size)>;
  // Publishes one result of the runtime (its on_result record, valid during the call) on the
  // stream's result subject, or drops it (counted) when the stream's partition is not held.
  void publish(const kata_result_record& record);
  // Publishes one repetition (the runtime's on_repetition, called right after the result of the
  // frame that ended it, or at the stream's end) on the same subject as the stream's results, as
  // the Repetition message a ZeroMQ publisher sends (kata_message_write_repetition), or drops it
  // as publish() does. Called on on_result's thread.
  void publish_repetition(const kata_repetition& repetition);
  // Connects to NATS and starts taking partitions; their messages go to offer. Throws Error
  // (connection.hpp).
  void start(Offer offer);
  // Gives every partition back (the others take them at once) and disconnects; after it returns
  // nothing reaches the runtime. Idempotent.
  void stop();

  const Shard* shard() const { return shard_.get(); }
  // Messages the runtime's ring would not take (full: the runtime fell behind; or it was stopping).
  uint64_t bridge_dropped() const { return bridge_dropped_.load(std::memory_order_relaxed); }
  // Results (and repetitions) the message writers refused (a record with a non-finite value:
  // none from a runtime), not published.
  uint64_t results_refused() const { return write_failed_.load(std::memory_order_relaxed); }

 private:
  void on_message(const void* data, size_t size);
  ShardOptions options_;
  Offer offer_;  // set by start() before the first subscription exists
  std::unique_ptr<Shard> shard_;
  std::atomic<Shard*> live_shard_{nullptr};  // for publish(): null before start and after stop
  std::vector<unsigned char> message_;        // a result's bytes [publish()'s thread]
  std::atomic<uint64_t> write_failed_{0};     // records kata_message_write_result refused (none expected)
  std::atomic<uint64_t> bridge_dropped_{0};
};

}  // namespace kata::transport::nats
