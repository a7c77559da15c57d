#include "transport/nats/serve_bridge.hpp"

#include <chrono>
#include <cstring>

namespace kata::transport::nats {

ServeBridge::ServeBridge(ShardOptions options) : options_(std::move(options)), message_(4096) {}

ServeBridge::~ServeBridge() { stop(); }

void ServeBridge::publish(const kata_result_record& record) {
  Shard* shard = live_shard_.load(std::memory_order_acquire);
  if (shard == nullptr) return;
  // The runtime stamps published_ns only for its own ZeroMQ publisher (none here): stamped as it
  // does (steady_clock, CLOCK_MONOTONIC), just before the encoding, so that a result's computed ->
  // published -> received split means the same on both transports (kata replay --transport nats
  // reports it).
  kata_result_record stamped = record;
  stamped.struct_size = sizeof stamped;  // the runtime's record is at least this kata.h's
  stamped.published_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
  // The ABI's writer: the bytes the runtime's own publisher would send. The buffer grows to the
  // largest result once (a ghost of 64 joints: about 1.5 kB).
  size_t size = 0;
  kata_status status = kata_message_write_result(&stamped, message_.data(), message_.size(), &size);
  if (status == KATA_E_BUFFER_TOO_SMALL) {
    message_.resize(size);
    status = kata_message_write_result(&stamped, message_.data(), message_.size(), &size);
  }
  if (status != KATA_OK) {
    write_failed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  shard->publish_result(record.stream_id, message_.data(), size);
}

void ServeBridge::publish_repetition(const kata_repetition& repetition) {
  Shard* shard = live_shard_.load(std::memory_order_acquire);
  if (shard == nullptr) return;
  kata_repetition r = repetition;
  r.struct_size = sizeof r;  // the runtime's is at least this kata.h's
  size_t size = 0;
  kata_status status = kata_message_write_repetition(&r, message_.data(), message_.size(), &size);
  if (status == KATA_E_BUFFER_TOO_SMALL) {
    message_.resize(size);
    status = kata_message_write_repetition(&r, message_.data(), message_.size(), &size);
  }
  if (status != KATA_OK) {
    write_failed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  shard->publish_result(r.stream_id, message_.data(), size);
}

void ServeBridge::start(Offer offer) {
  offer_ = std::move(offer);  // before the Shard exists: its lease thread subscribes after this
  Shard::Handlers h;
  h.on_message = [this](const void* data, size_t size) { on_message(data, size); };
  shard_ = std::make_unique<Shard>(options_, h);
  live_shard_.store(shard_.get(), std::memory_order_release);
}

void ServeBridge::on_message(const void* data, size_t size) {
  // A skeleton definition is also a consumer's: forwarded to the stream's result subject.
  if (size >= kStreamTopicBytes + 8 &&
      std::memcmp(static_cast<const char*>(data) + kStreamTopicBytes + 4, "KSKL", 4) == 0) {
    uint64_t id = 0;
    // live_shard_, not shard_: the first delivery may come before start() has stored shard_.
    Shard* shard = live_shard_.load(std::memory_order_acquire);
    if (shard != nullptr && read_stream_topic(static_cast<const char*>(data), &id)) shard->publish_definition(id, data, size);
  }
  // Into the runtime's ring; its I/O thread verifies, counts and scores it (kata_runtime_offer).
  if (!offer_(data, size)) bridge_dropped_.fetch_add(1, std::memory_order_relaxed);
}

void ServeBridge::stop() {
  live_shard_.store(nullptr, std::memory_order_release);
  if (shard_) shard_->stop(true);  // returns after the last delivery: nothing reaches runtime_ after
  shard_.reset();
}

}  // namespace kata::transport::nats
