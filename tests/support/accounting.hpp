// Nothing lost, and proven so: the check at the end of every live test that each frame
// handed to a runtime became a result the test received or one count of one drop cause, per
// stream:
//
//   frames sent = results received + sum over runtime::kDropCauses + gaps the consumer counted
//
// and, so that a missing frame is named by where it went missing, each stage's own balance:
//
//   taken:     sent      = frames_in + queue_full + stopped + stale + unauthorised
//                          + out_of_sequence + wrong_joints (frames of the stream the ingest refused)
//   computed:  frames_in = results + pipeline_dropped + refused
//   handed on: results   = delivered + result_queue_full    (delivered: published + send_failed
//                                                            with a publisher, else what sinks saw)
//   received:  published = received + consumer gaps
//
// Call it after stop() (a stream's last results come from its flush) and after every pushing
// thread was joined. Sources of "sent": the push() calls that were answered kOk, kState (queue
// full) or kStopped, or the frames a source sent over ZeroMQ. The Python twin for the CLI tests
// (kata serve's --counters file) is tests/support/accounting.py.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <sstream>
#include <string>

#include "runtime/runtime.hpp"

namespace kata::test {

struct StreamTally {
  uint64_t sent = 0;      // frames the test handed over for this stream
  uint64_t received = 0;  // results of this stream the test received (subscriber or sink)
  uint64_t gaps = 0;      // results the consumer counted missing (result_sequence gaps), if it counts
};

enum class Delivery {
  kPublished,  // results go out on the runtime's publisher; received = what a subscriber read
  kSinks,      // no publisher: received = what an in-process sink saw
};

// The frames of one stream not accounted for, with every count named; empty when it balances.
inline std::string unaccounted(uint64_t stream_id, const StreamTally& t, const runtime::StreamCounters& c,
                               Delivery delivery) {
  uint64_t dropped = 0;
  std::ostringstream causes;
  for (const runtime::DropCause& cause : runtime::kDropCauses) {
    dropped += c.*cause.count;
    causes << " + " << cause.name << " " << c.*cause.count;
  }
  if (t.sent == t.received + dropped + t.gaps) return "";
  const auto diff = [](uint64_t a, uint64_t b) {
    return static_cast<long long>(a) - static_cast<long long>(b);
  };
  std::ostringstream out;
  out << "stream " << stream_id << ": " << diff(t.sent, t.received + dropped + t.gaps)
      << " frame(s) unaccounted for: sent " << t.sent << " != received " << t.received << causes.str()
      << " + consumer gaps " << t.gaps << ";";
  const uint64_t taken =
      c.frames_in + c.queue_full + c.stopped + c.stale + c.unauthorised + c.out_of_sequence + c.wrong_joints;
  const uint64_t delivered = delivery == Delivery::kPublished ? c.published + c.send_failed : t.received;
  if (t.sent != taken)
    out << " lost before a worker queue took it (sent " << t.sent << ", taken or refused " << taken << ")";
  else if (c.frames_in != c.results + c.pipeline_dropped + c.refused)
    out << " lost in the worker: " << diff(c.frames_in, c.results + c.pipeline_dropped + c.refused)
        << " queued frame(s) neither computed nor refused";
  else if (delivery == Delivery::kPublished && c.results != delivered + c.result_queue_full)
    out << " lost between the worker and the I/O thread: "
        << diff(c.results, delivered + c.result_queue_full) << " result(s) neither published nor dropped";
  else if (delivery == Delivery::kSinks && c.results != t.received + c.result_queue_full)
    out << " lost between the worker and the sinks: " << diff(c.results, t.received + c.result_queue_full)
        << " result(s) neither handed to a sink nor dropped";
  else
    out << " lost after publishing: published " << c.published << ", received " << t.received
        << ", consumer gaps " << t.gaps;
  return out.str();
}

// Every stream of `tallies` balances (and the runtime holds no stream the test did not expect
// when `every_stream` is set). A gtest assertion: EXPECT_TRUE(every_frame_accounted(...)).
inline ::testing::AssertionResult every_frame_accounted(const runtime::Runtime& runtime,
                                                        const std::map<uint64_t, StreamTally>& tallies,
                                                        Delivery delivery = Delivery::kPublished) {
  std::string failures;
  for (const auto& [id, tally] : tallies) {
    const std::optional<runtime::StreamCounters> c = runtime.stream_counters(id);
    if (!c) {
      failures += "stream " + std::to_string(id) + ": not open in the runtime\n";
      continue;
    }
    const std::string why = unaccounted(id, tally, *c, delivery);
    if (!why.empty()) failures += why + "\n";
  }
  if (failures.empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << failures;
}

}  // namespace kata::test
