// `kata serve` over NATS ([transport] kind = "nats"; docs/deploy.md): a Shard (shard.hpp) whose
// messages reach the runtime's own ingest, and whose results leave through a runtime Sink.
//
// The runtime's ingest is the one ZeroMQ uses, unchanged (the same verifier, size limit, stream
// table, counters by cause, revisions and closes): the bridge binds it to a private local socket
// (ipc:// in a directory only this user may enter) and pushes every message of a held partition
// into it from libnats' delivery thread, in order. All of them come from that one sender, so the
// ingest's per-sender ownership says nothing here: who may publish on a stream's subject is the
// NATS account's permissions' business. The cost is one local hop (a PUSH -> PULL over ipc, tens
// of microseconds) that a runtime taking messages from any thread would not need.
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
// Thread rules: construct, start(), stop() and destroy on one thread; sink() is called by the
// runtime (one thread at a time).
#pragma once

#include <memory>
#include <string>

#include "runtime/runtime.hpp"
#include "transport/nats/shard.hpp"

namespace kata::transport::nats {

class ServeBridge {
 public:
  // Makes the private socket's directory; nothing is connected yet. Throws kata::Error(kIo).
  explicit ServeBridge(ShardOptions options);
  // stop(), then removes the socket's directory.
  ~ServeBridge();
  ServeBridge(const ServeBridge&) = delete;
  ServeBridge& operator=(const ServeBridge&) = delete;

  // The endpoint the runtime's ingest binds ("bind:" + this), a PULL ingest.
  std::string ingest_endpoint() const { return "ipc://" + socket_path_; }
  // The sink that publishes results (to RuntimeConfig::sinks before the runtime is made).
  runtime::Sink sink();
  // Connects to the ingest and to NATS, and starts taking partitions. Throws kata::Error.
  void start();
  // Gives every partition back (the others take them at once) and disconnects. Idempotent.
  void stop();

  const Shard* shard() const { return shard_.get(); }
  // Messages the local socket would not take (its queue full: the runtime fell behind).
  uint64_t bridge_dropped() const { return bridge_dropped_.load(std::memory_order_relaxed); }

 private:
  void on_message(const void* data, size_t size);
  ShardOptions options_;
  std::string directory_, socket_path_;
  void* context_ = nullptr;
  void* push_ = nullptr;  // [libnats' delivery thread] after start()
  std::unique_ptr<Shard> shard_;
  std::atomic<Shard*> live_shard_{nullptr};  // for the sink: null before start and after stop
  std::unique_ptr<Encoder> encoder_;          // [the sink's thread]
  std::atomic<uint64_t> bridge_dropped_{0};
};

}  // namespace kata::transport::nats
