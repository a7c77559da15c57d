// ZeroMQ publisher and ingest (see zmq_io.hpp).
#include "transport/zmq_io.hpp"

#include <zmq.h>

#include <cerrno>
#include <cstring>

#include "common/error.hpp"

namespace kata::transport {

namespace {

std::string last_endpoint(void* socket) {
  char buffer[512];
  size_t size = sizeof buffer;
  if (zmq_getsockopt(socket, ZMQ_LAST_ENDPOINT, buffer, &size) != 0) return {};
  return std::string(buffer);
}

std::string zmq_reason() { return zmq_strerror(zmq_errno()); }

void set_int(void* socket, int option, int value, const char* what) {
  if (zmq_setsockopt(socket, option, &value, sizeof value) != 0)
    throw Error(ErrorKind::kIo, std::string("ZeroMQ: cannot set ") + what + ": " + zmq_reason());
}

}  // namespace

Context::Context(int io_threads) : context_(zmq_ctx_new()) {
  if (!context_) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create a context: " + zmq_reason());
  zmq_ctx_set(context_, ZMQ_IO_THREADS, io_threads);
}

Context::~Context() { zmq_ctx_term(context_); }

// ---------------------------------------------------------------------------------------------

Publisher::Publisher(Context& context, const PublisherOptions& options) {
  if (options.endpoints.empty()) throw Error(ErrorKind::kInvalidArgument, "publisher: no endpoint");
  socket_ = zmq_socket(context.get(), ZMQ_XPUB);
  if (!socket_) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create an XPUB socket: " + zmq_reason());
  try {
    set_int(socket_, ZMQ_SNDHWM, options.send_hwm, "ZMQ_SNDHWM");
    set_int(socket_, ZMQ_LINGER, 0, "ZMQ_LINGER");
    set_int(socket_, ZMQ_XPUB_VERBOSE, 1, "ZMQ_XPUB_VERBOSE");
    for (const std::string& e : options.endpoints) {
      const bool connect = e.rfind("connect:", 0) == 0;
      const std::string endpoint = connect ? e.substr(8) : e;
      if ((connect ? zmq_connect(socket_, endpoint.c_str()) : zmq_bind(socket_, endpoint.c_str())) != 0)
        throw Error(ErrorKind::kIo, std::string("publisher: cannot ") + (connect ? "connect " : "bind ") + endpoint +
                                        ": " + zmq_reason());
    }
  } catch (...) {
    zmq_close(socket_);
    throw;
  }
}

std::string Publisher::endpoint() const { return last_endpoint(socket_); }

Publisher::~Publisher() { zmq_close(socket_); }

bool Publisher::send(Bytes message) {
  if (zmq_send(socket_, message.data, message.size, ZMQ_DONTWAIT) < 0) {
    ++failed_;
    return false;
  }
  ++sent_;
  return true;
}

int Publisher::poll_joins(const std::function<void(const uint8_t*, size_t)>& on_join) {
  int count = 0;
  uint8_t buffer[256];
  for (;;) {
    const int n = zmq_recv(socket_, buffer, sizeof buffer, ZMQ_DONTWAIT);
    if (n < 0) break;
    ++count;
    // 1 = subscribe, 0 = unsubscribe; the rest is the topic prefix (truncated to the buffer).
    if (n >= 1 && buffer[0] == 1) {
      const size_t size = static_cast<size_t>(n) - 1;
      on_join(buffer + 1, size < sizeof buffer - 1 ? size : sizeof buffer - 1);
    }
  }
  return count;
}

// ---------------------------------------------------------------------------------------------

uint64_t IngestCounters::malformed_total() const {
  uint64_t sum = 0;
  for (uint64_t m : malformed) sum += m;
  return sum;
}

uint64_t IngestCounters::dropped_total() const {
  return malformed_total() + refused_skeletons + unknown_stream + wrong_joint_count + out_of_order + other_kind;
}

Ingest::Ingest(Context& context, const IngestOptions& options, Handlers handlers)
    : decoder_(options.max_message_bytes, options.require_checksum), handlers_(std::move(handlers)),
      receive_buffer_(options.max_message_bytes + 1) {
  if (options.endpoints.empty()) throw Error(ErrorKind::kInvalidArgument, "ingest: no endpoint");
  if (options.shard_count > 1 && options.shard_index >= options.shard_count)
    throw Error(ErrorKind::kInvalidArgument, "ingest: shard index must be below the shard count");
  shard_count_ = options.shard_count;
  shard_index_ = options.shard_index;
  socket_ = zmq_socket(context.get(), options.kind == IngestKind::kSub ? ZMQ_SUB : ZMQ_PULL);
  if (!socket_) throw Error(ErrorKind::kIo, "ZeroMQ: cannot create an ingest socket: " + zmq_reason());
  try {
    set_int(socket_, ZMQ_RCVHWM, options.receive_hwm, "ZMQ_RCVHWM");
    set_int(socket_, ZMQ_LINGER, 0, "ZMQ_LINGER");
    if (options.kind == IngestKind::kSub && zmq_setsockopt(socket_, ZMQ_SUBSCRIBE, "", 0) != 0)
      throw Error(ErrorKind::kIo, "ingest: cannot subscribe: " + zmq_reason());
    for (const std::string& e : options.endpoints) {
      const bool bind = e.rfind("bind:", 0) == 0;
      const std::string endpoint = bind ? e.substr(5) : e;
      if ((bind ? zmq_bind(socket_, endpoint.c_str()) : zmq_connect(socket_, endpoint.c_str())) != 0)
        throw Error(ErrorKind::kIo,
                    std::string("ingest: cannot ") + (bind ? "bind " : "connect ") + endpoint + ": " + zmq_reason());
    }
  } catch (...) {
    zmq_close(socket_);
    throw;
  }
}

std::string Ingest::endpoint() const { return last_endpoint(socket_); }

Ingest::~Ingest() { zmq_close(socket_); }

int Ingest::poll(int max_messages) {
  int count = 0;
  while (count < max_messages) {
    // Received into a buffer one byte larger than the limit: a longer message is truncated by
    // ZeroMQ but zmq_recv returns its full size, so it is recognised as oversized.
    const int n = zmq_recv(socket_, receive_buffer_.data(), receive_buffer_.size(), ZMQ_DONTWAIT);
    if (n < 0) break;
    ++count;
    ++counters_.received;
    // A multi-part message: only the first part is a kata message; drain the rest.
    int more = 0;
    size_t more_size = sizeof more;
    zmq_getsockopt(socket_, ZMQ_RCVMORE, &more, &more_size);
    bool multipart = false;
    while (more) {
      multipart = true;
      uint8_t sink;
      zmq_recv(socket_, &sink, 1, 0);
      zmq_getsockopt(socket_, ZMQ_RCVMORE, &more, &more_size);
    }
    if (multipart) {
      ++counters_.malformed[static_cast<int>(DecodeError::kUnknownIdentifier)];
      continue;
    }
    handle(receive_buffer_.data(), static_cast<size_t>(n));
  }
  return count;
}

void Ingest::handle(const void* data, size_t size) {
  uint64_t topic_stream = 0;
  if (shard_count_ > 1 && size >= kTopicBytes && parse_topic(static_cast<const uint8_t*>(data), &topic_stream) &&
      shard_of(topic_stream, shard_count_) != shard_index_) {
    ++counters_.other_shard;
    return;
  }
  const MessageKind kind = decoder_.decode(data, size);
  switch (kind) {
    case MessageKind::kNone:
      ++counters_.malformed[static_cast<int>(decoder_.error())];
      return;
    case MessageKind::kResult:
      ++counters_.other_kind;
      return;
    case MessageKind::kSkeleton: {
      SkeletonDefinition definition;
      try {
        definition = decoder_.skeleton();
      } catch (const Error&) {
        ++counters_.refused_skeletons;
        return;
      }
      Known& known = streams_[definition.stream_id];
      if (known.accepted && known.revision == definition.revision) {
        ++counters_.repeated_skeletons;
        return;
      }
      bool accepted = false;
      try {
        accepted = handlers_.on_skeleton ? handlers_.on_skeleton(definition) : true;
      } catch (const Error&) {
        accepted = false;
      }
      known.revision = definition.revision;
      known.joints = definition.skeleton.joint_count();
      known.any_frame = false;
      known.accepted = accepted;
      if (accepted) ++counters_.skeletons;
      else ++counters_.refused_skeletons;
      return;
    }
    case MessageKind::kFrame: {
      const FrameView& f = decoder_.frame();
      auto it = streams_.find(f.stream_id);
      if (it == streams_.end() || !it->second.accepted) {
        ++counters_.unknown_stream;
        return;
      }
      Known& known = it->second;
      if (f.joints != known.joints) {
        ++counters_.wrong_joint_count;
        return;
      }
      bool restarted = false;
      if (known.any_frame) {
        if (f.sequence == 0 && known.last_sequence > 0) {
          restarted = true;
          ++counters_.restarts;
        } else if (f.sequence <= known.last_sequence) {
          ++counters_.out_of_order;
          return;
        } else {
          counters_.sequence_gaps += f.sequence - known.last_sequence - 1;
        }
      }
      known.any_frame = true;
      known.last_sequence = f.sequence;
      ++counters_.frames;
      if (handlers_.on_frame) handlers_.on_frame(f, restarted);
      return;
    }
  }
}

}  // namespace kata::transport
