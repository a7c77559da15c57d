// A bounded single-producer single-consumer ring of whole messages (variable sizes, copied in),
// for handing ingest messages from a transport's own thread (libnats' delivery thread) to the
// runtime's I/O thread, which owns the ingest table (runtime.hpp, Runtime::offer).
//
// Why a byte ring and not cells of the largest message: frames are ~1 KB and the limit is 1 MiB,
// so cells sized for the limit would cost a gigabyte for a useful depth. Each message takes an
// 8-byte header and its bytes rounded up to 8, contiguous; one that does not fit before the end
// of the buffer leaves a wrap marker and starts again at 0. The buffer is allocated once, at
// construction: push and pop never allocate, never block, never take a lock.
//
// Thread rules: push() on one thread at a time (the producer), front() / pop() / empty() on one
// thread at a time (the consumer). head_ is written by the producer only and tail_ by the consumer
// only; a release store of either publishes the bytes before it (acquire loads on the other side),
// which is all TSan needs to see.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>

namespace kata::transport {

class MessageRing {
 public:
  // capacity: bytes, rounded up to a power of two (at least 64).
  explicit MessageRing(size_t capacity) {
    size_t c = 64;
    while (c < capacity) c <<= 1;
    capacity_ = c;
    buffer_.reset(new uint8_t[c]);
  }
  MessageRing(const MessageRing&) = delete;
  MessageRing& operator=(const MessageRing&) = delete;

  size_t capacity() const { return capacity_; }
  // The largest message push() can ever take (one in an otherwise empty ring).
  size_t max_message() const { return capacity_ / 2 - kHeader; }

  // Copies one message in. False when there is no room now (the consumer fell behind) or it is
  // larger than max_message(): nothing is stored. [producer]
  bool push(const void* data, size_t size) {
    if (size > max_message()) return false;
    const size_t need = kHeader + round8(size);
    size_t head = head_.load(std::memory_order_relaxed);
    const size_t tail = tail_.load(std::memory_order_acquire);
    const size_t offset = head & (capacity_ - 1);
    const size_t to_end = capacity_ - offset;
    const size_t total = need <= to_end ? need : to_end + need;
    if (head - tail + total > capacity_) return false;
    if (need > to_end) {  // offsets are multiples of 8: the marker always fits
      write_header(offset, kWrap);
      head += to_end;
    }
    const size_t at = head & (capacity_ - 1);
    write_header(at, static_cast<uint32_t>(size));
    if (size > 0) std::memcpy(buffer_.get() + at + kHeader, data, size);
    head_.store(head + need, std::memory_order_release);
    return true;
  }

  // The oldest message, left in place until pop(): false when the ring is empty. [consumer]
  bool front(const uint8_t** data, size_t* size) {
    size_t tail = tail_.load(std::memory_order_relaxed);
    const size_t head = head_.load(std::memory_order_acquire);
    if (tail == head) return false;
    size_t offset = tail & (capacity_ - 1);
    uint32_t length = read_header(offset);
    if (length == kWrap) {  // the producer publishes a marker together with the message after it
      tail += capacity_ - offset;
      offset = 0;
      length = read_header(0);
    }
    *data = buffer_.get() + offset + kHeader;
    *size = length;
    next_tail_ = tail + kHeader + round8(length);
    return true;
  }
  // Frees the message front() returned. [consumer]
  void pop() { tail_.store(next_tail_, std::memory_order_release); }
  bool empty() const { return tail_.load(std::memory_order_relaxed) == head_.load(std::memory_order_acquire); }

 private:
  static constexpr size_t kHeader = 8;
  static constexpr uint32_t kWrap = 0xFFFFFFFFu;
  static size_t round8(size_t n) { return (n + 7) & ~size_t{7}; }
  void write_header(size_t offset, uint32_t length) { std::memcpy(buffer_.get() + offset, &length, sizeof length); }
  uint32_t read_header(size_t offset) const {
    uint32_t length;
    std::memcpy(&length, buffer_.get() + offset, sizeof length);
    return length;
  }

  size_t capacity_ = 0;
  std::unique_ptr<uint8_t[]> buffer_;
  alignas(64) std::atomic<size_t> head_{0};  // bytes ever pushed [producer]
  alignas(64) std::atomic<size_t> tail_{0};  // bytes ever popped [consumer]
  size_t next_tail_ = 0;                     // [consumer]
};

}  // namespace kata::transport
