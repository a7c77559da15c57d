// The tests' one ZeroMQ subscriber: a SUB socket to a runtime's publisher, and the next message
// within a time limit. Header-only over libzmq (no kata library), so the public-ABI tests, which
// link only libkata, use it too; each test decodes what it receives its own way (the transport
// Decoder inside, kata_message_read_result through the C ABI). One per thread: ZeroMQ sockets are
// not thread-safe.
#pragma once

#include <zmq.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace kata::test {

class ZmqSubscriber {
 public:
  // Connects to `endpoint`, subscribed to `topic` (16 lowercase hex digits: one stream; "": every
  // message), with ZMQ_LINGER 0 and ZMQ_RCVHWM receive_hwm (messages queued before the test reads).
  ZmqSubscriber(void* context, const std::string& endpoint, int receive_hwm = 100000, const std::string& topic = "",
                size_t buffer_bytes = 1 << 20)
      : socket_(zmq_socket(context, ZMQ_SUB)), buffer_(buffer_bytes) {
    int linger = 0;
    zmq_setsockopt(socket_, ZMQ_LINGER, &linger, sizeof linger);
    zmq_setsockopt(socket_, ZMQ_RCVHWM, &receive_hwm, sizeof receive_hwm);
    zmq_setsockopt(socket_, ZMQ_SUBSCRIBE, topic.data(), topic.size());
    connected_ = zmq_connect(socket_, endpoint.c_str()) == 0;
  }
  ~ZmqSubscriber() { zmq_close(socket_); }
  ZmqSubscriber(const ZmqSubscriber&) = delete;
  ZmqSubscriber& operator=(const ZmqSubscriber&) = delete;

  bool connected() const { return connected_; }
  // The next message within timeout_ms into data(): its size (cut to the buffer's), or -1 when none
  // came in time.
  int receive(int timeout_ms) {
    zmq_pollitem_t item{socket_, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&item, 1, timeout_ms) <= 0) return -1;
    const int n = zmq_recv(socket_, buffer_.data(), buffer_.size(), 0);
    return n < 0 ? -1 : std::min(n, static_cast<int>(buffer_.size()));
  }
  // The next message within timeout_ms, decoded by `decoder` (a transport::Decoder: its decode()
  // returns the message kind); the kind's default value (kNone) when none came in time.
  template <class Decoder>
  auto next(Decoder& decoder, int timeout_ms) -> decltype(decoder.decode(nullptr, 0)) {
    const int n = receive(timeout_ms);
    if (n < 0) return {};
    return decoder.decode(buffer_.data(), static_cast<size_t>(n));
  }
  const uint8_t* data() const { return buffer_.data(); }
  void* socket() const { return socket_; }

 private:
  void* socket_;
  std::vector<uint8_t> buffer_;
  bool connected_ = false;
};

}  // namespace kata::test
