#include "transport/nats/lease.hpp"

#include <nats/nats.h>

#include <algorithm>
#include <chrono>
#include <cstring>

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
  }
  return "?";
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

LeaseManager::LeaseManager(Connection& connection, LeaseOptions options, Handler handler)
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
  for (uint32_t p = 0; p < options_.partitions; ++p) {
    Slot& s = slots_[p];
    if (!s.held.load(std::memory_order_relaxed)) continue;
    if (writes && reachable) reachable = renew(p);
    if (!s.held.load(std::memory_order_relaxed)) continue;
    if (!s.paused && s.last_ok_ns + (options_.ttl_ms - options_.guard_ms) * kMs <= steady_ns()) {
      s.paused = true;
      s.valid_until.store(0, std::memory_order_release);
      emit(LeaseEvent::Kind::kPaused, p, s.epoch.load(), 0);
    }
  }
  if (writes) reachable_ = reachable;
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
  std::vector<std::string> live;
  for (const auto& [k, seen] : seen_)
    if (k.compare(0, 2, "m.") == 0 && (now - seen.since_ns < ttl || k.compare(2, std::string::npos, options_.member) == 0))
      live.push_back(k.substr(2));
  {
    std::lock_guard<std::mutex> lock(mutex_);
    members_ = live;
  }
  if (!std::binary_search(live.begin(), live.end(), options_.member)) return;  // our membership is not written yet
  for (uint32_t p = 0; p < options_.partitions; ++p) {
    const int owner = rendezvous_owner(live, p);
    const bool mine = owner >= 0 && live[static_cast<size_t>(owner)] == options_.member;
    Slot& s = slots_[p];
    if (s.held.load(std::memory_order_relaxed)) {
      if (!mine && !s.paused) give_back(p);
      continue;
    }
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
  s.revision = revision;
  s.last_ok_ns = sent_ns;
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
  if (seen != nullptr && !seen->value.empty()) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.takeovers;
  }
  const int64_t until = t0 + (options_.ttl_ms - options_.guard_ms) * kMs;
  s.revision = rev;
  s.last_ok_ns = t0;
  s.paused = false;
  s.epoch.store(rev, std::memory_order_relaxed);
  s.held.store(true, std::memory_order_release);
  emit(LeaseEvent::Kind::kAcquired, p, rev, until);
  s.valid_until.store(until, std::memory_order_release);
  return true;
}

void LeaseManager::give_back(uint32_t p) {
  Slot& s = slots_[p];
  // Stop publishing before the partition can be claimed by anyone else.
  s.valid_until.store(0, std::memory_order_release);
  s.held.store(false, std::memory_order_release);
  s.paused = false;
  emit(LeaseEvent::Kind::kReleased, p, s.epoch.load(), 0);
  uint64_t rev = 0;
  // By revision: a lease taken over meanwhile is not overwritten.
  kvStore_Update(&rev, kv_, key(p).c_str(), "", 0, s.revision);
}

void LeaseManager::lose(uint32_t p) {
  Slot& s = slots_[p];
  s.valid_until.store(0, std::memory_order_release);
  s.held.store(false, std::memory_order_release);
  s.paused = false;
  emit(LeaseEvent::Kind::kLost, p, s.epoch.load(), 0);
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
