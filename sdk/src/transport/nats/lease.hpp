// Which shard holds which partition: leases in a replicated JetStream key-value bucket.
//
// NATS 2.9 assigns no partition to exactly one consumer, so shards agree among themselves through
// one KV bucket (R3 on a 3-server cluster):
//   m.<member>     a shard's membership, rewritten every renew_ms.
//   p.<partition>  the lease of a partition: its value is the holder's member name (empty: given
//                  back). Claimed with create (refused while a value exists) or update-by-revision
//                  of a given-back or stale value, renewed with update-by-revision every renew_ms
//                  (refused once another claim was made), given back with update-by-revision to
//                  an empty value.
// Each shard watches the whole bucket with one long-lived KV watcher (one JetStream consumer),
// drained every renew_ms / 2 (writes: every renew_ms), and notes, per key, when it first saw the
// key's current revision (its own steady clock). The watcher must deliver the shard's own
// membership write of the previous tick, or it is dropped and made anew (with every observation).
// A key whose revision has not changed for ttl_ms of that shard's observation is stale: a stale
// member is gone, a stale lease may be taken over. Each shard wants the partitions rendezvous
// hashing over the live members gives them (partition.hpp): it claims those free or stale and
// gives back those another live member should hold, so one shard joining or leaving moves only the
// partitions it wins or held. A partition is given back only to a member seen writing during this
// observation (its revision moved on): a fresh watcher also shows the last membership of a shard
// that died long ago, live-looking for ttl_ms, and giving it partitions would move them twice.
//
// Staleness is judged by observation, not by the servers' clocks, and a write or read that fails
// (no stream leader, a server lost) restarts every observation: a holder that could not renew while
// the bucket could not be reached is not judged stale for it.
//
// No two holders at once. A renewal sent at the holder's time t0 and accepted is written no
// earlier than t0, so any other shard first sees that revision no earlier than t0 and may take the
// lease over (by that revision) no earlier than t0 + ttl_ms. The holder publishes for the
// partition until valid_until = t0 + ttl_ms - guard_ms and then pauses unless a later renewal
// succeeded; a renewal by revision that succeeds after a pause proves nobody took it over, so it
// resumes, ownership unchanged. A renewal the servers refuse (taken over) loses it at once. Each
// tenure is named by its epoch, the KV revision of its claim: a later tenure of a partition always
// has a larger epoch, so results carry (owner, epoch) and subscribers drop a stream's results of an
// older epoch than one already seen (results.hpp). Assumes the shards' clocks advance at the same
// rate within guard_ms per ttl_ms (steady clocks: a stepped wall clock changes nothing).
//
// Through an election of the bucket's leader (its server lost: 4-9 s in NATS 2.9, raft's election
// timeout) the holders keep publishing, ownership unchanged: no claim can land while no leader
// exists, and every claimer's observation restarts with its first write refused. The proof that
// no leader exists: a write to the bucket answered "no responders" (no server has the leader's
// subscription) by the servers of a majority of its replicas, each asked on a connection of its
// own (the witnesses: one per configured server URL, pinned to it), each of those servers a
// replica (the bucket on every server: R3 on three). A leader needs a majority of replicas to
// commit and reaches them over the same routes that carry its subscription, so none can commit a
// claim then. Such proofs at every tick for at least renew_ms (from s0 to s) mean every other shard
// (writing its membership every renew_ms) had a write refused at some w >= s - renew_ms, so its
// observation began after w and it may claim no earlier than s - renew_ms + ttl_ms: the holder
// publishes until s - renew_ms + ttl_ms - guard_ms (kElection), continuing its tenure only while
// it has not lapsed. A server that is cut off alone answers "no responders" too, but it is one
// server, not a majority: its holders pause as before.
//
// The bucket's own TTL (MaxAge) only collects the keys of shards long gone (bucket_ttl_ms >= ttl_ms).
//
// Thread rules: one lease thread does all KV work and calls the handler; may_publish(), held(),
// members(), counters() and pauses() may be called from any thread (may_publish is lock-free).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "transport/nats/connection.hpp"
#include "transport/nats/partition.hpp"

typedef struct __kvStore kvStore;
typedef struct __kvWatcher kvWatcher;

namespace kata::transport::nats {

struct LeaseOptions {
  std::string bucket = "kata_leases";  // [A-Za-z0-9_-]
  std::string member;                  // this shard's name, unique in the cluster (valid_member_name)
  uint32_t partitions = kDefaultPartitions;
  // The bucket is created with these when missing (replicas: 3 on a 3-server cluster; memory:
  // leases need not survive a restart of every server). An existing bucket must have this TTL.
  int replicas = 3;
  bool memory_storage = true;
  // Lease lifetime, renewal period, and the margin kept before a lease could be taken over
  // (milliseconds). A killed shard's partitions are held again after about ttl_ms + renew_ms / 2; a
  // holder that cannot renew publishes until ttl_ms - guard_ms after its last renewal.
  int64_t ttl_ms = 3000;
  int64_t renew_ms = 500;
  int64_t guard_ms = 750;
  // The bucket's MaxAge when this shard creates it: forgets the keys of shards long gone.
  int64_t bucket_ttl_ms = 60000;
  // Keep publishing through an election of the bucket's leader (above), when witnesses are given
  // and the bucket has 3 or more replicas; false: pause once a lease cannot be renewed.
  bool through_elections = true;
};

// The options' problem (a bad member or bucket name, guard_ms not within ttl_ms, renewals too
// rare to keep a lease), or empty.
std::string lease_options_problem(const LeaseOptions& options);

struct LeaseEvent {
  enum class Kind {
    kAcquired,  // the partition is this shard's from now (epoch: the claim's revision)
    kExtended,  // renewed: valid_until_ns moves on (reported before it is used)
    kPaused,    // valid_until passed without a renewal (the bucket out of reach): not published now
    kResumed,   // a renewal succeeded after a pause: the same tenure goes on
    kReleased,  // given back to the member that should hold it (publishing stopped first)
    kLost,      // the servers refused a renewal: another shard took it over after it went stale
    kElection,  // valid_until moves on without a renewal: the bucket has no leader, so no claim can land
  };
  Kind kind;
  uint32_t partition;
  uint64_t epoch;
  int64_t at_ns;           // steady clock, when the lease thread saw it
  int64_t valid_until_ns;  // steady clock; 0 for kReleased, kLost and kPaused
};
const char* lease_event_name(LeaseEvent::Kind kind);

struct LeaseCounters {
  uint64_t acquired = 0, released = 0, lost = 0, paused = 0, resumed = 0;
  uint64_t claims_refused = 0;      // a claim lost a race (another shard claimed first)
  uint64_t takeovers = 0;           // claims of a stale lease (its holder stopped renewing)
  uint64_t renewals = 0, renewals_failed = 0;
  uint64_t reads_failed = 0;        // bucket reads that failed (every observation restarts)
  uint64_t leaderless_proofs = 0;   // looks at the bucket that proved it had no leader (election)
};

// How long one partition went without this shard publishing for it, and why, since the shard began.
struct PartitionPauses {
  uint32_t partition = 0;
  uint64_t lapsed = 0;       // paused: renewals failed and no election was proven (cut off, or slow)
  int64_t lapsed_ns = 0;     //   for this long in all (a pause still going on counts up to now)
  uint64_t elections = 0;    // published through an election of the bucket's leader (no pause)
  int64_t election_ns = 0;   //   for this long beyond the last renewal's validity
  uint64_t taken_over = 0;   // moved here from a holder that stopped renewing (it died, or was cut off)
  int64_t taken_over_ns = 0; //   the partition had no holder for about this long before (as seen here)
  uint64_t handed_over = 0;  // moved here, given back by its holder (a rebalance: a shard joined or left)
  int64_t handed_over_ns = 0;
  uint64_t moved_out = 0;    // given back (rebalance, stop) or lost (taken over)
};

// For an operator: each partition's pauses and why, one clause each ("p12: paused 1x 0.8 s (lease
// lapsed ...)", "p3: taken over 1x after 3.2 s without a holder", "p5: handed over 1x after 0.1
// s", "p7: published through 1 election for 5.1 s (no pause)"), "; "-separated; "none" when no
// partition paused, moved here or went through an election.
std::string describe_pauses(const std::vector<PartitionPauses>& pauses);
// The same as a JSON object keyed by partition: {"12": {"lapsed": 1, "lapsed_ms": 812, ...}, ...}.
std::string pauses_json(const std::vector<PartitionPauses>& pauses);

class LeaseManager {
 public:
  using Handler = std::function<void(const LeaseEvent&)>;
  // Opens (or creates) the bucket and starts the lease thread; the handler runs on that thread.
  // witnesses: the connection's options, to open one more connection pinned to each of its servers
  // (the proof of an election, above); null or one server: none (holders pause through elections).
  // Throws Error (connection.hpp) for bad options, and when the bucket cannot be opened or
  // created, or exists with another TTL.
  LeaseManager(Connection& connection, LeaseOptions options, Handler handler = {},
               const ConnectionOptions* witnesses = nullptr);
  // stop(), then closes the bucket.
  ~LeaseManager();
  LeaseManager(const LeaseManager&) = delete;
  LeaseManager& operator=(const LeaseManager&) = delete;

  // Stops the lease thread. give_back: every partition is released (publishing stops first) and
  // the membership deleted, so the others take over at once instead of after ttl_ms. Idempotent.
  void stop(bool give_back = true);

  // Whether this shard may publish for the partition now; epoch (when not null) receives the
  // tenure's epoch. [any thread] Lock-free.
  bool may_publish(uint32_t partition, uint64_t* epoch = nullptr) const;
  // The partitions held now (valid or paused), ascending. [any thread]
  std::vector<uint32_t> held() const;
  // The live members of the last membership read, sorted. [any thread]
  std::vector<std::string> members() const;
  LeaseCounters counters() const;
  // Per partition that paused, moved or was published through an election, ascending. [any thread]
  std::vector<PartitionPauses> pauses() const;
  // Witness connections open, and the bucket's replicas: an election is proven by
  // replicas / 2 + 1 servers (0: never, holders pause instead).
  size_t witnesses() const { return witnesses_.size(); }
  int leaderless_quorum() const { return leaderless_quorum_; }
  const LeaseOptions& options() const { return options_; }

 private:
  struct Slot {
    std::atomic<int64_t> valid_until{0};  // steady ns; 0: not held or paused
    std::atomic<uint64_t> epoch{0};
    std::atomic<bool> held{false};
    uint64_t revision = 0;     // last accepted revision [lease thread]
    int64_t last_ok_ns = 0;    // t0 of the last accepted claim or renewal [lease thread]
    int64_t until_ns = 0;      // valid_until while held and not paused [lease thread]
    bool paused = false;       // [lease thread]
    int64_t paused_at = 0;       // when the pause began [lease thread]
    int64_t election_since = 0;  // when it would have paused but for an election (0: none) [lease thread]
  };
  void run();
  void tick(int64_t now);
  // What the last read of the bucket showed of one key, and since when (this shard's clock).
  struct Seen {
    uint64_t revision = 0;
    int64_t since_ns = 0;
    std::string value;
    bool moved = false;  // its revision moved on during this observation (a member seen writing)
  };
  bool renew(uint32_t p);  // false: the servers could not be reached
  void renewed(uint32_t p, int64_t sent_ns, uint64_t revision);  // a renewal sent at sent_ns landed
  bool claim(uint32_t p, const Seen* seen, int64_t now);
  void give_back(uint32_t p);
  void lose(uint32_t p);
  void ended(uint32_t p, int64_t now);  // a tenure ends (given back or lost): the pause and election stats
  // One look at the bucket's leader through every connection: 1 proven leaderless (no responders
  // from leaderless_quorum_ servers), -1 a server accepted the write (a leader exists), 0 neither.
  int probe_leader(int64_t* sent_ns, int64_t* received_ns);
  void election_round();
  bool read_bucket(int64_t now);  // drains the watcher into seen_; false: start over (seen_ cleared)
  void drop_watcher();
  void emit(LeaseEvent::Kind kind, uint32_t p, uint64_t epoch, int64_t valid_until);
  std::string key(uint32_t p) const { return "p." + std::to_string(p); }

  Connection& connection_;
  LeaseOptions options_;
  Handler handler_;
  kvStore* kv_ = nullptr;
  std::unique_ptr<Slot[]> slots_;
  std::map<std::string, Seen> seen_;  // by key [lease thread]
  std::vector<std::unique_ptr<Connection>> witnesses_;  // one per server URL, pinned to it
  int leaderless_quorum_ = 0;         // servers that must answer "no responders" (0: never proven)
  int64_t leaderless_since_ns_ = 0;   // the current run of proofs began (0: none) [lease thread]
  kvWatcher* watcher_ = nullptr;      // the bucket's one watcher [lease thread]
  bool watch_ready_ = false;          // its initial values are all in [lease thread]
  uint64_t ticks_ = 0;                // even ticks write (membership, renewals) [lease thread]
  bool reachable_ = true;             // the last writes reached the bucket [lease thread]
  uint64_t member_revision_ = 0, member_revision_before_ = 0;  // our membership writes, this tick and the last [lease thread]
  mutable std::mutex mutex_;  // members_ and counters_ (copied out by other threads)
  std::vector<std::string> members_;
  LeaseCounters counters_;
  struct PauseRecord {
    PartitionPauses stats;
    int64_t paused_since = 0;  // a pause going on began then (0: none), counted up to now by pauses()
  };
  std::unique_ptr<PauseRecord[]> pauses_;  // mutex_
  std::mutex wait_mutex_;  // the lease thread's sleep between ticks, cut short by stop()
  std::condition_variable wait_cv_;
  std::atomic<bool> stop_{false};
  bool stopped_ = false;
  bool give_back_ = true;
  std::thread thread_;
};

}  // namespace kata::transport::nats
