// The ingest's refusal log (zmq_io.hpp, Ingest): who a sender is, and each refusal counted by
// cause and logged once per sender.
#include "transport/zmq_io.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <zmq.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "common/error.hpp"
#include "common/text.hpp"
#include "transport/zmq_internal.hpp"

namespace kata::transport {

using namespace detail;

std::string Ingest::describe(SenderToken sender) const {
  if (sender == kLocalSender) return "local";
  if (sender == kClosedConnection) return "(a connection closed since)";
  if (is_key_sender(sender)) {
    char text[32];
    std::snprintf(text, sizeof text, "key %016llx", static_cast<unsigned long long>(sender));
    return text;
  }
  int fd = static_cast<int>(sender & 0xffffffffu) - 1;
  if (sender & kNumberedConnection) {
    // The descriptor the connection holds (a scan: only a first refusal is described).
    fd = -1;
    for (const auto& [descriptor, c] : connections_)
      if (c.holder_open && numbered_sender(c.holder) == sender) fd = descriptor;
  }
  sockaddr_storage address{};
  socklen_t size = sizeof address;
  char text[INET6_ADDRSTRLEN + 16] = "connection";
  if (getpeername(fd, reinterpret_cast<sockaddr*>(&address), &size) == 0) {
    char host[INET6_ADDRSTRLEN] = "";
    if (address.ss_family == AF_INET) {
      const auto* a = reinterpret_cast<const sockaddr_in*>(&address);
      inet_ntop(AF_INET, &a->sin_addr, host, sizeof host);
      std::snprintf(text, sizeof text, "%s:%u", host, ntohs(a->sin_port));
    } else if (address.ss_family == AF_INET6) {
      const auto* a = reinterpret_cast<const sockaddr_in6*>(&address);
      inet_ntop(AF_INET6, &a->sin6_addr, host, sizeof host);
      std::snprintf(text, sizeof text, "[%s]:%u", host, ntohs(a->sin6_port));
    } else {
      std::snprintf(text, sizeof text, "local socket %d", fd);
    }
  }
  return text;
}

void Ingest::refused(SenderToken sender, TableVerdict cause, uint64_t stream_id, const std::string& reason) {
  const char* why = "";
  switch (cause) {
    case TableVerdict::kPracticeValues: ++counters_.practice_bad_values; why = "sends a practice setting that cannot be"; break;
    case TableVerdict::kPracticeOutsideClip: ++counters_.practice_outside_clip; why = "sends a practice setting outside the teacher clip"; break;
    case TableVerdict::kPracticeNoClip: ++counters_.practice_no_clip; why = "sends a practice setting for a stream without a clip teacher"; break;
    case TableVerdict::kPracticeQueueFull: ++counters_.practice_queue_full; why = "sends a practice setting its stream's queue had no room for"; break;
    case TableVerdict::kNotOwner: ++counters_.not_owner; why = "sends for a stream another sender owns"; break;
    case TableVerdict::kLimit: ++counters_.refused_limit; why = "defines streams beyond a limit"; break;
    case TableVerdict::kUnknownStream: ++counters_.unknown_stream; return;
    case TableVerdict::kWrongJoints: ++counters_.wrong_joint_count; return;
    case TableVerdict::kOutOfOrder: ++counters_.out_of_order; return;
    case TableVerdict::kOutOfWindow: ++counters_.out_of_window; why = "sends sequence numbers far outside the window"; break;
    case TableVerdict::kStale: {
      ++counters_.stale;
      // A backlog after an outage is dropped without a word; a stream that stays stale with its
      // frames ever later is a source to fix (its clock, or its pace), and said once.
      double growth = 0.0;
      int64_t age_ns = 0;
      if (!log_refusals_ || !table_.stale_run_to_explain(stream_id, &growth, &age_ns)) return;
      char text[400];
      if (growth < 1.0)
        std::snprintf(text, sizeof text,
                      "%d in a row dropped as stale, the last %.2f s old (max_frame_age_ms %lld), their age growing "
                      "%.2f s per second: a capture clock at %.2fx this host's, or a source falling behind (a replay "
                      "slower than recorded? kata send --live-clock)",
                      IngestTable::kStaleRunToExplain, static_cast<double>(age_ns) * 1e-9,
                      static_cast<long long>(table_.limits().max_frame_age_ns / 1'000'000), growth, 1.0 - growth);
      else
        std::snprintf(text, sizeof text,
                      "%d in a row dropped as stale, the last %.2f s old (max_frame_age_ms %lld): its capture times "
                      "do not advance with this host's clock (a unit other than nanoseconds?)",
                      IngestTable::kStaleRunToExplain, static_cast<double>(age_ns) * 1e-9,
                      static_cast<long long>(table_.limits().max_frame_age_ns / 1'000'000));
      if (table_.first_refusal(sender, cause))
        std::fprintf(stderr, "\nkata ingest: sender %s sends frames ever later behind their capture times (stream %llu: %s); "
                     "counted, not logged again\n", describe(sender).c_str(), static_cast<unsigned long long>(stream_id), text);
      return;
    }
    case TableVerdict::kAccepted:
    case TableVerdict::kRepeated: return;
  }
  if (log_refusals_ && table_.first_refusal(sender, cause))
    std::fprintf(stderr, "\nkata ingest: sender %s %s (stream %llu%s%s); counted, not logged again\n",
                 describe(sender).c_str(), why, static_cast<unsigned long long>(stream_id), reason.empty() ? "" : ": ",
                 bounded(reason).c_str());
}

}  // namespace kata::transport
