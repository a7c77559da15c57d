#include "transport/nats/lease.hpp"

#include <nats/nats.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <set>

namespace kata::transport::nats {

namespace {

int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

constexpr int64_t kMs = 1'000'000;

bool valid_bucket_name(const std::string& name) {
  // Bucket names: the characters the client accepts ([A-Za-z0-9_-]), as member names.
  return valid_member_name(name);
}

// A renewal or claim the servers answered with a refusal (the key moved on: another holder, or
// the lease lapsed), as opposed to one that did not reach a stream leader (timeouts, no
// responders while a leader is elected, a connection being re-established).
bool refused_by_servers(natsStatus status, const std::string& why) {
  if (status == NATS_OK) return false;
  return why.find("wrong last sequence") != std::string::npos;
}

}  // namespace

const char* lease_event_name(LeaseEvent::Kind kind) {
  switch (kind) {
    case LeaseEvent::Kind::kAcquired: return "acquired";
    case LeaseEvent::Kind::kExtended: return "extended";
    case LeaseEvent::Kind::kPaused: return "paused";
    case LeaseEvent::Kind::kResumed: return "resumed";
    case LeaseEvent::Kind::kReleased: return "released";
    case LeaseEvent::Kind::kLost: return "lost";
    case LeaseEvent::Kind::kElection: return "election";
  }
  return "?";
}

std::string describe_pauses(const std::vector<PartitionPauses>& pauses) {
  std::string out;
  char clause[256];
  const auto seconds = [](int64_t ns) { return static_cast<double>(ns) / 1e9; };
  for (const PartitionPauses& p : pauses) {
    std::string text;
    if (p.lapsed > 0) {
      std::snprintf(clause, sizeof clause, "paused %llux %.1f s (lease lapsed: not renewed, no election proven)",
                    static_cast<unsigned long long>(p.lapsed), seconds(p.lapsed_ns));
      text += clause;
    }
    if (p.elections > 0) {
      std::snprintf(clause, sizeof clause, "%spublished through %llu election%s for %.1f s (no pause)", text.empty() ? "" : ", ",
                    static_cast<unsigned long long>(p.elections), p.elections == 1 ? "" : "s", seconds(p.election_ns));
      text += clause;
    }
    if (p.taken_over > 0) {
      std::snprintf(clause, sizeof clause, "%staken over %llux after %.1f s without a holder", text.empty() ? "" : ", ",
                    static_cast<unsigned long long>(p.taken_over), seconds(p.taken_over_ns));
      text += clause;
    }
    if (p.handed_over > 0) {
      std::snprintf(clause, sizeof clause, "%shanded over %llux after %.1f s", text.empty() ? "" : ", ",
                    static_cast<unsigned long long>(p.handed_over), seconds(p.handed_over_ns));
      text += clause;
    }
    if (text.empty()) continue;  // only given up (moved away): its new holder tells the pause
    out += (out.empty() ? "p" : "; p") + std::to_string(p.partition) + ": " + text;
  }
  return out.empty() ? "none" : out;
}

std::string pauses_json(const std::vector<PartitionPauses>& pauses) {
  std::string out = "{";
  char entry[320];
  for (const PartitionPauses& p : pauses) {
    std::snprintf(entry, sizeof entry,
                  "%s\"%u\": {\"lapsed\": %llu, \"lapsed_ms\": %lld, \"elections\": %llu, \"election_ms\": %lld, "
                  "\"taken_over\": %llu, \"taken_over_ms\": %lld, \"handed_over\": %llu, \"handed_over_ms\": %lld, "
                  "\"moved_out\": %llu}",
                  out.size() > 1 ? ", " : "", p.partition, static_cast<unsigned long long>(p.lapsed),
                  static_cast<long long>(p.lapsed_ns / kMs), static_cast<unsigned long long>(p.elections),
                  static_cast<long long>(p.election_ns / kMs), static_cast<unsigned long long>(p.taken_over),
                  static_cast<long long>(p.taken_over_ns / kMs), static_cast<unsigned long long>(p.handed_over),
                  static_cast<long long>(p.handed_over_ns / kMs), static_cast<unsigned long long>(p.moved_out));
    out += entry;
  }
  return out + "}";
}

std::string lease_options_problem(const LeaseOptions& o) {
  if (!valid_bucket_name(o.bucket)) return "the lease bucket name \"" + o.bucket + "\" is not 1..64 of [A-Za-z0-9_-]";
  if (!valid_member_name(o.member)) return "the shard name \"" + o.member + "\" is not 1..64 of [A-Za-z0-9_-]";
  if (o.partitions == 0 || o.partitions > 4096) return "partitions must be 1..4096";
  if (o.replicas < 1 || o.replicas > 5) return "lease replicas must be 1..5";
  if (o.ttl_ms < 100 || o.renew_ms <= 0 || o.guard_ms <= 0) return "lease ttl, renewal and guard must be positive (ttl >= 100 ms)";
  if (o.guard_ms >= o.ttl_ms) return "the lease guard must be shorter than its ttl";
  // Two renewals fit in the time a lease is usable, so one lost request does not pause it.
  if (2 * o.renew_ms > o.ttl_ms - o.guard_ms) return "renew at least twice within ttl - guard";
  if (o.bucket_ttl_ms != 0 && o.bucket_ttl_ms < o.ttl_ms) return "the bucket's ttl must be 0 (none) or at least the lease ttl";
  return {};
}

LeaseManager::LeaseManager(Connection& connection, LeaseOptions options, Handler handler,
                           const ConnectionOptions* witnesses)
    : connection_(connection), options_(std::move(options)), handler_(std::move(handler)) {
  if (auto problem = lease_options_problem(options_); !problem.empty()) throw Error(problem);
  kvConfig cfg;
  kvConfig_Init(&cfg);
  cfg.Bucket = options_.bucket.c_str();
  cfg.Description = "kata serve: partition leases and shard membership";
  cfg.History = 1;
  cfg.TTL = options_.bucket_ttl_ms * kMs;  // nanoseconds (the stream's MaxAge)
  cfg.StorageType = options_.memory_storage ? js_MemoryStorage : js_FileStorage;
  cfg.Replicas = options_.replicas;
  // Shards started together race to create the bucket, and a new R3 stream takes a moment to
  // elect its leader: retry for a few seconds before giving up.
  std::string why;
  int64_t ttl = -1;
  int64_t replicas = 0;
  const int64_t deadline = steady_ns() + 10'000 * kMs;
  do {
    if (kv_ == nullptr && js_CreateKeyValue(&kv_, connection_.jetstream(), &cfg) != NATS_OK) {
      // Made by another shard with other settings, or JetStream refused: bind to it if it exists.
      why = last_error();
      kv_ = nullptr;
      if (js_KeyValue(&kv_, connection_.jetstream(), options_.bucket.c_str()) != NATS_OK) kv_ = nullptr;
    }
    kvStatus* status = nullptr;
    if (kv_ != nullptr && kvStore_Status(&status, kv_) == NATS_OK) {
      ttl = kvStatus_TTL(status) / kMs;
      replicas = kvStatus_Replicas(status);
      kvStatus_Destroy(status);
      break;
    }
    if (kv_ != nullptr) why = last_error();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  } while (steady_ns() < deadline);
  if (ttl < 0) {
    if (kv_ != nullptr) kvStore_Destroy(kv_);
    throw Error("NATS: cannot create or open the lease bucket \"" + options_.bucket + "\": " + why);
  }
  if (ttl != 0 && ttl < options_.ttl_ms) {
    // The servers would forget a lease before its holder stops publishing.
    kvStore_Destroy(kv_);
    throw Error("the lease bucket \"" + options_.bucket + "\" keeps values " + std::to_string(ttl) +
                " ms, less than the lease ttl " + std::to_string(options_.ttl_ms) + " ms");
  }
  slots_.reset(new Slot[options_.partitions]);
  pauses_.reset(new PauseRecord[options_.partitions]);
  for (uint32_t p = 0; p < options_.partitions; ++p) pauses_[p].stats.partition = p;
  // The witnesses: a connection pinned to each server given (distinct servers answer for
  // themselves: no proof rests on one server's word), opened in the background so that a server
  // down now does not stop the shard. Only with 3 or more replicas: a majority of one or two
  // replicas is every replica, and a lone cut-off server would then prove what it cannot.
  if (witnesses != nullptr && options_.through_elections && replicas >= 3 && witnesses->servers.size() >= 2) {
    for (size_t i = 0; i < witnesses->servers.size(); ++i) {
      ConnectionOptions w = *witnesses;
      w.servers = {witnesses->servers[i]};
      w.randomize = false;
      w.name = options_.member + "-witness-" + std::to_string(i);
      w.connect_in_background = true;
      w.only_given_servers = true;  // pinned: a witness that moved to another server would speak for it twice
      w.single_delivery_thread = false;
      w.reconnect_wait_ms = std::max(w.reconnect_wait_ms, 250);
      try {
        witnesses_.push_back(std::make_unique<Connection>(w));
      } catch (const Error&) {
        // Unusable options for this one server: it is not a witness (fewer proofs, never a wrong one).
      }
    }
    leaderless_quorum_ = static_cast<int>(replicas / 2 + 1);
  }
  thread_ = std::thread([this] { run(); });
}

LeaseManager::~LeaseManager() {
  stop(true);
  drop_watcher();
  if (kv_ != nullptr) kvStore_Destroy(kv_);
}

void LeaseManager::stop(bool give_back) {
  if (stopped_) return;
  stopped_ = true;
  give_back_ = give_back;
  {
    std::lock_guard<std::mutex> lock(wait_mutex_);
    stop_.store(true);
    wait_cv_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

bool LeaseManager::may_publish(uint32_t partition, uint64_t* epoch) const {
  if (partition >= options_.partitions) return false;
  const Slot& s = slots_[partition];
  const int64_t until = s.valid_until.load(std::memory_order_acquire);
  if (until == 0 || steady_ns() >= until) return false;
  if (epoch != nullptr) *epoch = s.epoch.load(std::memory_order_relaxed);
  return true;
}

std::vector<uint32_t> LeaseManager::held() const {
  std::vector<uint32_t> out;
  for (uint32_t p = 0; p < options_.partitions; ++p)
    if (slots_[p].held.load(std::memory_order_acquire)) out.push_back(p);
  return out;
}

std::vector<std::string> LeaseManager::members() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return members_;
}

LeaseCounters LeaseManager::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

std::vector<PartitionPauses> LeaseManager::pauses() const {
  std::vector<PartitionPauses> out;
  const int64_t now = steady_ns();
  std::lock_guard<std::mutex> lock(mutex_);
  for (uint32_t p = 0; p < options_.partitions; ++p) {
    PartitionPauses x = pauses_[p].stats;
    if (pauses_[p].paused_since != 0) x.lapsed_ns += now - pauses_[p].paused_since;
    if (x.lapsed > 0 || x.elections > 0 || x.taken_over > 0 || x.handed_over > 0 || x.moved_out > 0) out.push_back(x);
  }
  return out;
}

void LeaseManager::emit(LeaseEvent::Kind kind, uint32_t p, uint64_t epoch, int64_t valid_until) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    switch (kind) {
      case LeaseEvent::Kind::kAcquired: ++counters_.acquired; break;
      case LeaseEvent::Kind::kExtended: ++counters_.renewals; break;
      case LeaseEvent::Kind::kPaused: ++counters_.paused; break;
      case LeaseEvent::Kind::kResumed: ++counters_.resumed; ++counters_.renewals; break;
      case LeaseEvent::Kind::kReleased: ++counters_.released; break;
      case LeaseEvent::Kind::kLost: ++counters_.lost; break;
      case LeaseEvent::Kind::kElection: break;
    }
  }
  if (handler_) handler_(LeaseEvent{kind, p, epoch, steady_ns(), valid_until});
}

void LeaseManager::run() {
  int64_t next = steady_ns();
  while (!stop_.load()) {
    tick(steady_ns());
    next += options_.renew_ms * kMs / 2;
    const int64_t now = steady_ns();
    if (next < now) next = now;  // a slow tick (servers out of reach) does not make a burst
    std::unique_lock<std::mutex> lock(wait_mutex_);
    wait_cv_.wait_for(lock, std::chrono::nanoseconds(next - now), [this] { return stop_.load(); });
  }
  if (give_back_) {
    for (uint32_t p = 0; p < options_.partitions; ++p)
      if (slots_[p].held.load()) give_back(p);
    kvStore_Delete(kv_, ("m." + options_.member).c_str());
  } else {
    // Stopped without giving back: stop publishing now all the same (the leases lapse by themselves).
    for (uint32_t p = 0; p < options_.partitions; ++p) slots_[p].valid_until.store(0, std::memory_order_release);
  }
}

void LeaseManager::tick(int64_t) {
  // Membership first, so that a joining shard is visible to the others before it claims anything.
  // Writes (membership, renewals) every other tick, i.e. every renew_ms; the bucket is looked at
  // every tick (renew_ms / 2), so a stale lease is taken over within half a period of going stale.
  const bool writes = (ticks_++ % 2) == 0;
  bool reachable = reachable_;
  if (writes) {
    uint64_t rev = 0;
    reachable = kvStore_PutString(&rev, kv_, ("m." + options_.member).c_str(), options_.member.c_str()) == NATS_OK;
    member_revision_before_ = member_revision_;
    member_revision_ = reachable ? rev : 0;
  }
  for (uint32_t p = 0; p < options_.partitions; ++p)
    if (writes && reachable && slots_[p].held.load(std::memory_order_relaxed)) reachable = renew(p);
  if (writes) reachable_ = reachable;
  // Out of reach: an election of the bucket's leader, proven, lets the holders publish on (above);
  // otherwise, or once it is over, each lease pauses at its valid_until.
  if (!reachable && leaderless_quorum_ > 0) election_round();
  else leaderless_since_ns_ = 0;
  for (uint32_t p = 0; p < options_.partitions; ++p) {
    Slot& s = slots_[p];
    if (!s.held.load(std::memory_order_relaxed) || s.paused || s.until_ns > steady_ns()) continue;
    s.paused = true;
    s.paused_at = steady_ns();
    s.valid_until.store(0, std::memory_order_release);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++pauses_[p].stats.lapsed;
      pauses_[p].paused_since = s.paused_at;
    }
    emit(LeaseEvent::Kind::kPaused, p, s.epoch.load(), 0);
  }
  const int64_t now = steady_ns();
  if (!reachable || !read_bucket(now)) {
    // What was seen before the bucket went out of reach proves nothing about renewals meanwhile.
    drop_watcher();
    if (!reachable) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++counters_.reads_failed;
    }
    return;
  }
  const int64_t ttl = options_.ttl_ms * kMs;
  // live: not stale; proven: also seen writing during this observation (or this shard itself).
  std::vector<std::string> live, proven;
  for (const auto& [k, seen] : seen_) {
    if (k.compare(0, 2, "m.") != 0) continue;
    const bool self = k.compare(2, std::string::npos, options_.member) == 0;
    if (now - seen.since_ns >= ttl && !self) continue;
    live.push_back(k.substr(2));
    if (seen.moved || self) proven.push_back(k.substr(2));
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    members_ = live;
  }
  if (!std::binary_search(live.begin(), live.end(), options_.member)) return;  // our membership is not written yet
  for (uint32_t p = 0; p < options_.partitions; ++p) {
    Slot& s = slots_[p];
    if (s.held.load(std::memory_order_relaxed)) {
      // Given back only to a member seen alive now: not to the last membership of one long dead
      // that a fresh watcher shows for ttl_ms (the partition would move there and back).
      const int owner = rendezvous_owner(proven, p);
      if (owner >= 0 && proven[static_cast<size_t>(owner)] != options_.member && !s.paused) give_back(p);
      continue;
    }
    // Claimed over every member that may be alive: never a partition a live member should hold.
    const int owner = rendezvous_owner(live, p);
    const bool mine = owner >= 0 && live[static_cast<size_t>(owner)] == options_.member;
    if (!mine) continue;
    const auto it = seen_.find(key(p));
    const Seen* seen = it == seen_.end() ? nullptr : &it->second;
    // Free (never claimed, collected, or given back), or stale: its holder stopped renewing.
    if (seen == nullptr || seen->value.empty() || now - seen->since_ns >= ttl) claim(p, seen, now);
  }
}

bool LeaseManager::renew(uint32_t p) {
  Slot& s = slots_[p];
  const std::string k = key(p);
  const int64_t t0 = steady_ns();
  uint64_t rev = 0;
  const natsStatus status = kvStore_UpdateString(&rev, kv_, k.c_str(), options_.member.c_str(), s.revision);
  if (status == NATS_OK) {
    renewed(p, t0, rev);
    return true;
  }
  const std::string why = last_error();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.renewals_failed;
  }
  if (!refused_by_servers(status, why)) return false;
  // Refused because the key moved on, but maybe by our own hand: an update whose request timed
  // out while the connection was down is still sent by the client once it is back (its
  // reconnect buffer), and lands after we gave up on it. The key then holds our name at a newer
  // revision (no other member writes our name), and the lease is still ours: renew on that
  // revision. Seen as whole partitions "lost" half a second after a server was killed
  // (runtime_nats_server_kill).
  kvEntry* entry = nullptr;
  if (kvStore_Get(&entry, kv_, k.c_str()) != NATS_OK || entry == nullptr) {
    if (entry != nullptr) kvEntry_Destroy(entry);
    return false;  // not known now: not renewed; the lease lapses at valid_until unless the next try settles it
  }
  const uint64_t current = kvEntry_Revision(entry);
  const bool ours = kvEntry_Operation(entry) == kvOp_Put && current > s.revision &&
                    static_cast<size_t>(kvEntry_ValueLen(entry)) == options_.member.size() &&
                    std::memcmp(kvEntry_Value(entry), options_.member.data(), options_.member.size()) == 0;
  kvEntry_Destroy(entry);
  if (!ours) {
    lose(p);
    return true;
  }
  const int64_t t1 = steady_ns();
  if (kvStore_UpdateString(&rev, kv_, k.c_str(), options_.member.c_str(), current) != NATS_OK)
    return false;  // ours, but this update did not land either: try again at the next renewal
  renewed(p, t1, rev);
  return true;
}

void LeaseManager::renewed(uint32_t p, int64_t sent_ns, uint64_t revision) {
  Slot& s = slots_[p];
  // Usable from when the request was sent, not when it was answered: the servers may have
  // counted the ttl from any moment in between.
  const int64_t until = sent_ns + (options_.ttl_ms - options_.guard_ms) * kMs;
  const bool was_paused = s.paused;
  const int64_t now = steady_ns();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (was_paused) {
      pauses_[p].stats.lapsed_ns += now - s.paused_at;
      pauses_[p].paused_since = 0;
    }
    if (s.election_since != 0) {
      ++pauses_[p].stats.elections;
      pauses_[p].stats.election_ns += std::max<int64_t>(0, std::min(now, s.until_ns) - s.election_since);
    }
  }
  s.election_since = 0;
  s.revision = revision;
  s.last_ok_ns = sent_ns;
  s.until_ns = until;
  s.paused = false;
  emit(was_paused ? LeaseEvent::Kind::kResumed : LeaseEvent::Kind::kExtended, p, s.epoch.load(), until);
  s.valid_until.store(until, std::memory_order_release);
}

bool LeaseManager::claim(uint32_t p, const Seen* seen, int64_t) {
  Slot& s = slots_[p];
  const std::string k = key(p);
  const int64_t t0 = steady_ns();
  uint64_t rev = 0;
  // By revision of what was seen (a concurrent claim or a late renewal wins instead), or create
  // when nothing was (refused if a value appeared meanwhile).
  const natsStatus status = seen == nullptr ? kvStore_CreateString(&rev, kv_, k.c_str(), options_.member.c_str())
                                            : kvStore_UpdateString(&rev, kv_, k.c_str(), options_.member.c_str(), seen->revision);
  if (status != NATS_OK) {
    // Refused by revision while the watcher still shows that revision: the key is gone (the
    // bucket's MaxAge collected a given-back lease; no delete is delivered for that). Forget it,
    // so the next tick claims with create; a newer value, if any, comes through the watcher.
    if (seen != nullptr && refused_by_servers(status, last_error())) {
      const auto it = seen_.find(k);
      if (it != seen_.end() && it->second.revision == seen->revision) seen_.erase(it);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.claims_refused;
    return false;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (seen != nullptr && !seen->value.empty()) ++counters_.takeovers;
    // A move: it was held before (a stale holder's, or given back); how long it had none, as seen here.
    if (seen != nullptr) {
      const bool stale = !seen->value.empty();
      ++(stale ? pauses_[p].stats.taken_over : pauses_[p].stats.handed_over);
      (stale ? pauses_[p].stats.taken_over_ns : pauses_[p].stats.handed_over_ns) += std::max<int64_t>(0, t0 - seen->since_ns);
    }
  }
  const int64_t until = t0 + (options_.ttl_ms - options_.guard_ms) * kMs;
  s.revision = rev;
  s.last_ok_ns = t0;
  s.until_ns = until;
  s.paused = false;
  s.election_since = 0;
  s.epoch.store(rev, std::memory_order_relaxed);
  s.held.store(true, std::memory_order_release);
  emit(LeaseEvent::Kind::kAcquired, p, rev, until);
  s.valid_until.store(until, std::memory_order_release);
  return true;
}

void LeaseManager::ended(uint32_t p, int64_t now) {
  Slot& s = slots_[p];
  std::lock_guard<std::mutex> lock(mutex_);
  ++pauses_[p].stats.moved_out;
  if (s.paused) {
    pauses_[p].stats.lapsed_ns += now - s.paused_at;
    pauses_[p].paused_since = 0;
  }
  if (s.election_since != 0) {
    ++pauses_[p].stats.elections;
    pauses_[p].stats.election_ns += std::max<int64_t>(0, std::min(now, s.until_ns) - s.election_since);
  }
  s.election_since = 0;
  s.paused = false;
  s.until_ns = 0;
}

void LeaseManager::give_back(uint32_t p) {
  Slot& s = slots_[p];
  // Stop publishing before the partition can be claimed by anyone else.
  s.valid_until.store(0, std::memory_order_release);
  s.held.store(false, std::memory_order_release);
  ended(p, steady_ns());
  emit(LeaseEvent::Kind::kReleased, p, s.epoch.load(), 0);
  uint64_t rev = 0;
  // By revision: a lease taken over meanwhile is not overwritten.
  kvStore_Update(&rev, kv_, key(p).c_str(), "", 0, s.revision);
}

void LeaseManager::lose(uint32_t p) {
  Slot& s = slots_[p];
  s.valid_until.store(0, std::memory_order_release);
  s.held.store(false, std::memory_order_release);
  ended(p, steady_ns());
  emit(LeaseEvent::Kind::kLost, p, s.epoch.load(), 0);
}

int LeaseManager::probe_leader(int64_t* sent_ns, int64_t* received_ns) {
  // The write: this shard's membership (harmless if a leader takes it), as a plain request on the
  // key's subject, so that each connection's own server answers.
  const std::string subject = "$KV." + options_.bucket + ".m." + options_.member;
  const int64_t wait_ms = std::min<int64_t>(options_.renew_ms, 500);
  std::set<std::string> leaderless;  // servers (by id) that answered "no responders"
  bool accepted = false;
  *sent_ns = steady_ns();
  const auto ask = [&](Connection& c) {
    if (accepted || !c.connected()) return;
    const std::string id = c.connected_server_id();
    natsMsg* reply = nullptr;
    const natsStatus status = natsConnection_Request(&reply, c.get(), subject.c_str(), options_.member.data(),
                                                     static_cast<int>(options_.member.size()), wait_ms);
    if (reply != nullptr) natsMsg_Destroy(reply);
    // The same server before and after (not one reconnected to meanwhile): its answer is its own.
    if (status == NATS_NO_RESPONDERS && !id.empty() && id == c.connected_server_id()) leaderless.insert(id);
    if (status == NATS_OK) accepted = true;
  };
  ask(connection_);
  for (auto& w : witnesses_) ask(*w);
  *received_ns = steady_ns();
  if (accepted) return -1;
  return static_cast<int>(leaderless.size()) >= leaderless_quorum_ ? 1 : 0;
}

void LeaseManager::election_round() {
  int64_t sent = 0, received = 0;
  if (probe_leader(&sent, &received) != 1) {
    leaderless_since_ns_ = 0;
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.leaderless_proofs;
  }
  // The run of proofs began no later than the first one was answered; it must have lasted a
  // renewal period before it proves every claimer's observation restarted (above).
  if (leaderless_since_ns_ == 0) leaderless_since_ns_ = received;
  const int64_t renew = options_.renew_ms * kMs;
  if (sent - renew < leaderless_since_ns_) return;
  const int64_t until = sent - renew + (options_.ttl_ms - options_.guard_ms) * kMs;
  const int64_t now = steady_ns();
  for (uint32_t p = 0; p < options_.partitions; ++p) {
    Slot& s = slots_[p];
    // Only a tenure still valid goes on: one that lapsed may have been taken over before the election.
    if (!s.held.load(std::memory_order_relaxed) || s.paused || s.until_ns <= now || until <= s.until_ns) continue;
    if (s.election_since == 0) s.election_since = s.until_ns;
    s.until_ns = until;
    emit(LeaseEvent::Kind::kElection, p, s.epoch.load(), until);
    s.valid_until.store(until, std::memory_order_release);
  }
}

void LeaseManager::drop_watcher() {
  if (watcher_ != nullptr) kvWatcher_Destroy(watcher_);
  watcher_ = nullptr;
  watch_ready_ = false;
  seen_.clear();
}

bool LeaseManager::read_bucket(int64_t) {
  // One watcher for the shard's life (a JetStream consumer): it delivers every key's current value
  // once, then each change as it is written; each tick drains what arrived. A key's since_ns is
  // when a drain first found its revision, no earlier than the write (the safety rule above).
  if (watcher_ == nullptr) {
    kvWatchOptions o;
    kvWatchOptions_Init(&o);  // deletes included: a deleted membership or lease leaves seen_
    if (kvStore_WatchAll(&watcher_, kv_, &o) != NATS_OK) {
      watcher_ = nullptr;
      std::lock_guard<std::mutex> lock(mutex_);
      ++counters_.reads_failed;
      return false;
    }
    seen_.clear();
    watch_ready_ = false;
  }
  for (;;) {
    kvEntry* entry = nullptr;
    // Until the initial values are all in, wait for them; then take only what has arrived.
    const natsStatus status = kvWatcher_Next(&entry, watcher_, watch_ready_ ? 1 : options_.ttl_ms / 2);
    if (status == NATS_TIMEOUT && watch_ready_) break;
    if (status != NATS_OK) {
      drop_watcher();
      std::lock_guard<std::mutex> lock(mutex_);
      ++counters_.reads_failed;
      return false;
    }
    if (entry == nullptr) {  // every initial value is in
      watch_ready_ = true;
      continue;
    }
    const char* k = kvEntry_Key(entry);
    if (k != nullptr) {
      const uint64_t revision = kvEntry_Revision(entry);
      const auto it = seen_.find(k);
      if (kvEntry_Operation(entry) != kvOp_Put) {
        if (it != seen_.end() && it->second.revision < revision) seen_.erase(it);
      } else if (it == seen_.end() || it->second.revision < revision) {
        Seen& seen = seen_[k];
        seen.moved = it != seen_.end();  // a newer revision of a key already seen: written meanwhile
        seen.revision = revision;
        seen.since_ns = steady_ns();
        seen.value.assign(static_cast<const char*>(kvEntry_Value(entry)), static_cast<size_t>(kvEntry_ValueLen(entry)));
      }
    }
    kvEntry_Destroy(entry);
  }
  // The watcher proves itself live with this shard's own membership: the write of the previous
  // tick (a whole period ago) must have come through. A watcher that fell behind or stopped (its
  // consumer lost with a server) would show stale keys that are not: start over.
  const auto self = seen_.find("m." + options_.member);
  if (member_revision_before_ != 0 && (self == seen_.end() || self->second.revision < member_revision_before_)) {
    drop_watcher();
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.reads_failed;
    return false;
  }
  return true;
}

}  // namespace kata::transport::nats
