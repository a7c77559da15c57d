// The ingest's reading of messages (zmq_io.hpp, Ingest): poll, housekeeping, each message by kind.
// The rest of the ZeroMQ side: zmq_socket.cpp (context, security), publisher.cpp, ingest_connections.cpp,
// ingest_refusals.cpp.
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

uint64_t IngestCounters::malformed_total() const {
  uint64_t sum = 0;
  for (uint64_t m : malformed) sum += m;
  return sum;
}

uint64_t IngestCounters::dropped_total() const {
  return malformed_total() + refused_skeletons + unknown_stream + wrong_joint_count + out_of_order + other_kind +
         not_owner + refused_limit + out_of_window + stale + practice_bad_values + practice_outside_clip +
         practice_no_clip + practice_queue_full;
}

void Ingest::housekeeping(int64_t now_ns) {
  if (now_ns < 0) now_ns = steady_now_ns();
  read_connection_events();
  if (now_ns >= next_expiry_ns_) {
    next_expiry_ns_ = now_ns + 1'000'000'000;  // idleness is judged once a second
    expired_.clear();
    table_.expire(now_ns, &expired_);
    for (uint64_t id : expired_) {
      ++counters_.expired;
      if (handlers_.on_close) handlers_.on_close(id);
    }
  }
}

void Ingest::reset() {
  table_ = IngestTable(table_.limits());
  counters_ = IngestCounters{};
  connections_.clear();
  open_connections_ = 0;
  next_expiry_ns_ = 0;
  logged_definition_refusals_.clear();
  handshaking_.clear();
}

int Ingest::poll(int max_messages) {
  housekeeping();
  if (socket_ == nullptr) return 0;  // kDirect: receive() takes its messages
  int count = 0;
  zmq_msg_t message;
  zmq_msg_init(&message);
  while (count < max_messages) {
    // ZeroMQ refuses a message above ZMQ_MAXMSGSIZE before buffering it (and drops its sender).
    if (zmq_msg_recv(&message, socket_, ZMQ_DONTWAIT) < 0) break;
    ++count;
    ++counters_.received;
    // Who sent it: the CURVE key the ZAP handler vouched for, or the connection the ZAP handler
    // numbered (a keyless ingest), else (a CURVE client) the connection's descriptor.
    SenderToken sender = kLocalSender;
    if (const char* user = zmq_msg_gets(&message, "User-Id"); user && *user) {
      sender = numbered_ ? numbered_connection(zmq_msg_get(&message, ZMQ_SRCFD), parse_number(user)) : key_sender(user);
    } else {
      const int fd = zmq_msg_get(&message, ZMQ_SRCFD);
      if (fd >= 0) sender = connection_of(fd);
    }
    // A multi-part message: only the first part is a kata message; drain the rest.
    bool multipart = zmq_msg_more(&message) != 0;
    if (multipart) {
      zmq_msg_t rest;
      zmq_msg_init(&rest);
      int more = 1;
      while (more) {
        if (zmq_msg_recv(&rest, socket_, 0) < 0) break;
        more = zmq_msg_more(&rest);
      }
      zmq_msg_close(&rest);
      ++counters_.malformed[static_cast<int>(DecodeError::kUnknownIdentifier)];
      continue;
    }
    handle(zmq_msg_data(&message), zmq_msg_size(&message), sender, steady_now_ns());
  }
  zmq_msg_close(&message);
  return count;
}

void Ingest::receive(const void* data, size_t size) {
  ++counters_.received;
  handle(data, size, kLocalSender, steady_now_ns());
}

void Ingest::handle_practice(SenderToken sender, int64_t now_ns) {
  const PracticeSetting p = decoder_.practice();
  const TableVerdict v = table_.judge_practice(sender, p.stream_id, p.revision);
  if (v != TableVerdict::kAccepted && v != TableVerdict::kRepeated) return refused(sender, v, p.stream_id);
  // Values no clip can hold are the verifier's to refuse, with the reason; the clip's bounds are
  // the receiver's (it knows the stream's teacher).
  char why[192];
  if (practice_values_problem(p, why, sizeof why)) return refused(sender, TableVerdict::kPracticeValues, p.stream_id, why);
  if (v == TableVerdict::kRepeated) {
    ++counters_.repeated_practices;
    return;
  }
  std::string reason;
  const TableVerdict taken = handlers_.on_practice ? handlers_.on_practice(p, &reason) : TableVerdict::kPracticeNoClip;
  if (taken != TableVerdict::kAccepted) return refused(sender, taken, p.stream_id, reason);
  table_.commit_practice(p.stream_id, p.revision, now_ns);
  ++counters_.practices;
}

bool Ingest::admit_frame(SenderToken sender, uint64_t stream_id, uint64_t sequence, int64_t capture_ns, int joints,
                         int64_t now_ns, bool* restarted) {
  uint64_t gap = 0;
  int64_t age_ns = -1;
  const TableVerdict v =
      table_.judge_frame(sender, stream_id, sequence, capture_ns, joints, now_ns, restarted, &gap, &age_ns);
  if (v != TableVerdict::kAccepted) {
    if (v != TableVerdict::kUnknownStream && handlers_.on_refused_frame) handlers_.on_refused_frame(stream_id, v);
    refused(sender, v, stream_id);
    return false;
  }
  if (*restarted) ++counters_.restarts;
  counters_.sequence_gaps += gap;
  if (age_ns >= 0) {
    const int bucket = age_ns < 1 ? 0 : static_cast<int>(8.0 * std::log2(static_cast<double>(age_ns)));
    ++counters_.age_histogram[std::min(std::max(bucket, 0), IngestCounters::kAgeBuckets - 1)];
  }
  ++counters_.frames;
  return true;
}

void Ingest::handle_frame(SenderToken sender, int64_t now_ns) {
  const FrameView& f = decoder_.frame();
  bool restarted = false;
  if (!admit_frame(sender, f.stream_id, f.sequence, f.capture_ns, f.joints, now_ns, &restarted)) return;
  if (handlers_.on_frame) handlers_.on_frame(f, restarted);
}

void Ingest::handle_batch(SenderToken sender, int64_t now_ns) {
  // Each frame as if it had come alone, in the batch's order, from the batch's sender: its shard,
  // its own checks (a refused one is counted by cause and the next goes on), then the table's rules.
  const size_t n = decoder_.batch_size();
  ++counters_.batches;
  counters_.batch_frames += n;
  for (size_t i = 0; i < n; ++i) {
    if (shard_count_ > 1 && shard_of(decoder_.batch_stream_id(i), shard_count_) != shard_index_) {
      ++counters_.other_shard;
      continue;
    }
    const DecodeError e = decoder_.batch_frame(i);
    if (e != DecodeError::kNone) {
      ++counters_.malformed[static_cast<int>(e)];
      continue;
    }
    handle_frame(sender, now_ns);
  }
}

void Ingest::handle(const void* data, size_t size, SenderToken sender, int64_t now_ns) {
  if (now_ns < 0) now_ns = steady_now_ns();
  uint64_t topic_stream = 0;
  // A batch's frames belong to many streams: each is judged by its own shard below.
  if (shard_count_ > 1 && size >= kTopicBytes && parse_topic(static_cast<const uint8_t*>(data), &topic_stream) &&
      topic_stream != kBatchStreamId && shard_of(topic_stream, shard_count_) != shard_index_) {
    ++counters_.other_shard;
    return;
  }
  if (is_people_frame(data, size)) return handle_people(data, size, sender, now_ns);
  const MessageKind kind = decoder_.decode(data, size);
  switch (kind) {
    case MessageKind::kNone:
      ++counters_.malformed[static_cast<int>(decoder_.error())];
      return;
    case MessageKind::kResult:
    case MessageKind::kStats:
    case MessageKind::kRepetition:
      ++counters_.other_kind;
      return;
    case MessageKind::kPractice:
      return handle_practice(sender, now_ns);
    case MessageKind::kSkeleton: {
      const uint64_t id = decoder_.stream_id();
      // Ownership and limits first: a refused definition allocates nothing.
      if (decoder_.skeleton_closed()) {
        const TableVerdict v = table_.judge_close(sender, id);
        if (v != TableVerdict::kAccepted) return refused(sender, v, id);
        table_.forget(id);
        ++counters_.closes;
        if (handlers_.on_close) handlers_.on_close(id);
        return;
      }
      bool is_new = false;
      const TableVerdict v = table_.judge_definition(sender, id, decoder_.skeleton_revision(), &is_new);
      if (v == TableVerdict::kRepeated) {
        ++counters_.repeated_skeletons;
        return;
      }
      if (v != TableVerdict::kAccepted) return refused(sender, v, id);
      SkeletonDefinition definition;
      try {
        definition = decoder_.skeleton();
      } catch (const Error&) {
        ++counters_.refused_skeletons;
        return;
      }
      definition.refused.clear();  // a receiver's field: a source's is ignored
      bool accepted = false;
      std::string why;
      try {
        if (is_new) accepted = handlers_.on_skeleton ? handlers_.on_skeleton(definition) : true;
        else accepted = handlers_.on_revision ? handlers_.on_revision(definition) : false;
      } catch (const Error& e) {
        accepted = false;
        why = e.what();
        // Why, once per stream (the first 64 streams): a skeleton that does not fit its layout
        // would otherwise show only as dropped frames.
        if (log_refusals_ && logged_definition_refusals_.size() < 64 &&
            std::find(logged_definition_refusals_.begin(), logged_definition_refusals_.end(), id) ==
                logged_definition_refusals_.end()) {
          logged_definition_refusals_.push_back(id);
          std::fprintf(stderr,
                       "\nkata ingest: stream %llu's skeleton definition (layout '%s') refused: %s; its frames are "
                       "dropped (counted as unknown stream) until a definition is accepted; not logged again\n",
                       static_cast<unsigned long long>(id), bounded(definition.layout).c_str(), e.what());
        }
      }
      if (!accepted) {
        ++counters_.refused_skeletons;
        if (!why.empty() && handlers_.on_refused_definition) handlers_.on_refused_definition(definition, why);
        return;
      }
      table_.commit_definition(sender, id, definition.revision, definition.skeleton.joint_count(), now_ns);
      ++counters_.skeletons;
      if (!is_new) ++counters_.revisions;
      return;
    }
    case MessageKind::kFrame:
      return handle_frame(sender, now_ns);
    case MessageKind::kFrameBatch:
      return handle_batch(sender, now_ns);
  }
}

}  // namespace kata::transport
