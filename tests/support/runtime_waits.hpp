// Bounded waits on a runtime's counters, for the live tests that feed it over sockets.
#pragma once

#include <chrono>
#include <cstdint>
#include <thread>

#include "runtime/runtime.hpp"

namespace kata::test {

// Waits until the runtime has received `n` ingest messages (its counters' snapshot lags by up to
// 50 ms), or `limit` passed; true when they came.
inline bool wait_received(const runtime::Runtime& runtime, uint64_t n,
                          std::chrono::milliseconds limit = std::chrono::seconds(20)) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (runtime.counters().ingest.received < n) {
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace kata::test
