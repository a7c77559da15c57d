#include "transport/nats/serve_bridge.hpp"

#include <zmq.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "common/error.hpp"
#include "pipeline/pipeline.hpp"

namespace kata::transport::nats {

ServeBridge::ServeBridge(ShardOptions options) : options_(std::move(options)), encoder_(std::make_unique<Encoder>()) {
  std::string pattern = (std::filesystem::temp_directory_path() / "kata-nats-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) throw Error(ErrorKind::kIo, "serve: cannot make a private socket directory in " +
                                                                          std::filesystem::temp_directory_path().string());
  directory_ = pattern;  // mkdtemp makes it 0700: no other user can reach the socket inside
  socket_path_ = directory_ + "/ingest.sock";
}

ServeBridge::~ServeBridge() {
  stop();
  std::error_code ec;
  std::filesystem::remove_all(directory_, ec);
}

runtime::Sink ServeBridge::sink() {
  runtime::Sink s;
  s.on_result = [this](const ResultFields& fields) {
    Shard* shard = live_shard_.load(std::memory_order_acquire);
    if (shard == nullptr) return;
    // The runtime stamps published_ns only for its own ZeroMQ publisher (none here): stamped as it
    // does, just before the encoding, so that a result's computed -> published -> received split
    // means the same on both transports (kata replay --transport nats reports it).
    ResultFields stamped = fields;
    stamped.published_ns = pipeline::now_ns();
    const Bytes bytes = encoder_->result(stamped);
    shard->publish_result(fields.stream_id, bytes.data, bytes.size);
  };
  return s;
}

void ServeBridge::start() {
  context_ = zmq_ctx_new();
  push_ = zmq_socket(context_, ZMQ_PUSH);
  // A deep queue: the runtime's ingest reads in batches; beyond this the bridge drops (counted)
  // rather than block libnats' delivery thread.
  const int hwm = 100000, linger = 0;
  zmq_setsockopt(push_, ZMQ_SNDHWM, &hwm, sizeof hwm);
  zmq_setsockopt(push_, ZMQ_LINGER, &linger, sizeof linger);
  if (zmq_connect(push_, ingest_endpoint().c_str()) != 0)
    throw Error(ErrorKind::kIo, "serve: cannot connect to the ingest at " + ingest_endpoint() + ": " +
                                    zmq_strerror(zmq_errno()));
  Shard::Handlers h;
  h.on_message = [this](const void* data, size_t size) { on_message(data, size); };
  shard_ = std::make_unique<Shard>(options_, h);
  live_shard_.store(shard_.get(), std::memory_order_release);
}

void ServeBridge::on_message(const void* data, size_t size) {
  // A skeleton definition is also a consumer's: forwarded to the stream's result subject.
  if (size >= kTopicBytes + 8 && std::memcmp(static_cast<const char*>(data) + kTopicBytes + 4, "KSKL", 4) == 0) {
    uint64_t id = 0;
    if (parse_topic(static_cast<const uint8_t*>(data), &id)) shard_->publish_definition(id, data, size);
  }
  if (zmq_send(push_, data, size, ZMQ_DONTWAIT) < 0) bridge_dropped_.fetch_add(1, std::memory_order_relaxed);
}

void ServeBridge::stop() {
  live_shard_.store(nullptr, std::memory_order_release);
  if (shard_) shard_->stop(true);
  shard_.reset();
  if (push_ != nullptr) zmq_close(push_);
  push_ = nullptr;
  if (context_ != nullptr) zmq_ctx_term(context_);
  context_ = nullptr;
}

}  // namespace kata::transport::nats
