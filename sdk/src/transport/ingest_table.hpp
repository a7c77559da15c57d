// The ingest's table of streams and senders: who owns which stream, what its last sequence was,
// how old its frames are. Pure bookkeeping (no socket, no clock of its own: the caller passes the
// arrival time), so the rules are tested and fuzzed without ZeroMQ.
//
// The rules (docs/runtime.md, "Who may send what"):
// - A stream belongs to the sender that defined it: its CURVE key when the ingest authenticates,
//   otherwise its connection. Another sender's definitions, revisions, closes and frames for it
//   are refused (counted as not_owner, logged once per sender and cause). When an unauthenticated
//   owner's connection closes, its streams become orphans: the next definition claims them (a
//   source that reconnects gets its streams back with a restart).
// - A new revision from the owner restarts the stream with it (schemas/skeleton.fbs).
// - Limits are judged before anything is allocated: streams per sender and in all
//   (refused_limit). A refused definition leaves nothing behind.
// - Sequences are judged against a window: a frame more than `sequence_window` after the last
//   one is dropped (out_of_window) unless `kResync` frames in a row agree on the new numbering
//   (a source that jumped: counted as a restart); 0 after later ones is a restart; anything
//   else not after the last one is out of order. A gap adds at most the window to the counter.
// - A frame older than max_frame_age by its capture time, against the stream's clock, is stale
//   (dropped, counted). The stream's clock: the smallest arrival - capture offset seen so far (the
//   quickest delivery), reset by a restart or revision; a frame's age is its offset beyond that.
// - A practice setting (schemas/practice.fbs) is the owner's too; the revision in force again is
//   a re-send (kRepeated). Every accepted definition forgets it, so that a reopened stream takes
//   the setting again.
// - Idle streams expire after idle_seconds without a frame, definition or practice setting from
//   their owner.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace kata::transport {

// Who sent a message: the CURVE key's hash (bit 63 set), or a connection: on a keyless ingest its
// number (bit 62 set; the context's ZAP handler numbers every connection, curve.hpp), on a CURVE
// client ingest (no User-Id) its descriptor and that descriptor's generation, bumped when the
// connection closes. 0: a message without a connection (handed in directly, inproc).
// kClosedConnection: a message read after its connection's close was seen (it waited in the
// socket's queue): it cannot own a stream (a stream it defines is an orphan at once, claimed by
// the next definition), since its connection will never send again.
using SenderToken = uint64_t;
inline constexpr SenderToken kLocalSender = 0;
inline constexpr SenderToken kClosedConnection = ~0ULL;
inline SenderToken connection_sender(int fd, uint32_t generation) {
  return (static_cast<uint64_t>(generation) << 32) | static_cast<uint32_t>(fd + 1);
}
inline constexpr SenderToken kNumberedConnection = 1ULL << 62;
inline SenderToken numbered_sender(uint64_t number) { return kNumberedConnection | (number & (kNumberedConnection - 1)); }
SenderToken key_sender(const char* user_id);  // FNV-1a 64 of the key text, bit 63 set
inline bool is_key_sender(SenderToken t) { return (t >> 63) != 0 && t != kClosedConnection; }

struct IngestLimits {
  uint32_t max_streams = 1024;           // streams the ingest holds in all
  uint32_t max_streams_per_sender = 64;  // streams one sender may define
  uint64_t sequence_window = 1 << 16;    // largest forward jump in sequence accepted as a gap
  int64_t max_frame_age_ns = 250'000'000;  // stale beyond this age (0: never stale)
  int64_t idle_ns = 300'000'000'000;       // a stream without traffic this long expires (0: never)
};

// Why a message was refused by the table (each is one IngestCounters field).
enum class TableVerdict {
  kAccepted,      // a new stream / revision / frame handed on
  kRepeated,      // a periodic re-send of the revision in force (not handed on, not a drop)
  kNotOwner,      // another sender's stream
  kLimit,         // beyond a streams limit
  kUnknownStream, // a frame before its definition (or after its close)
  kWrongJoints,   // joint count differs from the definition
  kOutOfOrder,    // not after the last sequence
  kOutOfWindow,   // too far after the last sequence
  kStale,         // older than max_frame_age
  // A practice setting refused (schemas/practice.fbs), judged by the ingest and its receiver:
  kPracticeValues,       // a time not finite or negative, an empty loop, a start and a loop
  kPracticeOutsideClip,  // a time outside the stream's teacher clip (or a loop within one frame)
  kPracticeNoClip,       // the stream has no clip teacher to practise on
  kPracticeQueueFull,    // the stream's worker queue was full (the setting is lost: send it again)
};

class IngestTable {
 public:
  explicit IngestTable(IngestLimits limits = {}) : limits_(limits) {}

  // A definition of stream `id` (revision, joints) from `sender`: what to do with it. For
  // kAccepted, *is_new says whether it opens a stream (else it is a new revision: a restart).
  // Nothing is stored until commit_definition: the caller asks the receiver first.
  TableVerdict judge_definition(SenderToken sender, uint64_t id, uint32_t revision, bool* is_new) const;
  // Stores an accepted definition (the receiver took it) and restarts the stream's numbering.
  void commit_definition(SenderToken sender, uint64_t id, uint32_t revision, int joints, int64_t now_ns);
  // A close of stream `id` from `sender`: kAccepted (then forget(id)), kNotOwner or kUnknownStream.
  TableVerdict judge_close(SenderToken sender, uint64_t id) const;
  void forget(uint64_t id);

  // A practice setting of stream `id` from `sender`: kAccepted (hand it on, then
  // commit_practice), kRepeated (the revision in force), kNotOwner or kUnknownStream.
  TableVerdict judge_practice(SenderToken sender, uint64_t id, uint32_t revision) const;
  // Stores the revision the receiver applied (the owner's activity, as a frame is).
  void commit_practice(uint64_t id, uint32_t revision, int64_t now_ns);

  // A frame: kAccepted with *restarted (the receiver restarts the stream's kinetics), *gap
  // (frames missing before it, at most the window) and *age_ns (its age by the stream's clock,
  // -1 when unknown), or the reason it is dropped.
  TableVerdict judge_frame(SenderToken sender, uint64_t id, uint64_t sequence, int64_t capture_ns, int joints,
                           int64_t now_ns, bool* restarted, uint64_t* gap, int64_t* age_ns);

  // The connection behind `sender` closed: its streams become orphans (claimed by the next
  // definition). Key senders keep theirs.
  void sender_gone(SenderToken sender);
  // Streams idle past the limit at now_ns, removed from the table (the caller closes them).
  void expire(int64_t now_ns, std::vector<uint64_t>* expired);

  // First refusal of `cause` for this sender? (log once per sender and cause).
  bool first_refusal(SenderToken sender, TableVerdict cause);

  // A stream whose every frame has been stale for kStaleRunToExplain frames in a row, with their
  // age growing: not a backlog after an outage (its queued frames arrive together, ages falling,
  // then fresh ones) but a source whose capture clock runs slower than this host's, or that falls
  // further behind every frame. True once per run, when the run reaches that length, with how fast
  // the age grew (seconds of age per second of arrival) and the last frame's age.
  static constexpr int kStaleRunToExplain = 60;
  bool stale_run_to_explain(uint64_t id, double* age_growth, int64_t* age_ns) const;

  size_t streams() const { return streams_.size(); }
  bool known(uint64_t id) const { return streams_.count(id) != 0; }
  const IngestLimits& limits() const { return limits_; }

 private:
  // An orphan's owner is the closed connection: its late messages still reach it (in order),
  // and any sender's definition claims it.
  static constexpr SenderToken kNoOwner = kClosedConnection;
  static constexpr int kResync = 3;
  struct Stream {
    SenderToken owner = kNoOwner;
    uint32_t revision = 0;
    int joints = 0;
    bool any_frame = false;
    bool restart_next = false;       // a revision: the next frame restarts the stream
    uint64_t last_sequence = 0;
    uint64_t candidate = 0;          // a new numbering beyond the window, being confirmed
    int candidate_run = 0;
    bool has_offset = false;
    int64_t min_offset_ns = 0;       // smallest arrival - capture
    int stale_run = 0;               // frames in a row judged stale (0 after an accepted one)
    int64_t stale_run_first_ns = 0;  // the run's first frame: its arrival and age
    int64_t stale_run_first_age = 0;
    int64_t stale_run_last_age = 0;
    int64_t stale_run_last_ns = 0;
    int64_t last_activity_ns = 0;
    bool has_practice = false;       // a practice setting was applied since the last definition
    uint32_t practice_revision = 0;  // its revision
  };
  struct Sender {
    uint32_t streams = 0;
    uint32_t logged = 0;  // bit per TableVerdict already logged
  };
  IngestLimits limits_;
  std::unordered_map<uint64_t, Stream> streams_;
  std::unordered_map<SenderToken, Sender> senders_;
};

}  // namespace kata::transport
