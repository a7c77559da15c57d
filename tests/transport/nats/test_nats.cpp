// kata's NATS transport against a real 3-server NATS cluster on loopback (nats_cluster.hpp):
// the servers' partition mapping against partition_of, and the partition leases (lease.hpp) held
// by shard processes (nats_agent.hpp) that the tests kill with SIGKILL, whose servers they kill,
// and that join and leave. Every lease test checks, from the shards' own logs, that no partition
// ever had two holders allowed to publish at the same instant (steady clock, one host), and that
// every probe result a subscriber received was published inside its sender's tenure.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nats/nats.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "nats_agent.hpp"
#include "nats_cluster.hpp"
#include "support/temp_paths.hpp"
#include "support/zmq_subscriber.hpp"
#include "transport/nats/connection.hpp"
#include "transport/nats/lease.hpp"
#include "transport/nats/partition.hpp"
#include "transport/nats/results.hpp"
#include "transport/nats/shard.hpp"
#include "transport/nats/topic.hpp"
#include "transport/wire.hpp"

namespace kata::test {
namespace {

namespace kn = transport::nats;
constexpr uint32_t kPartitions = 64;

int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
constexpr int64_t kMs = 1'000'000;

bool wait_for(const std::function<bool()>& done, int64_t timeout_ms) {
  const int64_t deadline = steady_ns() + timeout_ms * kMs;
  while (steady_ns() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return done();
}

// ---------------------------------------------------------------- pure functions

TEST(NatsPartition, Fnv1aKnownValues) {
  // The FNV-1a 32 reference values (Fowler/Noll/Vo test vectors).
  EXPECT_EQ(kn::fnv1a32("", 0), 0x811c9dc5u);
  EXPECT_EQ(kn::fnv1a32("a", 1), 0xe40c292cu);
  EXPECT_EQ(kn::fnv1a32("foobar", 6), 0xbf9cf968u);
}

TEST(NatsPartition, TopicIsTheDocumentedHexAndAgreesWithTheRuntimes) {
  // kata/runtime.h: the stream id as 16 lowercase hex digits, most significant first.
  char topic[kn::kStreamTopicBytes];
  kn::write_stream_topic(0x0123456789abcdefULL, topic);
  EXPECT_EQ(std::string(topic, sizeof topic), "0123456789abcdef");
  kn::write_stream_topic(7, topic);
  EXPECT_EQ(std::string(topic, sizeof topic), "0000000000000007");
  uint64_t id = 0;
  EXPECT_TRUE(kn::read_stream_topic("fedcba9876543210", &id));
  EXPECT_EQ(id, 0xfedcba9876543210ULL);
  id = 5;
  EXPECT_FALSE(kn::read_stream_topic("FEDCBA9876543210", &id));  // upper case is not a topic
  EXPECT_FALSE(kn::read_stream_topic("000000000000000g", &id));
  EXPECT_EQ(id, 5u);
  // The same bytes the runtime's own writer puts in front of every message.
  char runtime_topic[kata::transport::kTopicBytes];
  for (uint64_t sid : {0ULL, 1ULL, 0xffffffffffffffffULL, 0x8000000000000001ULL, 123456789ULL}) {
    kn::write_stream_topic(sid, topic);
    kata::transport::write_topic(sid, runtime_topic);
    EXPECT_EQ(std::string(topic, sizeof topic), std::string(runtime_topic, sizeof runtime_topic)) << sid;
  }
}

TEST(NatsPartition, SubjectsRoundTrip) {
  EXPECT_EQ(kn::ingest_subject("kata", 0x1234), "kata.in.0000000000001234");
  EXPECT_EQ(kn::partition_subject("kata", 7), "kata.in.7.*");
  EXPECT_EQ(kn::result_subject("kata", 0xabc), "kata.out.0000000000000abc.>");
  uint32_t p = 0;
  uint64_t id = 0;
  ASSERT_TRUE(kn::parse_partition_subject("kata", "kata.in.63.00000000deadbeef", &p, &id));
  EXPECT_EQ(p, 63u);
  EXPECT_EQ(id, 0xdeadbeefull);
  EXPECT_FALSE(kn::parse_partition_subject("kata", "kata.in.x.00000000deadbeef", &p, &id));
  EXPECT_FALSE(kn::parse_partition_subject("kata", "kata.in.3.00000000DEADBEEF", &p, &id));
  EXPECT_FALSE(kn::parse_partition_subject("kata", "kata.in.3.00000000deadbeef.x", &p, &id));
  char subject[128];
  ASSERT_TRUE(kn::format_result_subject(subject, sizeof subject, "kata", 0x42, 9001, "shard-a"));
  EXPECT_STREQ(subject, "kata.out.0000000000000042.9001.shard-a");
  uint64_t epoch = 0;
  const char* owner = nullptr;
  ASSERT_TRUE(kn::parse_result_subject("kata", subject, &id, &epoch, &owner));
  EXPECT_EQ(id, 0x42u);
  EXPECT_EQ(epoch, 9001u);
  EXPECT_STREQ(owner, "shard-a");
  EXPECT_FALSE(kn::format_result_subject(subject, 20, "kata", 0x42, 9001, "shard-a"));
  EXPECT_FALSE(kn::parse_result_subject("kata", "kata.out.0000000000000042.x.a", &id, &epoch, &owner));
  EXPECT_FALSE(kn::parse_result_subject("kata", "kata.out.0000000000000042.5.", &id, &epoch, &owner));
}

TEST(NatsPartition, EpochFilterDropsOlderTenures) {
  kn::EpochFilter filter(2);
  EXPECT_TRUE(filter.accept(1, 10));
  EXPECT_TRUE(filter.accept(1, 10));
  EXPECT_TRUE(filter.accept(1, 12));   // the partition moved: a newer tenure
  EXPECT_FALSE(filter.accept(1, 10));  // the former holder, late: dropped
  EXPECT_TRUE(filter.accept(2, 3));    // another stream keeps its own epoch
  EXPECT_TRUE(filter.accept(3, 1));    // beyond the bound: accepted, not remembered
  EXPECT_EQ(filter.stale(), 1u);
  EXPECT_EQ(filter.handovers(), 1u);
  EXPECT_EQ(filter.untracked(), 1u);
}

TEST(NatsPartition, RendezvousMovesOnlyWhatMust) {
  const std::vector<std::string> three{"shard-a", "shard-b", "shard-c"};
  std::vector<std::string> four = three;
  four.push_back("shard-d");
  std::sort(four.begin(), four.end());
  int moved = 0, per_member[4] = {};
  for (uint32_t p = 0; p < kPartitions; ++p) {
    const std::string before = three[static_cast<size_t>(kn::rendezvous_owner(three, p))];
    const std::string after = four[static_cast<size_t>(kn::rendezvous_owner(four, p))];
    ++per_member[kn::rendezvous_owner(four, p)];
    if (before != after) {
      ++moved;
      EXPECT_EQ(after, "shard-d") << "partition " << p << " moved between two members that stayed";
    }
  }
  // About a quarter moves to the newcomer, and nobody is left without partitions.
  EXPECT_GE(moved, 8);
  EXPECT_LE(moved, 26);
  for (int n : per_member) EXPECT_GE(n, 6);
  EXPECT_EQ(kn::rendezvous_owner({}, 0), -1);
}

TEST(NatsPartition, OptionsProblemsAreNamed) {
  kn::ConnectionOptions c;
  EXPECT_NE(kn::options_problem(c).find("no NATS server"), std::string::npos);
  c.servers = {"nats://127.0.0.1:4222"};
  EXPECT_EQ(kn::options_problem(c), "");
  c.credentials_file = "user.creds";
  c.nkey = "UABC";
  c.nkey_seed_file = "seed";
  EXPECT_NE(kn::options_problem(c).find("not both"), std::string::npos);
  c.credentials_file.clear();
  c.nkey = "SABC";
  EXPECT_NE(kn::options_problem(c).find("starts with U"), std::string::npos);
  kn::LeaseOptions l;
  EXPECT_NE(kn::lease_options_problem(l).find("shard name"), std::string::npos);
  l.member = "shard-a";
  EXPECT_EQ(kn::lease_options_problem(l), "");
  l.guard_ms = l.ttl_ms;
  EXPECT_NE(kn::lease_options_problem(l).find("guard"), std::string::npos);
  l.guard_ms = 750;
  l.renew_ms = 2000;
  EXPECT_NE(kn::lease_options_problem(l).find("renew"), std::string::npos);
  l.renew_ms = 250;
  l.member = "a.b";
  EXPECT_FALSE(kn::lease_options_problem(l).empty());
}

// A given-back lease that nobody claims is collected by the bucket's MaxAge, and the servers send
// no delete for that: the shard's watcher still shows the empty value at its old revision, so a
// claim by that revision is refused (the key is gone). The shard must then forget the key and claim
// with create. Made deterministic with a member that only the test writes ("m.c", no lease
// manager behind it): the shard gives c its rendezvous partitions, c never claims them, the test
// keeps c alive until the bucket has collected those keys, then deletes c.
TEST(NatsCluster, GivenBackLeaseCollectedByMaxAgeIsClaimedWithCreate) {
  TempDir dir;
  NatsCluster cluster(dir.path().string(), 1);
  ASSERT_EQ(cluster.problem(), "");
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection shard_connection(co);
  kn::LeaseOptions lo;
  lo.member = "a";
  lo.bucket = "lease_maxage";
  lo.partitions = 8;
  lo.replicas = 1;
  lo.ttl_ms = 1000;
  lo.renew_ms = 300;
  lo.guard_ms = 250;
  lo.bucket_ttl_ms = 1000;  // the smallest the options allow: keys unwritten for 1 s are collected
  ASSERT_EQ(kn::lease_options_problem(lo), "");
  kn::LeaseManager leases(shard_connection, lo);
  ASSERT_TRUE(wait_for([&] { return leases.held().size() == lo.partitions; }, 10000));

  const std::vector<std::string> both{"a", "c"};
  std::vector<uint32_t> to_c, to_a;
  for (uint32_t p = 0; p < lo.partitions; ++p)
    (both[static_cast<size_t>(kn::rendezvous_owner(both, p))] == "c" ? to_c : to_a).push_back(p);
  ASSERT_FALSE(to_c.empty());  // fixed by the hash: 8 partitions, two members

  kn::Connection test_connection(co);
  kvStore* kv = nullptr;
  ASSERT_EQ(js_KeyValue(&kv, test_connection.jetstream(), lo.bucket.c_str()), NATS_OK);
  std::atomic<bool> c_alive{true};
  std::thread c_member([&] {
    while (c_alive.load()) {
      uint64_t rev = 0;
      kvStore_PutString(&rev, kv, "m.c", "c");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  // The shard sees c and gives c's partitions back (an empty value each).
  const bool gave_back = wait_for([&] { return leases.held() == to_a; }, 5000);
  // Kept alive until the bucket has collected every given-back key (written once, then never).
  bool collected = false;
  if (gave_back)
    collected = wait_for([&] {
      for (uint32_t p : to_c) {
        kvEntry* e = nullptr;
        const natsStatus s = kvStore_Get(&e, kv, ("p." + std::to_string(p)).c_str());
        if (e != nullptr) kvEntry_Destroy(e);
        if (s != NATS_NOT_FOUND) return false;
      }
      return true;
    }, 5000);
  const uint64_t refused_before = leases.counters().claims_refused;
  c_alive.store(false);
  c_member.join();
  kvStore_Delete(kv, "m.c");
  ASSERT_TRUE(gave_back);
  ASSERT_TRUE(collected);
  // c is gone: its partitions are the shard's again, although a claim by the seen revision fails.
  EXPECT_TRUE(wait_for([&] { return leases.held().size() == lo.partitions; }, 5000));
  EXPECT_GE(leases.counters().claims_refused, refused_before + 1);
  for (uint32_t p : to_c) EXPECT_TRUE(leases.may_publish(p)) << p;
  leases.stop();
  kvStore_Destroy(kv);
}

// ---------------------------------------------------------------- the servers' mapping

TEST(NatsCluster, ServerMappingMatchesPartitionOf) {
  TempDir dir;
  NatsCluster cluster(dir.path().string(), 1);
  ASSERT_EQ(cluster.problem(), "");
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection connection(co);
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, connection.get(), "kata.in.*.*"), NATS_OK);
  ASSERT_TRUE(connection.flush(2000));
  // Ids of every shape: small, large, every byte set; each published on its unmapped subject.
  std::vector<uint64_t> ids;
  for (uint64_t i = 0; i < 200; ++i) ids.push_back(i);
  for (uint64_t i = 0; i < 100; ++i) ids.push_back(0x9e3779b97f4a7c15ull * (i + 1));
  ids.push_back(~0ull - 1);
  for (uint64_t id : ids) ASSERT_TRUE(connection.publish(kn::ingest_subject("kata", id), "x", 1));
  std::set<uint32_t> seen;
  for (size_t n = 0; n < ids.size(); ++n) {
    natsMsg* msg = nullptr;
    ASSERT_EQ(natsSubscription_NextMsg(&msg, sub, 5000), NATS_OK) << "message " << n << " of " << ids.size();
    uint32_t p = 0;
    uint64_t id = 0;
    ASSERT_TRUE(kn::parse_partition_subject("kata", natsMsg_GetSubject(msg), &p, &id)) << natsMsg_GetSubject(msg);
    EXPECT_EQ(p, kn::partition_of(id, kPartitions)) << "stream " << id;
    seen.insert(p);
    natsMsg_Destroy(msg);
  }
  EXPECT_EQ(seen.size(), kPartitions);  // 301 streams reach every partition
  natsSubscription_Destroy(sub);
}

// kata send --transport nats: definitions and frames of every stream on its ingest subject, each
// landing in its stream's partition, verified by the same decoder as the ZeroMQ ingest's.
TEST(NatsCluster, SendPublishesEveryStreamInItsPartition) {
  TempDir dir;
  NatsCluster cluster(dir.path().string(), 1);
  ASSERT_EQ(cluster.problem(), "");
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection connection(co);
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, connection.get(), "kata.in.*.*"), NATS_OK);
  natsSubscription_SetPendingLimits(sub, -1, -1);
  ASSERT_TRUE(connection.flush(2000));
  const int streams = 5, frames = 30;
  const std::string command = std::string(KATA_CLI) + " send --transport nats --nats-server " + cluster.url(0) +
                              " --bvh " KATA_DATA_DIR "/cmu/05_18.bvh --streams " + std::to_string(streams) +
                              " --stream-id 1000 --frames " + std::to_string(frames) + " --speed 20 --close 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  transport::Decoder decoder;
  std::map<uint64_t, int> definitions, frames_of;
  std::map<uint64_t, uint64_t> next_sequence;
  for (;;) {
    natsMsg* msg = nullptr;
    if (natsSubscription_NextMsg(&msg, sub, 1000) != NATS_OK) break;
    uint32_t p = 0;
    uint64_t id = 0;
    ASSERT_TRUE(kn::parse_partition_subject("kata", natsMsg_GetSubject(msg), &p, &id));
    EXPECT_EQ(p, kn::partition_of(id, kPartitions));
    const auto kind = decoder.decode(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)));
    ASSERT_NE(kind, transport::MessageKind::kNone) << transport::decode_error_name(decoder.error());
    EXPECT_EQ(decoder.stream_id(), id);
    if (kind == transport::MessageKind::kSkeleton) ++definitions[id];
    if (kind == transport::MessageKind::kFrame) {
      EXPECT_EQ(decoder.frame().sequence, next_sequence[id]) << "stream " << id << ": in order, none lost";
      next_sequence[id] = decoder.frame().sequence + 1;
      ++frames_of[id];
    }
    natsMsg_Destroy(msg);
  }
  natsSubscription_Destroy(sub);
  ASSERT_EQ(frames_of.size(), static_cast<size_t>(streams));
  for (const auto& [id, n] : frames_of) {
    EXPECT_GE(id, 1000u);
    EXPECT_EQ(n, frames) << "stream " << id;
    EXPECT_GE(definitions[id], 2) << "stream " << id << ": the first definition and the closing one";
  }
}

// Three shards in one process: each receives exactly the streams of the partitions it holds (its
// subscriptions, not a filter over everyone's traffic), and only the holder's results go out.
TEST(NatsCluster, ShardsReceiveOnlyTheirPartitions) {
  TempDir dir;
  NatsCluster cluster(dir.path().string(), 3);
  ASSERT_EQ(cluster.problem(), "");
  struct Seen {
    std::mutex mutex;
    std::map<uint64_t, int> messages;  // by stream
    int dropped = 0;
  };
  const std::vector<std::string> names{"shard-a", "shard-b", "shard-c"};
  std::vector<std::unique_ptr<Seen>> seen;
  std::vector<std::unique_ptr<kn::Shard>> shards;
  for (size_t i = 0; i < names.size(); ++i) {
    seen.push_back(std::make_unique<Seen>());
    kn::ShardOptions so;
    so.connection.servers = cluster.urls();
    so.lease.member = names[i];
    Seen* mine = seen.back().get();
    kn::Shard::Handlers h;
    h.on_message = [mine](const void* data, size_t) {
      uint64_t id = 0;
      ASSERT_TRUE(transport::parse_topic(static_cast<const uint8_t*>(data), &id));
      std::lock_guard<std::mutex> lock(mine->mutex);
      ++mine->messages[id];
    };
    h.on_dropped = [mine](uint32_t) {
      std::lock_guard<std::mutex> lock(mine->mutex);
      ++mine->dropped;
    };
    shards.push_back(std::make_unique<kn::Shard>(so, h));
  }
  // Balanced: every partition held by the member rendezvous hashing gives it.
  ASSERT_TRUE(wait_for([&] {
    for (uint32_t p = 0; p < kPartitions; ++p) {
      uint64_t epoch = 0;
      if (!shards[static_cast<size_t>(kn::rendezvous_owner(names, p))]->leases().may_publish(p, &epoch)) return false;
    }
    return true;
  }, 15000));
  for (auto& s : seen) {
    std::lock_guard<std::mutex> lock(s->mutex);
    s->messages.clear();
  }
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection source(co);
  transport::Encoder encoder;
  const float xyz[3] = {0, 1, 0};
  const int streams = 96;
  for (int round = 0; round < 3; ++round)
    for (uint64_t id = 1; id <= streams; ++id) {
      const auto m = encoder.frame(id, static_cast<uint64_t>(round), round, xyz, 1);
      ASSERT_TRUE(source.publish(kn::ingest_subject("kata", id), m.data, m.size));
    }
  // Around the mapping: stream 1's frame published straight to another partition's subject.
  const uint32_t p1 = kn::partition_of(1, kPartitions);
  const auto stray = encoder.frame(1, 99, 99, xyz, 1);
  source.publish("kata.in." + std::to_string((p1 + 1) % kPartitions) + ".0000000000000001", stray.data, stray.size);
  ASSERT_TRUE(source.flush(2000));
  ASSERT_TRUE(wait_for([&] {
    int total = 0;
    for (auto& s : seen) {
      std::lock_guard<std::mutex> lock(s->mutex);
      for (const auto& [id, n] : s->messages) total += n;
    }
    return total >= 3 * streams;
  }, 5000));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  uint64_t wrong = 0;
  for (size_t i = 0; i < names.size(); ++i) {
    std::lock_guard<std::mutex> lock(seen[i]->mutex);
    for (const auto& [id, n] : seen[i]->messages) {
      const uint32_t p = kn::partition_of(id, kPartitions);
      EXPECT_EQ(names[static_cast<size_t>(kn::rendezvous_owner(names, p))], names[i]) << "stream " << id;
      EXPECT_EQ(n, 3) << "stream " << id;
    }
    wrong += shards[i]->counters().wrong_partition;
    // Nothing else reached it: every message it received was one of its own streams'.
    EXPECT_EQ(shards[i]->counters().received, shards[i]->counters().handed_on + shards[i]->counters().wrong_partition);
  }
  EXPECT_EQ(wrong, 1u) << "the frame published around the mapping";
  size_t covered = 0;
  for (auto& s : seen) covered += s->messages.size();
  EXPECT_EQ(covered, static_cast<size_t>(streams));
  // Results: every shard tries every stream; only the holder's go out, under its epoch.
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, source.get(), "kata.out.>"), NATS_OK);
  ASSERT_TRUE(source.flush(2000));
  // flush() answers for the server this connection is on; the others learn of the subscription
  // over their routes a moment later (results published before that would not reach it).
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  int published = 0;
  for (auto& shard : shards)
    for (uint64_t id = 1; id <= streams; ++id) published += shard->publish_result(id, "r", 1);
  EXPECT_EQ(published, streams);
  std::set<uint64_t> results;
  for (int n = 0; n < streams; ++n) {
    natsMsg* msg = nullptr;
    ASSERT_EQ(natsSubscription_NextMsg(&msg, sub, 2000), NATS_OK);
    uint64_t id = 0, epoch = 0;
    const char* owner = nullptr;
    ASSERT_TRUE(kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &epoch, &owner));
    const uint32_t p = kn::partition_of(id, kPartitions);
    EXPECT_EQ(owner, names[static_cast<size_t>(kn::rendezvous_owner(names, p))]);
    uint64_t held_epoch = 0;
    EXPECT_TRUE(shards[static_cast<size_t>(kn::rendezvous_owner(names, p))]->leases().may_publish(p, &held_epoch));
    EXPECT_EQ(epoch, held_epoch);
    results.insert(id);
    natsMsg_Destroy(msg);
  }
  EXPECT_EQ(results.size(), static_cast<size_t>(streams));
  natsSubscription_Destroy(sub);
  // Stopping gives every partition back (each dropped once).
  shards[0]->stop(true);
  EXPECT_EQ(static_cast<size_t>(seen[0]->dropped), shards[0]->counters().leases.acquired);
}

// Child processes killed (SIGKILL) and reaped at scope exit unless reaped before: a failed
// assertion leaves no kata serve behind.
struct Children {
  std::vector<pid_t> pids;
  ~Children() {
    for (pid_t& pid : pids)
      if (pid > 0 && ::kill(pid, SIGKILL) == 0) ::waitpid(pid, nullptr, 0);
  }
};

// What a result says that does not depend on when it was computed: every field but the clocks,
// as bytes (floats bit for bit).
std::string fingerprint(const transport::ResultFields& r) {
  std::string out;
  auto add = [&](const void* p, size_t n) { out.append(static_cast<const char*>(p), n); };
  add(&r.result_sequence, 8);
  add(&r.frame_sequence, 8);
  add(&r.frame_index, 8);
  add(&r.capture_time, 8);
  add(&r.scored, 1);
  add(&r.distance, 4);
  add(&r.score, 4);
  add(r.parts, sizeof r.parts);
  add(&r.matched_teacher_frame, 4);
  add(&r.matched_teacher_time, 8);
  if (r.ghost) add(r.ghost, sizeof(float) * 3 * static_cast<size_t>(r.ghost_joint_count));
  add(r.part_scores, sizeof r.part_scores);
  add(&r.part_to_fix, 4);
  add(&r.state, 4);
  return out;
}

// A stage config's scoring part: the shipped model, a CMU teacher, one worker whose queue holds
// every frame of the run, no frame judged stale (the comparison wants every frame
// scored, whatever the machine's load: under ASan one worker computes about half of the 5,760
// frames a second sent here, and the default queues of 4,096 dropped some).
std::string scoring_config() {
  return "[runtime]\nworkers = 1\nframe_queue_capacity = 16384\n[scoring]\nmodel = \"models/default.kata\"\nteacher = \"" KATA_DATA_DIR
         "/cmu/05_18.bvh\"\nghost = true\n";
}

// The holder of each partition as the lease bucket says now ("" given back or never claimed, "?"
// the bucket could not be read): the servers' own view, not a shard's.
std::vector<std::string> bucket_holders(kn::Connection& connection, const std::string& bucket) {
  std::vector<std::string> out(kPartitions, "?");
  kvStore* kv = nullptr;
  if (js_KeyValue(&kv, connection.jetstream(), bucket.c_str()) != NATS_OK) return out;
  for (uint32_t p = 0; p < kPartitions; ++p) {
    kvEntry* entry = nullptr;
    const natsStatus s = kvStore_Get(&entry, kv, ("p." + std::to_string(p)).c_str());
    if (s == NATS_NOT_FOUND) out[p] = "";
    if (s != NATS_OK || entry == nullptr) continue;
    out[p].assign(static_cast<const char*>(kvEntry_Value(entry)), static_cast<size_t>(kvEntry_ValueLen(entry)));
    kvEntry_Destroy(entry);
  }
  kvStore_Destroy(kv);
  return out;
}

// Whether the lease bucket shows every partition at its rendezvous holder among `names`.
bool at_rendezvous_holders(kn::Connection& connection, const std::vector<std::string>& names) {
  const auto holders = bucket_holders(connection, "kata_leases");
  for (uint32_t p = 0; p < kPartitions; ++p)
    if (holders[p] != names[static_cast<size_t>(kn::rendezvous_owner(names, p))]) return false;
  return true;
}

// kata serve x 3 with [transport] kind = "nats" and kata send --transport nats, 96 streams at 60 Hz
// for a second, scored against a teacher with the ghost: every stream's results come back on NATS
// once each, in order, from the shard rendezvous hashing gives the stream's partition, with its
// definition, equal field for field (floats bit for bit) to one kata serve over ZeroMQ fed the same.
TEST(NatsCluster, ServeShardsMatchOneProcess) {
  TempDir dir;
  const int streams = 96, frames = 60;
  const std::string send_args = " --bvh " KATA_DATA_DIR "/cmu/05_18.bvh --streams " + std::to_string(streams) +
                                " --stream-id 500 --frames " + std::to_string(frames) + " --warmup 0.5";
  // The reference: one kata serve, ZeroMQ in and out.
  std::map<uint64_t, std::vector<std::string>> reference;
  {
    const int in = free_port(), out = free_port();
    const std::string config = dir.file("one.toml");
    std::ofstream(config) << "[ingest]\nendpoints = [\"bind:tcp://127.0.0.1:" << in
                          << "\"]\nkind = \"pull\"\nmax_frame_age_ms = 0\nmax_streams_per_sender = 1024\n[publish]\nendpoints = [\"tcp://127.0.0.1:" << out
                          << "\"]\n" << scoring_config();
    Children children;
    const pid_t serve = spawn({KATA_CLI, "serve", "--config", config}, dir.file("one.log"));
    ASSERT_GT(serve, 0);
    children.pids.push_back(serve);
    void* context = zmq_ctx_new();
    {
      ZmqSubscriber sub(context, "tcp://127.0.0.1:" + std::to_string(out));
      std::this_thread::sleep_for(std::chrono::milliseconds(1000));
      const std::string command = std::string(KATA_CLI) + " send --endpoint tcp://127.0.0.1:" + std::to_string(in) + send_args;
      const pid_t sender = spawn({"/bin/sh", "-c", command}, dir.file("one-send.log"));
      children.pids.push_back(sender);
      transport::Decoder decoder;
      [[maybe_unused]] int malformed = 0;
      int received = 0;
      // The publisher re-sends definitions and stats every second: read until every result came
      // (or nothing new for 3 s, or 60 s in all).
      const int64_t deadline = steady_ns() + 60'000 * kMs;
      for (int n; received < streams * frames && steady_ns() < deadline && (n = sub.receive(3000)) >= 0;) {
        const auto kind = decoder.decode(sub.data(), static_cast<size_t>(n));
        malformed += kind == transport::MessageKind::kNone;  // (the publisher's large Stats messages: not read here)
        if (kind == transport::MessageKind::kResult) {
          reference[decoder.result().stream_id].push_back(fingerprint(decoder.result()));
          ++received;
        }
      }
      int status = -1;
      ::waitpid(sender, &status, 0);
      children.pids[1] = -1;
      EXPECT_EQ(status, 0) << "kata send (ZeroMQ)";
    }
    zmq_ctx_term(context);
    ::kill(serve, SIGTERM);
    ::waitpid(serve, nullptr, 0);
    children.pids[0] = -1;
  }
  auto text_of = [&](const std::string& name) {
    std::ifstream f(dir.file(name));
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  };
  ASSERT_EQ(reference.size(), static_cast<size_t>(streams)) << text_of("one.log") << text_of("one-send.log");
  for (const auto& [id, results] : reference) ASSERT_EQ(results.size(), static_cast<size_t>(frames)) << "reference stream " << id << text_of("one.log") << text_of("one-send.log");

  NatsCluster cluster(dir.path().string(), 3);
  ASSERT_EQ(cluster.problem(), "");
  const std::vector<std::string> names{"serve-a", "serve-b", "serve-c"};
  Children shard_processes;
  std::vector<pid_t>& pids = shard_processes.pids;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string config = dir.file(names[i] + ".toml");
    std::ofstream(config) << "[transport]\nkind = \"nats\"\nservers = [\"" << cluster.url(static_cast<int>(i)) << "\", \""
                          << cluster.url(static_cast<int>((i + 1) % 3)) << "\"]\nshard = \"" << names[i]
                          << "\"\n[ingest]\nmax_frame_age_ms = 0\n" << scoring_config();
    pids.push_back(spawn({KATA_CLI, "serve", "--config", config}, dir.file(names[i] + ".log")));
    ASSERT_GT(pids.back(), 0);
  }
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection consumer(co);
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, consumer.get(), "kata.out.>"), NATS_OK);
  natsSubscription_SetPendingLimits(sub, -1, -1);
  ASSERT_TRUE(consumer.flush(2000));
  // The frames start once the shards have shared the partitions out (the bucket shows every
  // partition at its rendezvous holder), not after a fixed sleep: a shard that starts late under
  // load (CI's sanitizer builds beside) would otherwise see its streams' first frames go to
  // another holder, or to none.
  const auto balanced = [&] { return at_rendezvous_holders(consumer, names); };
  ASSERT_TRUE(wait_for(balanced, 20000)) << "the three shards never held their rendezvous partitions";
  const std::string command = std::string(KATA_CLI) + " send --transport nats --nats-server " + cluster.url(1) + send_args;
  const pid_t sender = spawn({"/bin/sh", "-c", command}, dir.file("nats-send.log"));
  Children send_process{{sender}};
  transport::Decoder decoder;
  kn::EpochFilter epochs;
  std::map<uint64_t, std::vector<std::string>> results;
  std::map<uint64_t, std::set<std::string>> owners;
  std::map<uint64_t, int> definitions;
  int received = 0;
  const int64_t deadline = steady_ns() + 60'000 * kMs;
  while (received < streams * frames && steady_ns() < deadline) {
    natsMsg* msg = nullptr;
    if (natsSubscription_NextMsg(&msg, sub, 3000) != NATS_OK) break;
    uint64_t id = 0, epoch = 0;
    const char* owner = nullptr;
    ASSERT_TRUE(kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &epoch, &owner));
    const auto kind = decoder.decode(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)));
    ASSERT_NE(kind, transport::MessageKind::kNone) << transport::decode_error_name(decoder.error());
    EXPECT_EQ(decoder.stream_id(), id);
    EXPECT_TRUE(epochs.accept(id, epoch));
    received += kind == transport::MessageKind::kResult;
    owners[id].insert(owner);
    if (kind == transport::MessageKind::kResult) results[id].push_back(fingerprint(decoder.result()));
    if (kind == transport::MessageKind::kSkeleton) ++definitions[id];
    natsMsg_Destroy(msg);
  }
  natsSubscription_Destroy(sub);
  int status = -1;
  ::waitpid(sender, &status, 0);
  send_process.pids.clear();
  EXPECT_EQ(status, 0) << "kata send (NATS)";
  for (pid_t pid : pids) ::kill(pid, SIGTERM);
  for (pid_t& pid : pids) {
    int exit_status = -1;
    ::waitpid(pid, &exit_status, 0);
    pid = -1;
    EXPECT_TRUE(WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0) << "kata serve exited with " << exit_status;
  }
  ASSERT_EQ(results.size(), static_cast<size_t>(streams));
  int differing = 0;
  for (const auto& [id, got] : results) {
    ASSERT_EQ(got.size(), static_cast<size_t>(frames)) << "stream " << id << ": one result per frame, none twice";
    if (got != reference[id] && ++differing <= 3) ADD_FAILURE() << "stream " << id << " differs from the one-process run";
    EXPECT_EQ(owners[id], (std::set<std::string>{names[static_cast<size_t>(
                  kn::rendezvous_owner(names, kn::partition_of(id, kPartitions)))]}))
        << "stream " << id;
    EXPECT_GE(definitions[id], 1) << "stream " << id << ": its skeleton definition reached the consumer";
  }
  EXPECT_EQ(differing, 0);
  // Every shard's ingest took only its own streams, refusing nothing.
  for (const auto& name : names) {
    std::ifstream log(dir.file(name + ".log"));
    const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find(" 0 outside their partition"), std::string::npos) << text;
    EXPECT_NE(text.find(" + 0 dropped (not owner"), std::string::npos) << text;
  }
}


// kata serve over NATS hands its messages to the runtime's direct ingest (Runtime::offer), not
// over a private ipc socket: hostile messages on streams' subjects (each with its subject's topic,
// so the shard hands them on) are counted by cause in the ingest and never disturb the stream kata
// send feeds beside them, which keeps every result; and no socket directory is made in TMPDIR
// (until the direct ingest the bridge's socket lived in a kata-nats-* directory there).
TEST(NatsCluster, ServeDirectIngestCountsHostileMessagesByCause) {
  TempDir dir;
  NatsCluster cluster(dir.path().string(), 3);
  ASSERT_EQ(cluster.problem(), "");
  const std::string tmp = dir.file("tmp");
  std::filesystem::create_directories(tmp);
  const std::string config = dir.file("solo.toml");
  std::ofstream(config) << "[transport]\nkind = \"nats\"\nservers = [\"" << cluster.url(0)
                        << "\"]\nshard = \"solo\"\n[ingest]\nmax_frame_age_ms = 0\n" << scoring_config();
  Children children;
  children.pids.push_back(spawn({"/bin/sh", "-c", "TMPDIR=" + tmp + " exec " KATA_CLI " serve --config " + config},
                                dir.file("solo.log")));
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection consumer(co);
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, consumer.get(), "kata.out.>"), NATS_OK);
  natsSubscription_SetPendingLimits(sub, -1, -1);
  ASSERT_TRUE(consumer.flush(2000));
  ASSERT_TRUE(wait_for([&] { return at_rendezvous_holders(consumer, {"solo"}); }, 20000))
      << "the shard never held every partition";
  for (const auto& entry : std::filesystem::directory_iterator(tmp))
    EXPECT_NE(entry.path().filename().string().rfind("kata-nats-", 0), 0u) << "a socket directory: " << entry.path();
  // Hostile: a topic-correct start and junk, on the real stream's subject and on another's.
  const uint64_t real = 500, other = 777;
  int hostile = 0;
  auto attack = [&] {
    for (uint64_t id : {real, other}) {
      char message[64];
      transport::write_topic(id, message);
      std::memset(message + transport::kTopicBytes, 0x5A, sizeof message - transport::kTopicBytes);
      ASSERT_TRUE(consumer.publish(kn::ingest_subject("kata", id), message, sizeof message));
      ++hostile;
    }
  };
  for (int i = 0; i < 10; ++i) attack();
  const int frames = 60;
  const std::string command = std::string(KATA_CLI) + " send --transport nats --nats-server " + cluster.url(1) +
                              " --bvh " KATA_DATA_DIR "/cmu/05_18.bvh --streams 1 --stream-id 500 --frames " +
                              std::to_string(frames) + " --warmup 0.5";
  const pid_t sender = spawn({"/bin/sh", "-c", command}, dir.file("send.log"));
  Children send_process{{sender}};
  for (int i = 0; i < 10; ++i) {  // while the real frames flow
    attack();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(consumer.flush(2000));
  transport::Decoder decoder;
  std::vector<uint64_t> sequences;
  const int64_t deadline = steady_ns() + 60'000 * kMs;
  while (static_cast<int>(sequences.size()) < frames && steady_ns() < deadline) {
    natsMsg* msg = nullptr;
    if (natsSubscription_NextMsg(&msg, sub, 3000) != NATS_OK) break;
    if (decoder.decode(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg))) ==
        transport::MessageKind::kResult) {
      EXPECT_EQ(decoder.result().stream_id, real);
      sequences.push_back(decoder.result().frame_sequence);
    }
    natsMsg_Destroy(msg);
  }
  natsSubscription_Destroy(sub);
  int status = -1;
  ::waitpid(sender, &status, 0);
  send_process.pids.clear();
  EXPECT_EQ(status, 0) << "kata send (NATS)";
  std::vector<uint64_t> want(frames);
  for (int i = 0; i < frames; ++i) want[static_cast<size_t>(i)] = static_cast<uint64_t>(i);
  EXPECT_EQ(sequences, want) << "the real stream: every result once, in order";
  ::kill(children.pids[0], SIGTERM);
  int exit_status = -1;
  ::waitpid(children.pids[0], &exit_status, 0);
  children.pids.clear();
  EXPECT_TRUE(WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0) << "kata serve exited with " << exit_status;
  std::ifstream log(dir.file("solo.log"));
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  // Every hostile message reached the ingest and was counted as malformed, nothing else refused.
  const std::string dropped = "+ " + std::to_string(hostile) + " dropped (not owner 0, limit 0, window 0, stale 0, malformed " +
                              std::to_string(hostile) + ", unknown stream 0,";
  EXPECT_NE(text.find(dropped), std::string::npos) << "want '" << dropped << "' in:\n" << text;
  EXPECT_NE(text.find(" 0 not taken by the ingest"), std::string::npos) << text;
}

// Repetitions reach a NATS consumer as results do: one kata serve shard (a single server) scores
// 02_01 played twice by kata send over NATS against the same clip, its whole length the practice
// section, looped; the stream is closed at the end (the take's end). The consumer of the stream's
// result subject gets a Repetition message (the bytes a ZeroMQ publisher sends) for each play: the
// first when the second begins, the second when the stream closes; both complete, at the
// teacher's tempo, ending where their play ended.
TEST(NatsCluster, ServeRepetitionsPassThrough) {
  TempDir dir;
  NatsCluster cluster(dir.path().string(), 1);
  ASSERT_EQ(cluster.problem(), "");
  const std::string config = dir.file("solo.toml");
  std::ofstream(config) << "[transport]\nkind = \"nats\"\nservers = [\"" << cluster.url(0)
                        << "\"]\nshard = \"solo\"\nlease_replicas = 1\n[ingest]\nmax_frame_age_ms = 0\n"
                        << "[runtime]\nworkers = 1\nframe_queue_capacity = 16384\n[scoring]\nmodel = \"models/default.kata\"\n"
                        << "teacher = \"" KATA_DATA_DIR "/cmu/02_01.bvh\"\nghost = false\n";
  Children children;
  children.pids.push_back(spawn({KATA_CLI, "serve", "--config", config}, dir.file("solo.log")));
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection consumer(co);
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, consumer.get(), "kata.out.>"), NATS_OK);
  natsSubscription_SetPendingLimits(sub, -1, -1);
  ASSERT_TRUE(consumer.flush(2000));
  ASSERT_TRUE(wait_for([&] { return at_rendezvous_holders(consumer, {"solo"}); }, 20000))
      << "the shard never held every partition";
  // 02_01 from frame 1: 343 frames at 120 Hz, one play 343 / 120 s; the section its whole length.
  const int n = 343;
  const double ft = 1.0 / 120.0;
  const std::string command = std::string(KATA_CLI) + " send --transport nats --nats-server " + cluster.url(0) +
                              " --bvh " KATA_DATA_DIR "/cmu/02_01.bvh --streams 1 --stream-id 600 --loops 2 --speed 4"
                              " --loop 0 " + std::to_string((n - 1) * ft) + " --close --warmup 0.5";
  const pid_t sender = spawn({"/bin/sh", "-c", command}, dir.file("send.log"));
  Children send_process{{sender}};
  transport::Decoder decoder;
  std::vector<kata_repetition> reps;
  int results = 0;
  const int64_t deadline = steady_ns() + 60'000 * kMs;
  while (reps.size() < 2 && steady_ns() < deadline) {
    natsMsg* msg = nullptr;
    if (natsSubscription_NextMsg(&msg, sub, 5000) != NATS_OK) break;
    uint64_t id = 0, epoch = 0;
    const char* owner = nullptr;
    EXPECT_TRUE(kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &epoch, &owner));
    const auto kind = decoder.decode(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)));
    if (kind == transport::MessageKind::kResult) ++results;
    if (kind == transport::MessageKind::kRepetition) {
      EXPECT_EQ(id, 600u);
      EXPECT_EQ(decoder.repetition().stream_id, 600u);
      reps.push_back(decoder.repetition());
    }
    natsMsg_Destroy(msg);
  }
  natsSubscription_Destroy(sub);
  int status = -1;
  ::waitpid(sender, &status, 0);
  send_process.pids.clear();
  EXPECT_EQ(status, 0) << "kata send (NATS)";
  ::kill(children.pids[0], SIGTERM);
  ::waitpid(children.pids[0], nullptr, 0);
  children.pids.clear();
  std::ifstream log(dir.file("solo.log"));
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  ASSERT_EQ(reps.size(), 2u) << results << " results\n" << text;
  EXPECT_EQ(results, 2 * n);
  for (size_t i = 0; i < reps.size(); ++i) {
    EXPECT_EQ(reps[i].index, static_cast<int32_t>(i + 1));
    EXPECT_EQ(reps[i].partial, 0) << i;
    EXPECT_NEAR(reps[i].tempo, 1.0, 0.05) << i;
    EXPECT_NEAR(reps[i].end_time, (i + 1) * n * ft, 0.05) << i;
  }
}

// kill -9 of one kata serve shard while frames flow (the failover test with scoring): three
// shards score 24 streams at 60 Hz fed by kata send over NATS; once every stream's results flow
// from its partition's holder, the shard holding the most of them is killed. Its partitions are
// held again (the lease bucket's view) within 5 s, each of its streams resumes at its new holder
// (rendezvous hashing over the two left) from its next skeleton definition, in order and with one
// gap the consumer counts from frame_sequence; every other stream's results have no gap at all;
// every stream's results end with the last frame sent.
TEST(NatsCluster, ServeShardKilledStreamsResume) {
  TempDir dir;
  const int streams = 24, frames = 900;  // 15 s at 60 Hz (05_18 at --speed 0.5)
  const uint64_t first_id = 700;
  NatsCluster cluster(dir.path().string(), 3);
  ASSERT_EQ(cluster.problem(), "");
  const std::vector<std::string> names{"serve-a", "serve-b", "serve-c"};
  std::map<std::string, int> owned;
  for (int k = 0; k < streams; ++k)
    ++owned[names[static_cast<size_t>(kn::rendezvous_owner(names, kn::partition_of(first_id + static_cast<uint64_t>(k), kPartitions)))]];
  std::string victim = names[0];
  for (const auto& n : names)
    if (owned[n] > owned[victim]) victim = n;
  std::vector<std::string> survivors;
  for (const auto& n : names)
    if (n != victim) survivors.push_back(n);
  Children shard_processes;
  std::map<std::string, pid_t> pid_of;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string config = dir.file(names[i] + ".toml");
    std::ofstream(config) << "[transport]\nkind = \"nats\"\nservers = [\"" << cluster.url(static_cast<int>(i)) << "\"]\nshard = \""
                          << names[i] << "\"\n[ingest]\nmax_frame_age_ms = 0\n" << scoring_config();
    pid_of[names[i]] = spawn({KATA_CLI, "serve", "--config", config}, dir.file(names[i] + ".log"));
    ASSERT_GT(pid_of[names[i]], 0);
    shard_processes.pids.push_back(pid_of[names[i]]);
  }
  kn::ConnectionOptions co;
  co.servers = cluster.urls();
  kn::Connection consumer(co);
  // The frames start once the shards have shared the partitions out (the bucket shows every
  // partition at its rendezvous holder): a gap before the kill would be a start-up move, not this test's.
  const auto balanced = [&] { return at_rendezvous_holders(consumer, names); };
  ASSERT_TRUE(wait_for(balanced, 20000)) << "the three shards never held their rendezvous partitions";
  natsSubscription* sub = nullptr;
  ASSERT_EQ(natsConnection_SubscribeSync(&sub, consumer.get(), "kata.out.>"), NATS_OK);
  natsSubscription_SetPendingLimits(sub, -1, -1);
  ASSERT_TRUE(consumer.flush(2000));
  const std::string command = std::string(KATA_CLI) + " send --transport nats --nats-server " + cluster.url(1) +
                              " --bvh " KATA_DATA_DIR "/cmu/05_18.bvh --speed 0.5 --streams " + std::to_string(streams) +
                              " --stream-id " + std::to_string(first_id) + " --frames " + std::to_string(frames) +
                              " --warmup 0.5";
  const pid_t sender = spawn({"/bin/sh", "-c", command}, dir.file("send.log"));
  Children send_process{{sender}};

  struct Got {
    uint64_t sequence;
    int64_t at;
    std::string owner;
  };
  std::map<uint64_t, std::vector<Got>> got;
  transport::Decoder decoder;
  kn::EpochFilter epochs;
  int64_t killed_at = 0;
  std::vector<std::string> before_kill;
  // Partitions held again: polled from the bucket by a thread of its own after the kill.
  std::atomic<int64_t> held_again_at{0};
  std::thread watcher;
  const int64_t deadline = steady_ns() + 90'000 * kMs;
  for (int64_t quiet_since = steady_ns(); steady_ns() < deadline;) {
    natsMsg* msg = nullptr;
    if (natsSubscription_NextMsg(&msg, sub, 200) != NATS_OK) {
      // Done once the sender has exited and nothing came for 3 s.
      if (send_process.pids[0] < 0 && steady_ns() - quiet_since > 3000 * kMs) break;
      int status = 0;
      if (send_process.pids[0] > 0 && ::waitpid(sender, &status, WNOHANG) == sender) {
        send_process.pids[0] = -1;
        EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "kata send exited with " << status;
      }
      continue;
    }
    quiet_since = steady_ns();
    uint64_t id = 0, epoch = 0;
    const char* owner = nullptr;
    // (No ASSERT inside this loop: returning with the watcher thread running would abort.)
    if (!kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &epoch, &owner)) {
      ADD_FAILURE() << "not a result subject: " << natsMsg_GetSubject(msg);
      natsMsg_Destroy(msg);
      continue;
    }
    const bool fresh = epochs.accept(id, epoch);
    const auto kind = decoder.decode(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)));
    if (fresh && kind == transport::MessageKind::kResult) got[id].push_back({decoder.result().frame_sequence, quiet_since, owner});
    natsMsg_Destroy(msg);
    // The kill, once every stream has had two seconds of results from its holder.
    if (killed_at == 0 && static_cast<int>(got.size()) == streams &&
        std::all_of(got.begin(), got.end(), [](const auto& g) { return g.second.back().sequence >= 120; })) {
      before_kill = bucket_holders(consumer, "kata_leases");
      killed_at = steady_ns();
      ::kill(pid_of[victim], SIGKILL);
      ::waitpid(pid_of[victim], nullptr, 0);
      for (pid_t& p : shard_processes.pids)
        if (p == pid_of[victim]) p = -1;
      watcher = std::thread([&, before = before_kill] {
        kn::Connection watching(co);
        while (steady_ns() - killed_at < 20'000 * kMs) {
          const auto now = bucket_holders(watching, "kata_leases");
          bool all = true;
          for (uint32_t p = 0; p < kPartitions; ++p)
            if (before[p] == victim && (now[p] == victim || now[p] == "" || now[p] == "?")) all = false;
          if (all) {
            held_again_at = steady_ns();
            return;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
      });
    }
  }
  natsSubscription_Destroy(sub);
  if (watcher.joinable()) watcher.join();
  // No result of a former tenure arrived after one of a newer: one publisher per stream at a time.
  EXPECT_EQ(epochs.stale(), 0u);
  ASSERT_GT(killed_at, 0) << "the streams never all flowed (" << got.size() << " of " << streams << " streams had results)";
  ASSERT_GT(held_again_at.load(), 0) << victim << "'s partitions were not all held again within 20 s";
  const double held_again_ms = static_cast<double>(held_again_at.load() - killed_at) / 1e6;
  EXPECT_LT(held_again_ms, 5000.0) << victim << "'s partitions held again only after this long";
  double slowest_resume_ms = 0;
  uint64_t gap_frames = 0;
  for (int k = 0; k < streams; ++k) {
    const uint64_t id = first_id + static_cast<uint64_t>(k);
    const auto& v = got[id];
    ASSERT_FALSE(v.empty()) << "stream " << id;
    const std::string& holder = names[static_cast<size_t>(kn::rendezvous_owner(names, kn::partition_of(id, kPartitions)))];
    uint64_t gaps = 0, missing = 0;
    for (size_t i = 1; i < v.size(); ++i) {
      ASSERT_GT(v[i].sequence, v[i - 1].sequence) << "stream " << id << ": results out of order or twice";
      if (v[i].sequence != v[i - 1].sequence + 1) ++gaps, missing += v[i].sequence - v[i - 1].sequence - 1;
    }
    EXPECT_EQ(v.back().sequence, static_cast<uint64_t>(frames - 1)) << "stream " << id << " did not resume to the end";
    if (holder != victim) {
      EXPECT_EQ(v.front().sequence, 0u) << "stream " << id << " of " << holder;
      EXPECT_EQ(gaps, 0u) << "stream " << id << " of " << holder << " (not killed) lost " << missing << " frames";
      for (const auto& g : v) EXPECT_EQ(g.owner, holder) << "stream " << id << " moved";
      continue;
    }
    // The killed shard's stream: one gap around the kill, then results from its new holder only.
    EXPECT_EQ(gaps, 1u) << "stream " << id;
    EXPECT_GT(missing, 0u) << "stream " << id;
    gap_frames += missing;
    const std::string& heir = survivors[static_cast<size_t>(kn::rendezvous_owner(survivors, kn::partition_of(id, kPartitions)))];
    const auto resumed = std::find_if(v.begin(), v.end(), [&](const Got& g) { return g.at > killed_at && g.owner != victim; });
    ASSERT_NE(resumed, v.end()) << "stream " << id << " never resumed";
    EXPECT_EQ(resumed->owner, heir) << "stream " << id;
    for (auto it = resumed; it != v.end(); ++it) EXPECT_EQ(it->owner, heir) << "stream " << id;
    slowest_resume_ms = std::max(slowest_resume_ms, static_cast<double>(resumed->at - killed_at) / 1e6);
  }
  // Resumed: held again, plus at most the sources' definition interval (1 s) and the scoring of the
  // frame; 2 s of margin for a loaded machine.
  EXPECT_LT(slowest_resume_ms, held_again_ms + 3000.0);
  std::printf("[ figures ] %s killed with %d of %d streams: its partitions held again after %.0f ms, its streams "
              "resumed after at most %.0f ms (%llu frames counted missing in all); %d other streams without a gap\n",
              victim.c_str(), owned[victim], streams, held_again_ms, slowest_resume_ms,
              static_cast<unsigned long long>(gap_frames), streams - owned[victim]);
}

// ---------------------------------------------------------------- leases across processes

// One tenure of a partition as a shard's log tells it.
struct Tenure {
  std::string owner;
  uint64_t epoch = 0;
  int64_t start = 0;           // acquired (before publishing began)
  int64_t valid_until = 0;     // the latest valid_until reported
  int64_t ended = LLONG_MAX;   // released / lost
  bool open() const { return ended == LLONG_MAX; }
  int64_t end() const { return std::min(valid_until, ended); }
};

struct Event {
  std::string kind;
  uint32_t partition;
  uint64_t epoch;
  int64_t at, valid_until;
};

class Shards {
 public:
  Shards(const NatsCluster& cluster, const std::string& dir, const std::string& bucket)
      : cluster_(cluster), dir_(dir), bucket_(bucket) {}
  ~Shards() {
    for (auto& [name, pid] : pids_)
      if (pid > 0) ::kill(pid, SIGKILL);
    for (auto& [name, pid] : pids_)
      if (pid > 0) ::waitpid(pid, nullptr, 0);
  }
  // Starts shard `name`, connecting first to server `first_server`.
  void start(const std::string& name, int first_server) {
    AgentOptions o;
    for (int i = 0; i < cluster_.size(); ++i) o.servers.push_back(cluster_.url((first_server + i) % cluster_.size()));
    o.member = name;
    o.bucket = bucket_;
    o.log_file = log(name);
    pids_[name] = spawn(agent_argv(o), dir_ + "/" + name + ".out");
    ASSERT_GT(pids_[name], 0);
  }
  void kill9(const std::string& name) {
    ::kill(pids_[name], SIGKILL);
    ::waitpid(pids_[name], nullptr, 0);
    pids_[name] = -1;
    dead_.insert(name);
  }
  // SIGTERM: the shard gives its partitions back and exits 0.
  void leave(const std::string& name) {
    ::kill(pids_[name], SIGTERM);
    int status = -1;
    ::waitpid(pids_[name], &status, 0);
    pids_[name] = -1;
    dead_.insert(name);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << name << " exited with status " << status;
  }
  std::string log(const std::string& name) const { return dir_ + "/" + name + ".log"; }

  std::vector<Event> events(const std::string& name, uint64_t* reconnects = nullptr, std::string* error = nullptr) const {
    std::vector<Event> out;
    std::ifstream file(log(name));
    std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
    // Only whole lines: the shard may be writing the last one right now.
    text.resize(text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1);
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      std::istringstream ls(line);
      std::string tag;
      ls >> tag;
      if (tag == "E") {
        Event e;
        ls >> e.kind >> e.partition >> e.epoch >> e.at >> e.valid_until;
        out.push_back(e);
      } else if (tag == "R" && reconnects != nullptr) {
        ls >> *reconnects;
      } else if (tag == "X" && error != nullptr) {
        *error = line;
      }
    }
    return out;
  }
  // Every tenure of every partition, from every shard's log.
  std::vector<std::vector<Tenure>> tenures() const {
    std::vector<std::vector<Tenure>> out(kPartitions);
    for (const auto& [name, pid] : pids_) {
      std::map<uint32_t, Tenure> open;
      for (const Event& e : events(name)) {
        if (e.kind == "acquired") {
          open[e.partition] = Tenure{name, e.epoch, e.at, e.valid_until, LLONG_MAX};
        } else if (e.kind == "extended" || e.kind == "resumed" || e.kind == "election") {
          open[e.partition].valid_until = std::max(open[e.partition].valid_until, e.valid_until);
        } else if (e.kind == "released" || e.kind == "lost") {
          Tenure t = open[e.partition];
          t.ended = e.at;
          out[e.partition].push_back(t);
          open.erase(e.partition);
        }
      }
      for (auto& [p, t] : open) out[p].push_back(t);
    }
    for (auto& v : out) std::sort(v.begin(), v.end(), [](const Tenure& a, const Tenure& b) { return a.start < b.start; });
    return out;
  }
  // The holder of each partition now ("" none): an open tenure of a live shard.
  std::vector<std::string> owners() const {
    std::vector<std::string> out(kPartitions);
    const auto all = tenures();
    for (uint32_t p = 0; p < kPartitions; ++p)
      for (const Tenure& t : all[p])
        if (t.open() && !dead_.count(t.owner)) out[p] = t.owner;
    return out;
  }
  bool all_held() const {
    for (const auto& o : owners())
      if (o.empty()) return false;
    return true;
  }
  // Held by the members rendezvous hashing gives them.
  bool balanced(const std::vector<std::string>& live) const {
    std::vector<std::string> sorted = live;
    std::sort(sorted.begin(), sorted.end());
    const auto o = owners();
    for (uint32_t p = 0; p < kPartitions; ++p)
      if (o[p] != sorted[static_cast<size_t>(kn::rendezvous_owner(sorted, p))]) return false;
    return true;
  }
  std::string error(const std::string& name) const {
    std::string e;
    events(name, nullptr, &e);
    return e;
  }

 private:
  const NatsCluster& cluster_;
  std::string dir_, bucket_;
  std::map<std::string, pid_t> pids_;
  std::set<std::string> dead_;
};

// Tenures of a partition that began or ended after t: 0 when it kept its holder throughout.
int changes_since(const std::vector<Tenure>& tenures, int64_t t) {
  int n = 0;
  for (const Tenure& x : tenures) n += (x.start > t) + (!x.open() && x.ended > t);
  return n;
}

// No partition ever had two tenures whose publishing windows overlap.
void expect_one_holder_at_a_time(const std::vector<std::vector<Tenure>>& all) {
  for (uint32_t p = 0; p < kPartitions; ++p) {
    const auto& v = all[p];
    for (size_t i = 1; i < v.size(); ++i) {
      EXPECT_GE(v[i].start, v[i - 1].end())
          << "partition " << p << ": " << v[i].owner << " (epoch " << v[i].epoch << ") began "
          << (v[i - 1].end() - v[i].start) / 1e6 << " ms before " << v[i - 1].owner << " (epoch " << v[i - 1].epoch
          << ") had to stop";
      EXPECT_GT(v[i].epoch, v[i - 1].epoch) << "partition " << p << ": a later tenure has a smaller epoch";
    }
  }
}

// Collects the probe results every shard publishes.
class ProbeSubscriber {
 public:
  explicit ProbeSubscriber(const NatsCluster& cluster) {
    kn::ConnectionOptions co;
    co.servers = cluster.urls();
    connection_ = std::make_unique<kn::Connection>(co);
    natsConnection_Subscribe(&sub_, connection_->get(), kn::all_results_subject("kata").c_str(), &ProbeSubscriber::on_msg,
                             this);
    natsSubscription_SetPendingLimits(sub_, -1, -1);
    // Unsubscribe does not wait for a callback the delivery thread is already in; the completion
    // callback comes after the last one, so the destructor waits for it before the vector goes.
    natsSubscription_SetOnCompleteCB(sub_, &ProbeSubscriber::on_complete, this);
    connection_->flush(2000);
  }
  ~ProbeSubscriber() {
    if (natsSubscription_Unsubscribe(sub_) == NATS_OK) {
      std::unique_lock<std::mutex> lock(mutex_);
      completed_cv_.wait_for(lock, std::chrono::seconds(5), [this] { return completed_; });
    }
    natsSubscription_Destroy(sub_);
  }
  struct Received {
    Probe probe;
    uint64_t epoch;
    std::string owner;
    int64_t at;
  };
  std::vector<Received> received() {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }
  uint64_t malformed() {
    std::lock_guard<std::mutex> lock(mutex_);
    return malformed_;
  }

 private:
  static void on_msg(natsConnection*, natsSubscription*, natsMsg* msg, void* self_ptr) {
    auto* self = static_cast<ProbeSubscriber*>(self_ptr);
    Received r{};
    uint64_t id = 0;
    const char* owner = nullptr;
    std::lock_guard<std::mutex> lock(self->mutex_);
    if (natsMsg_GetDataLength(msg) == sizeof(Probe) &&
        kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &r.epoch, &owner)) {
      std::memcpy(&r.probe, natsMsg_GetData(msg), sizeof(Probe));
      r.owner = owner;
      r.at = steady_ns();
      if (r.probe.stream_id == id) self->received_.push_back(r);
      else ++self->malformed_;
    } else {
      ++self->malformed_;
    }
    natsMsg_Destroy(msg);
  }
  static void on_complete(void* self_ptr) {
    auto* self = static_cast<ProbeSubscriber*>(self_ptr);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->completed_ = true;
    self->completed_cv_.notify_all();
  }
  std::unique_ptr<kn::Connection> connection_;
  natsSubscription* sub_ = nullptr;
  std::mutex mutex_;
  std::condition_variable completed_cv_;
  bool completed_ = false;
  std::vector<Received> received_;
  uint64_t malformed_ = 0;
};

// Every probe was published by a holder inside its tenure, and a subscriber's epoch filter keeps
// each stream's epochs in order. Returns, per stream, the probe times received (after filtering).
void expect_probes_within_tenures(ProbeSubscriber& subscriber, const std::vector<std::vector<Tenure>>& all) {
  const auto received = subscriber.received();
  EXPECT_GT(received.size(), 100u);
  EXPECT_EQ(subscriber.malformed(), 0u);
  int outside = 0;
  for (const auto& r : received) {
    const uint32_t p = kn::partition_of(r.probe.stream_id, kPartitions);
    const Tenure* tenure = nullptr;
    for (const Tenure& t : all[p])
      if (t.owner == r.owner && t.epoch == r.epoch) tenure = &t;
    if (tenure == nullptr) {
      ADD_FAILURE() << "a probe of partition " << p << " from " << r.owner << " epoch " << r.epoch
                    << " matches no tenure";
      continue;
    }
    if (!(r.probe.after_ns > tenure->start && r.probe.before_ns < tenure->end()) && ++outside <= 5)
      ADD_FAILURE() << "partition " << p << ": " << r.owner << " published " << (r.probe.before_ns - tenure->end()) / 1e6
                    << " ms after its tenure ended / " << (tenure->start - r.probe.after_ns) / 1e6 << " ms before it began";
  }
  EXPECT_EQ(outside, 0);
}

struct ClusterTest : ::testing::Test {
  TempDir dir;
  std::unique_ptr<NatsCluster> cluster;
  std::unique_ptr<Shards> shards;
  std::unique_ptr<ProbeSubscriber> probes;
  void SetUp() override {
    cluster = std::make_unique<NatsCluster>(dir.path().string(), 3);
    ASSERT_EQ(cluster->problem(), "");
    shards = std::make_unique<Shards>(*cluster, dir.path().string(), "kata_leases");
    probes = std::make_unique<ProbeSubscriber>(*cluster);
  }
  void TearDown() override {
    probes.reset();
    shards.reset();
    cluster.reset();
    // A failed run keeps the servers' and shards' logs for a look.
    if (HasFailure()) {
      const std::string keep = "/tmp/kata_nats_failed_" + std::to_string(::getpid());
      std::filesystem::copy(dir.path(), keep, std::filesystem::copy_options::recursive);
      std::printf("the servers' and shards' logs: %s\n", keep.c_str());
    }
  }
  void start_three() {
    shards->start("shard-a", 0);
    shards->start("shard-b", 1);
    shards->start("shard-c", 2);
    ASSERT_TRUE(wait_for([&] { return shards->balanced({"shard-a", "shard-b", "shard-c"}); }, 15000))
        << shards->error("shard-a") << shards->error("shard-b") << shards->error("shard-c");
  }
};

// kill -9 of a shard: its partitions are held again within 5 s; no other partition changes hands.
TEST_F(ClusterTest, ShardKilledPartitionsTakenOver) {
  start_three();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const auto before = shards->owners();
  const int64_t killed_at = steady_ns();
  shards->kill9("shard-b");
  ASSERT_TRUE(wait_for([&] { return shards->balanced({"shard-a", "shard-c"}); }, 8000));
  const auto all = shards->tenures();
  const auto after = shards->owners();
  double slowest_ms = 0;
  int moved = 0;
  for (uint32_t p = 0; p < kPartitions; ++p) {
    if (before[p] != "shard-b") {
      EXPECT_EQ(after[p], before[p]) << "partition " << p << " was not shard-b's and moved";
      EXPECT_EQ(changes_since(all[p], killed_at), 0) << "partition " << p << " was not shard-b's and was interrupted";
      continue;
    }
    ++moved;
    const Tenure& t = all[p].back();
    EXPECT_NE(t.owner, "shard-b");
    slowest_ms = std::max(slowest_ms, (t.start - killed_at) / 1e6);
  }
  EXPECT_GT(moved, 0);
  EXPECT_LT(slowest_ms, 5000.0) << "the slowest takeover";
  std::printf("[ figures ] %d partitions of the killed shard held again after at most %.0f ms\n", moved, slowest_ms);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  expect_one_holder_at_a_time(shards->tenures());
  expect_probes_within_tenures(*probes, shards->tenures());
}

// JetStream's view of the lease bucket's stream: the server that leads it ("" none answered within
// timeout_ms through any server: no leader, during an election).
std::string kv_leader(const NatsCluster& cluster, int timeout_ms = 2000) {
  natsConnection* nc = nullptr;
  std::string leader;
  const auto urls = cluster.urls();
  for (const auto& u : urls) {
    if (natsConnection_ConnectTo(&nc, u.c_str()) != NATS_OK) continue;
    natsMsg* reply = nullptr;
    if (natsConnection_RequestString(&reply, nc, "$JS.API.STREAM.INFO.KV_kata_leases", "", timeout_ms) == NATS_OK) {
      const std::string body(natsMsg_GetData(reply), static_cast<size_t>(natsMsg_GetDataLength(reply)));
      const auto at = body.find("\"leader\":\"");
      if (at != std::string::npos) leader = body.substr(at + 10, body.find('"', at + 10) - at - 10);
      natsMsg_Destroy(reply);
    }
    natsConnection_Destroy(nc);
    if (!leader.empty()) break;
  }
  return leader;
}

// kill -9 of the NATS server that leads the lease bucket (the worst one to lose): the shards
// reconnect, no partition changes hands, and no lease pauses: through the bucket's election (no
// leader, as the witnesses prove) every holder publishes on, each partition's probes without a gap
// longer than 0.5 s, every probe inside its holder's tenure and no two tenures overlapping (the
// invariant that lets a consumer keep every result of the newest epoch).
TEST_F(ClusterTest, ServerKilledOwnershipUnchanged) {
  start_three();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const std::string leader = kv_leader(*cluster);
  int victim = -1;
  for (int i = 0; i < cluster->size(); ++i)
    if (NatsCluster::name(i) == leader) victim = i;
  ASSERT_GE(victim, 0) << "no leader of the lease bucket found (\"" << leader << "\")";
  const std::string connected = std::string("shard-") + static_cast<char>('a' + victim);  // its first server
  const auto before = shards->owners();
  const int64_t killed_at = steady_ns();
  cluster->kill(victim);
  // The bucket has no leader until JetStream elects one (raft's election timeout: 4-9 s in NATS 2.9).
  const bool elected = wait_for([&] { const auto l = kv_leader(*cluster, 300); return !l.empty() && l != leader; }, 20000);
  const double election_ms = (steady_ns() - killed_at) / 1e6;
  EXPECT_TRUE(elected) << "no new leader of the lease bucket within 20 s";
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // renewals go on with the new leader
  uint64_t reconnects = 0;
  shards->events(connected, &reconnects);
  EXPECT_GE(reconnects, 1u) << connected << " was connected to the killed server";
  EXPECT_EQ(shards->owners(), before) << "ownership changed";
  const auto all = shards->tenures();
  for (uint32_t p = 0; p < kPartitions; ++p)
    EXPECT_EQ(changes_since(all[p], killed_at), 0) << "partition " << p << " changed hands";
  int paused = 0, through_election = 0;
  for (const char* s : {"shard-a", "shard-b", "shard-c"})
    for (const Event& e : shards->events(s)) {
      if (e.at < killed_at) continue;
      paused += e.kind == "paused";
      through_election += e.kind == "election";
    }
  EXPECT_EQ(paused, 0) << "leases paused through the election";
  // Each partition's probes (every 50 ms) from the kill to now: no gap longer than 0.5 s.
  std::map<uint64_t, std::vector<int64_t>> at;
  for (const auto& r : probes->received())
    if (r.probe.before_ns >= killed_at - 1000 * kMs) at[r.probe.stream_id].push_back(r.probe.before_ns);
  EXPECT_EQ(at.size(), static_cast<size_t>(kPartitions)) << "partitions whose probes went on";
  double longest_ms = 0;
  uint64_t worst = 0;
  const int64_t until = steady_ns() - 200 * kMs;
  for (auto& [id, v] : at) {
    std::sort(v.begin(), v.end());
    v.push_back(until);
    for (size_t i = 1; i < v.size(); ++i)
      if ((v[i] - v[i - 1]) / 1e6 > longest_ms) longest_ms = (v[i] - v[i - 1]) / 1e6, worst = id;
  }
  EXPECT_LE(longest_ms, 500.0) << "the longest gap in a partition's probes (stream " << worst << ")";
  std::printf("[ figures ] the lease bucket's leader %s killed: a new one after %.0f ms; %s reconnected %llu time(s); "
              "%d lease extensions through the election, %d pauses; the longest gap in a partition's probes %.0f ms "
              "(limit 500)\n",
              leader.c_str(), election_ms, connected.c_str(), static_cast<unsigned long long>(reconnects), through_election,
              paused, longest_ms);
  expect_one_holder_at_a_time(all);
  expect_probes_within_tenures(*probes, all);
}

// A fourth shard joins, then leaves: exactly the partitions rendezvous hashing gives it move to it,
// and back to their former holders when it leaves; no other partition is interrupted.
TEST_F(ClusterTest, ShardJoinsAndLeavesMovesOnlyItsPartitions) {
  start_three();
  const auto three = shards->owners();
  std::vector<std::string> four{"shard-a", "shard-b", "shard-c", "shard-d"};
  std::set<uint32_t> expected_moves;
  for (uint32_t p = 0; p < kPartitions; ++p)
    if (kn::rendezvous_owner(four, p) == 3) expected_moves.insert(p);
  const int64_t joined_at = steady_ns();
  shards->start("shard-d", 0);
  ASSERT_TRUE(wait_for([&] { return shards->balanced(four); }, 8000)) << shards->error("shard-d");
  const double join_ms = (steady_ns() - joined_at) / 1e6;
  const auto with_d = shards->owners();
  std::set<uint32_t> moved;
  for (uint32_t p = 0; p < kPartitions; ++p)
    if (with_d[p] != three[p]) moved.insert(p);
  EXPECT_EQ(moved, expected_moves);
  const int64_t left_at = steady_ns();
  shards->leave("shard-d");
  ASSERT_TRUE(wait_for([&] { return shards->balanced({"shard-a", "shard-b", "shard-c"}); }, 8000));
  const double leave_ms = (steady_ns() - left_at) / 1e6;
  EXPECT_EQ(shards->owners(), three);
  const auto all = shards->tenures();
  double longest_gap_ms = 0;
  for (uint32_t p = 0; p < kPartitions; ++p) {
    if (!expected_moves.count(p)) {
      EXPECT_EQ(changes_since(all[p], joined_at), 0) << "partition " << p << " should not have moved";
      continue;
    }
    // The former holder's tenure ends, shard-d's begins and ends, the former holder's begins.
    EXPECT_EQ(changes_since(all[p], joined_at), 4) << "partition " << p;
    ASSERT_GE(all[p].size(), 3u) << "partition " << p;
    const size_t n = all[p].size();
    EXPECT_EQ(all[p][n - 2].owner, "shard-d");
    for (size_t i = n - 2; i < n; ++i) longest_gap_ms = std::max(longest_gap_ms, (all[p][i].start - all[p][i - 1].end()) / 1e6);
  }
  EXPECT_LT(longest_gap_ms, 2000.0);
  std::printf("[ figures ] %zu partitions moved to the joining shard (balanced after %.0f ms) and back when it left (%.0f ms); "
              "longest handover gap %.0f ms\n",
              moved.size(), join_ms, leave_ms, longest_gap_ms);
  expect_one_holder_at_a_time(all);
  expect_probes_within_tenures(*probes, all);
}

// ---------------------------------------------------------------- kata serve through deaths

// Whether the lease bucket has a leader and every other replica is current (a restarted server
// has caught up), as JetStream says.
bool bucket_caught_up(const NatsCluster& cluster) {
  for (const auto& u : cluster.urls()) {
    natsConnection* nc = nullptr;
    if (natsConnection_ConnectTo(&nc, u.c_str()) != NATS_OK) continue;
    natsMsg* reply = nullptr;
    bool ok = false;
    if (natsConnection_RequestString(&reply, nc, "$JS.API.STREAM.INFO.KV_kata_leases", "", 1000) == NATS_OK) {
      const std::string body(natsMsg_GetData(reply), static_cast<size_t>(natsMsg_GetDataLength(reply)));
      size_t current = 0;
      for (size_t at = body.find("\"current\":true"); at != std::string::npos; at = body.find("\"current\":true", at + 1))
        ++current;
      ok = body.find("\"leader\":\"n") != std::string::npos && current + 1 >= static_cast<size_t>(cluster.size()) &&
           body.find("\"offline\":true") == std::string::npos;
      natsMsg_Destroy(reply);
    }
    natsConnection_Destroy(nc);
    return ok;
  }
  return false;
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ",") + s;
  return out;
}

// Three `kata serve` shards on a 3-server cluster, fed by `kata send --transport nats` (24 streams
// at 60 Hz), every server list given as the docs write it (comma-separated); a consumer thread
// keeps each stream's results (after the epoch filter) with their arrival times.
struct ServeRun {
  static constexpr int kStreams = 24;
  TempDir dir;
  std::unique_ptr<NatsCluster> cluster;
  const std::vector<std::string> names{"serve-a", "serve-b", "serve-c"};
  const uint64_t first_id;
  Children shard_processes, other_processes;
  std::map<std::string, pid_t> pid_of;
  std::unique_ptr<kn::Connection> consumer;
  natsSubscription* sub = nullptr;
  std::thread receiver;
  std::atomic<bool> stop{false};
  struct Got {
    uint64_t sequence;
    int64_t at;
    std::string owner;
    uint64_t epoch;
  };
  std::mutex mutex;
  std::map<uint64_t, std::vector<Got>> got;  // mutex
  uint64_t stale = 0;                         // mutex

  explicit ServeRun(uint64_t first) : first_id(first) {}
  ~ServeRun() {
    finish();
    // A failed run keeps the servers' and shards' logs for a look.
    if (::testing::Test::HasFailure()) {
      const std::string keep = "/tmp/kata_nats_failed_" + std::to_string(::getpid()) + "_" + std::to_string(first_id);
      std::error_code ignored;
      std::filesystem::copy(dir.path(), keep, std::filesystem::copy_options::recursive, ignored);
      std::printf("the servers' and shards' logs: %s\n", keep.c_str());
    }
  }
  std::string holder(uint64_t id) const {
    return names[static_cast<size_t>(kn::rendezvous_owner(names, kn::partition_of(id, kPartitions)))];
  }
  // "" or what went wrong.
  std::string start() {
    cluster = std::make_unique<NatsCluster>(dir.path().string(), 3);
    if (!cluster->problem().empty()) return cluster->problem();
    for (size_t i = 0; i < names.size(); ++i) {
      // Shard a: one comma-separated string; b: an array holding one such list; c: an array of URLs.
      std::vector<std::string> u;
      for (int k = 0; k < 3; ++k) u.push_back(cluster->url((static_cast<int>(i) + k) % 3));
      const std::string servers = i == 0 ? "\"" + join(u) + "\"" : i == 1 ? "[\"" + join(u) + "\"]"
                                                                          : "[\"" + u[0] + "\", \"" + u[1] + "\", \"" + u[2] + "\"]";
      const std::string config = dir.file(names[i] + ".toml");
      std::ofstream(config) << "[transport]\nkind = \"nats\"\nservers = " << servers << "\nshard = \"" << names[i]
                            << "\"\n[ingest]\nmax_frame_age_ms = 0\n" << scoring_config();
      pid_of[names[i]] = spawn({KATA_CLI, "serve", "--config", config}, dir.file(names[i] + ".log"));
      if (pid_of[names[i]] <= 0) return "cannot start kata serve";
      shard_processes.pids.push_back(pid_of[names[i]]);
    }
    kn::ConnectionOptions co;
    co.servers = cluster->urls();
    consumer = std::make_unique<kn::Connection>(co);
    if (!wait_for([&] { return at_rendezvous_holders(*consumer, names); }, 20000))
      return "the three shards never held their rendezvous partitions";
    if (natsConnection_SubscribeSync(&sub, consumer->get(), "kata.out.>") != NATS_OK) return "cannot subscribe";
    natsSubscription_SetPendingLimits(sub, -1, -1);
    consumer->flush(2000);
    receiver = std::thread([this] { receive(); });
    // 05_18 at --speed 0.5: 60 frames a second per stream, ~30 s a loop, for up to 2 minutes (stopped before).
    const std::string command = std::string(KATA_CLI) + " send --transport nats --nats-server " + join(cluster->urls()) +
                                " --bvh " KATA_DATA_DIR "/cmu/05_18.bvh --speed 0.5 --streams " + std::to_string(kStreams) +
                                " --stream-id " + std::to_string(first_id) + " --loops 4 --warmup 0.5";
    other_processes.pids.push_back(spawn({"/bin/sh", "-c", "exec " + command}, dir.file("send.log")));
    // Flowing: every stream has had two seconds of results.
    if (!wait_for([&] {
          std::lock_guard<std::mutex> lock(mutex);
          if (static_cast<int>(got.size()) < kStreams) return false;
          for (const auto& [id, v] : got)
            if (v.back().sequence < 120) return false;
          return true;
        }, 40000))
      return "the streams never all flowed";
    return "";
  }
  void receive() {
    transport::Decoder decoder;
    kn::EpochFilter epochs;
    while (!stop.load()) {
      natsMsg* msg = nullptr;
      if (natsSubscription_NextMsg(&msg, sub, 100) != NATS_OK) continue;
      const int64_t at = steady_ns();
      uint64_t id = 0, epoch = 0;
      const char* owner = nullptr;
      if (kn::parse_result_subject("kata", natsMsg_GetSubject(msg), &id, &epoch, &owner)) {
        const bool fresh = epochs.accept(id, epoch);
        const auto kind = decoder.decode(natsMsg_GetData(msg), static_cast<size_t>(natsMsg_GetDataLength(msg)));
        std::lock_guard<std::mutex> lock(mutex);
        if (!fresh) ++stale;
        else if (kind == transport::MessageKind::kResult) got[id].push_back({decoder.result().frame_sequence, at, owner, epoch});
      }
      natsMsg_Destroy(msg);
    }
  }
  void finish() {
    stop.store(true);
    if (receiver.joinable()) receiver.join();
    if (sub != nullptr) natsSubscription_Destroy(sub);
    sub = nullptr;
  }
  // The longest time without a result of stream id within [from, to] (the window's edges count).
  double longest_gap_ms(uint64_t id, int64_t from, int64_t to, int64_t* where = nullptr) {
    std::lock_guard<std::mutex> lock(mutex);
    int64_t last = from, longest = 0;
    for (const Got& g : got[id]) {
      if (g.at < from) continue;
      if (g.at > to) break;
      if (g.at - last > longest) {
        longest = g.at - last;
        if (where != nullptr) *where = last;
      }
      last = g.at;
    }
    if (to - last > longest) {
      longest = to - last;
      if (where != nullptr) *where = last;
    }
    return static_cast<double>(longest) / 1e6;
  }
  // Stops each shard with SIGINT and returns its log (its stop line says each partition's pauses).
  std::map<std::string, std::string> stop_shards() {
    for (pid_t pid : shard_processes.pids)
      if (pid > 0) ::kill(pid, SIGINT);
    std::map<std::string, std::string> logs;
    for (const auto& n : names) {
      pid_t& pid = pid_of[n];
      if (pid <= 0) continue;
      bool exited = false;
      for (int i = 0; i < 300 && !exited; ++i) {
        exited = ::waitpid(pid, nullptr, WNOHANG) == pid;
        if (!exited) std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      if (!exited) ::kill(pid, SIGKILL), ::waitpid(pid, nullptr, 0);
      for (pid_t& p : shard_processes.pids)
        if (p == pid) p = -1;
      pid = -1;
      std::ifstream in(dir.file(n + ".log"));
      logs[n] = std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    }
    return logs;
  }
};

// A line-per-result subscriber process whose output file is polled: each new result line's
// arrival time (within the 20 ms poll), for the C sample (it prints no time of its own).
class LineWatcher {
 public:
  explicit LineWatcher(std::string file) : file_(std::move(file)), thread_([this] { run(); }) {}
  ~LineWatcher() {
    stop_.store(true);
    thread_.join();
  }
  std::vector<int64_t> arrivals() {
    std::lock_guard<std::mutex> lock(mutex_);
    return arrivals_;
  }
  std::string text() {
    std::lock_guard<std::mutex> lock(mutex_);
    return text_;
  }

 private:
  void run() {
    std::string line;  // the last line, until its end arrives
    while (!stop_.load()) {
      std::ifstream in(file_, std::ios::binary);
      in.seekg(static_cast<std::streamoff>(read_));
      const std::string more((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      const int64_t now = steady_ns();
      read_ += more.size();
      std::lock_guard<std::mutex> lock(mutex_);
      text_ += more;
      for (char c : more) {
        if (c != '\n') {
          line += c;
          continue;
        }
        if (line.compare(0, 7, "stream ") == 0) arrivals_.push_back(now);
        line.clear();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  std::string file_;
  std::atomic<bool> stop_{false};
  size_t read_ = 0;  // [the thread]
  std::mutex mutex_;
  std::string text_;
  std::vector<int64_t> arrivals_;
  std::thread thread_;
};

double longest_gap_ms(std::vector<int64_t> at, int64_t from, int64_t to) {
  std::sort(at.begin(), at.end());
  int64_t last = from, longest = 0;
  for (int64_t t : at) {
    if (t < from || t > to) continue;
    longest = std::max(longest, t - last);
    last = t;
  }
  return static_cast<double>(std::max(longest, to - last)) / 1e6;
}

// kill -9 of the server that leads the lease bucket, then of each other server in turn (each
// killed one started again, and caught up, before the next), while three kata serve shards score
// 24 streams x 60 Hz: no stream's results stop for more than 0.5 s, no partition changes hands,
// nothing arrives twice or out of order, and every stream's kept results come from one holder and
// one epoch. Each shard's stop line names the partitions it published through an election.
// Python's kata.Subscriber and the C sample, each given the three URLs as one comma-separated
// list, follow a stream throughout: each loses its server once and goes on receiving.
TEST(NatsCluster, ServeServerKillsPauseNoStream) {
  ServeRun run(1100);
  const std::string problem = run.start();
  ASSERT_EQ(problem, "") << problem;
  const std::string all_urls = join(run.cluster->urls());
  // The subscribers, on the first stream.
  const uint64_t followed = run.first_id;
  std::unique_ptr<LineWatcher> c_lines;
#ifdef KATA_C_SUBSCRIBER
  run.other_processes.pids.push_back(
      spawn({KATA_C_SUBSCRIBER, all_urls, std::to_string(followed)}, run.dir.file("c_subscriber.log")));
  c_lines = std::make_unique<LineWatcher>(run.dir.file("c_subscriber.log"));
#endif
#ifdef KATA_PYTHON_FOLLOW
  run.other_processes.pids.push_back(
      spawn({"/usr/bin/env", "KATA_LIBRARY=" KATA_LIBRARY_FILE, "PYTHONPATH=" KATA_PYTHONPATH, "PYTHONDONTWRITEBYTECODE=1",
             "/usr/bin/python3", KATA_PYTHON_FOLLOW, all_urls, std::to_string(followed)},
            run.dir.file("python_subscriber.log")));
#endif
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the subscribers are in
  const auto holders_before = bucket_holders(*run.consumer, "kata_leases");
  const std::string leader = kv_leader(*run.cluster);
  int first = -1;
  for (int i = 0; i < 3; ++i)
    if (NatsCluster::name(i) == leader) first = i;
  ASSERT_GE(first, 0) << "no leader of the lease bucket (\"" << leader << "\")";
  const int64_t from = steady_ns();
  std::vector<int64_t> kills;
  for (int k = 0; k < 3; ++k) {
    const int victim = (first + k) % 3;
    const std::string led = kv_leader(*run.cluster);
    const int64_t killed_at = steady_ns();
    kills.push_back(killed_at);
    run.cluster->kill(victim);
    // Until the bucket has a leader among the servers left (an election when the victim led it).
    const bool elected = wait_for([&] { const auto l = kv_leader(*run.cluster, 300); return !l.empty() && l != NatsCluster::name(victim); }, 20000);
    const double elected_ms = (steady_ns() - killed_at) / 1e6;
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // renewals on the new leader
    ASSERT_TRUE(elected) << "the lease bucket had no leader 20 s after " << NatsCluster::name(victim) << " was killed";
    ASSERT_TRUE(run.cluster->restart(victim)) << NatsCluster::name(victim) << " did not come back";
    const bool caught_up = wait_for([&] { return bucket_caught_up(*run.cluster); }, 20000);
    EXPECT_TRUE(caught_up) << NatsCluster::name(victim) << " did not catch up with the lease bucket in 20 s";
    std::this_thread::sleep_for(std::chrono::milliseconds(1000));
    double worst_ms = 0;
    uint64_t worst_id = 0;
    for (int i = 0; i < ServeRun::kStreams; ++i) {
      const uint64_t id = run.first_id + static_cast<uint64_t>(i);
      const double g = run.longest_gap_ms(id, killed_at - 500 * kMs, steady_ns() - 300 * kMs);
      if (g > worst_ms) worst_ms = g, worst_id = id;
    }
    std::printf("[ figures ] %s killed (%s the lease bucket; a leader again after %.0f ms): the longest gap in a "
                "stream's results %.0f ms (stream %llu; limit 500)\n",
                NatsCluster::name(victim).c_str(), led == NatsCluster::name(victim) ? "it led" : "it did not lead", elected_ms,
                worst_ms, static_cast<unsigned long long>(worst_id));
  }
  const int64_t to = steady_ns() - 300 * kMs;
  for (pid_t& pid : run.other_processes.pids)  // the sender first, then the subscribers: all done
    if (pid > 0) ::kill(pid, SIGKILL), ::waitpid(pid, nullptr, 0), pid = -1;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  run.finish();
  EXPECT_EQ(bucket_holders(*run.consumer, "kata_leases"), holders_before) << "ownership changed";
  double longest = 0;
  for (int i = 0; i < ServeRun::kStreams; ++i) {
    const uint64_t id = run.first_id + static_cast<uint64_t>(i);
    const auto& v = run.got[id];
    ASSERT_FALSE(v.empty()) << "stream " << id;
    std::set<std::pair<std::string, uint64_t>> tenures;
    for (size_t j = 0; j < v.size(); ++j) {
      tenures.insert({v[j].owner, v[j].epoch});
      if (j > 0) {
        ASSERT_GT(v[j].sequence, v[j - 1].sequence) << "stream " << id << ": a result twice or out of order";
      }
    }
    EXPECT_EQ(tenures.size(), 1u) << "stream " << id << ": results of more than one holder or tenure kept";
    EXPECT_EQ(v.front().owner, run.holder(id)) << "stream " << id;
    int64_t where = 0;
    const double g = run.longest_gap_ms(id, from, to, &where);
    longest = std::max(longest, g);
    EXPECT_LE(g, 500.0) << "stream " << id << ": no result for this long, from " << (where - from) / 1e6
                        << " ms after the first kill (kills at " << (kills[0] - from) / 1e6 << ", " << (kills[1] - from) / 1e6
                        << ", " << (kills[2] - from) / 1e6 << " ms)";
  }
  EXPECT_EQ(run.stale, 0u) << "results of an older tenure after a newer one's";
  // The subscribers given three URLs: each lost its server (every server died once) and went on.
  if (c_lines) {
    const double g = longest_gap_ms(c_lines->arrivals(), from, to);
    const std::string text = c_lines->text();
    EXPECT_NE(text.find("reconnected to"), std::string::npos) << "the C sample never lost its server:\n" << text.substr(0, 400);
    EXPECT_LE(g, 1000.0) << "the C sample's longest silence";
    std::printf("[ figures ] the C sample (three URLs): the longest gap in its stream's results %.0f ms\n", g);
  }
#ifdef KATA_PYTHON_FOLLOW
  {
    std::ifstream in(run.dir.file("python_subscriber.log"));
    std::vector<int64_t> at;
    int servers_seen = 0;
    std::string all;
    for (std::string line; std::getline(in, line);) {
      all += line + "\n";
      if (line.compare(0, 10, "connected ") == 0) ++servers_seen;
      else if (!line.empty() && line[0] >= '0' && line[0] <= '9') at.push_back(std::stoll(line));
    }
    const double g = longest_gap_ms(at, from, to);
    EXPECT_GE(servers_seen, 2) << "Python's Subscriber never moved to another server:\n" << all.substr(0, 400);
    EXPECT_LE(g, 1000.0) << "Python's Subscriber's longest silence";
    std::printf("[ figures ] Python's Subscriber (three URLs): %d servers read from, the longest gap in its stream's "
                "results %.0f ms\n", servers_seen, g);
  }
#endif
  std::printf("[ figures ] three servers killed in turn: the longest gap in any stream's results %.0f ms (limit 500)\n", longest);
  // The operator's view: every shard's stop line says which partitions it published through an
  // election, and none paused.
  for (const auto& [name, log] : run.stop_shards()) {
    const auto at = log.find("NATS partition pauses: ");
    ASSERT_NE(at, std::string::npos) << name << ":\n" << log.substr(log.size() > 2000 ? log.size() - 2000 : 0);
    const std::string line = log.substr(at, log.find('\n', at) - at);
    EXPECT_EQ(line.find("lease lapsed"), std::string::npos) << name << ": " << line;
    EXPECT_EQ(line.find("taken over"), std::string::npos) << name << ": " << line;
    std::printf("[ figures ] %s: %s\n", name.c_str(), line.substr(0, 300).c_str());
  }
}

// kill -9 of a kata serve shard, then 15 s later of the server leading the lease bucket: the
// shard's streams move once (to the shard rendezvous hashing gives them among the two left, within
// 5 s), and the server's death moves nothing and stops no stream for more than 0.5 s (a fresh
// watcher still shows the dead shard's last membership: no partition may go back to it).
TEST(NatsCluster, ServeShardThenServerKilledStreamsMoveOnce) {
  ServeRun run(1300);
  const std::string problem = run.start();
  ASSERT_EQ(problem, "") << problem;
  std::map<std::string, int> owned;
  for (int i = 0; i < ServeRun::kStreams; ++i) ++owned[run.holder(run.first_id + static_cast<uint64_t>(i))];
  std::string victim = run.names[0];
  for (const auto& n : run.names)
    if (owned[n] > owned[victim]) victim = n;
  std::vector<std::string> survivors;
  for (const auto& n : run.names)
    if (n != victim) survivors.push_back(n);
  const int64_t from = steady_ns();
  const int64_t shard_killed = steady_ns();
  ::kill(run.pid_of[victim], SIGKILL);
  ::waitpid(run.pid_of[victim], nullptr, 0);
  for (pid_t& p : run.shard_processes.pids)
    if (p == run.pid_of[victim]) p = -1;
  run.pid_of[victim] = -1;
  std::this_thread::sleep_for(std::chrono::nanoseconds(shard_killed + 15'000 * kMs - steady_ns()));
  const std::string leader = kv_leader(*run.cluster);
  int server = -1;
  for (int i = 0; i < 3; ++i)
    if (NatsCluster::name(i) == leader) server = i;
  ASSERT_GE(server, 0) << "no leader of the lease bucket (\"" << leader << "\")";
  const int64_t server_killed = steady_ns();
  run.cluster->kill(server);
  const bool elected = wait_for([&] { const auto l = kv_leader(*run.cluster, 300); return !l.empty() && l != leader; }, 20000);
  const double elected_ms = (steady_ns() - server_killed) / 1e6;
  EXPECT_TRUE(elected) << "the lease bucket had no leader 20 s after its leader was killed";
  std::this_thread::sleep_for(std::chrono::milliseconds(4000));  // past a dead member's ttl on a fresh watcher
  const int64_t to = steady_ns() - 300 * kMs;
  for (pid_t& pid : run.other_processes.pids)
    if (pid > 0) ::kill(pid, SIGKILL), ::waitpid(pid, nullptr, 0), pid = -1;
  run.finish();
  double slowest_move = 0, longest_other = 0, longest_after_server = 0;
  for (int i = 0; i < ServeRun::kStreams; ++i) {
    const uint64_t id = run.first_id + static_cast<uint64_t>(i);
    const auto& v = run.got[id];
    ASSERT_FALSE(v.empty()) << "stream " << id;
    int moves = 0;
    for (size_t j = 1; j < v.size(); ++j) {
      ASSERT_GT(v[j].sequence, v[j - 1].sequence) << "stream " << id << ": a result twice or out of order";
      moves += v[j].owner != v[j - 1].owner;
    }
    const std::string& holder = run.holder(id);
    if (holder != victim) {
      EXPECT_EQ(moves, 0) << "stream " << id << " of " << holder << " moved";
      int64_t where = 0;
      const double g = run.longest_gap_ms(id, from, to, &where);
      longest_other = std::max(longest_other, g);
      EXPECT_LE(g, 500.0) << "stream " << id << " of " << holder << " (not killed): from " << (where - server_killed) / 1e6
                          << " ms after the server's death";
      continue;
    }
    // The killed shard's stream: one move, to its heir, within 5 s; then no gap through the server's death.
    EXPECT_EQ(moves, 1) << "stream " << id << " moved " << moves << " times";
    const std::string heir = survivors[static_cast<size_t>(kn::rendezvous_owner(survivors, kn::partition_of(id, kPartitions)))];
    EXPECT_EQ(v.back().owner, heir) << "stream " << id;
    const auto resumed = std::find_if(v.begin(), v.end(), [&](const ServeRun::Got& g) { return g.owner != victim; });
    ASSERT_NE(resumed, v.end()) << "stream " << id << " never resumed";
    const double move_ms = run.longest_gap_ms(id, from, resumed->at);
    slowest_move = std::max(slowest_move, move_ms);
    EXPECT_LE(move_ms, 5000.0) << "stream " << id << ": the move";
    int64_t where = 0;
    const double g = run.longest_gap_ms(id, resumed->at, to, &where);
    longest_after_server = std::max(longest_after_server, g);
    EXPECT_LE(g, 500.0) << "stream " << id << " after it moved: from " << (where - server_killed) / 1e6
                        << " ms after the server's death";
  }
  EXPECT_EQ(run.stale, 0u);
  std::printf("[ figures ] %s killed: its %d streams moved once, silent at most %.0f ms (limit 5000); %s (the lease "
              "bucket's leader) killed 15 s later, a leader again after %.0f ms: the moved streams' longest gap since they "
              "resumed %.0f ms, the others' %.0f ms (limit 500)\n",
              victim.c_str(), owned[victim], slowest_move, leader.c_str(), elected_ms, longest_after_server, longest_other);
  for (const auto& [name, log] : run.stop_shards()) {
    const auto at = log.find("NATS partition pauses: ");
    ASSERT_NE(at, std::string::npos) << name;
    const std::string line = log.substr(at, log.find('\n', at) - at);
    EXPECT_NE(line.find("taken over 1x"), std::string::npos) << name << " took none of " << victim << "'s partitions: " << line;
    EXPECT_EQ(line.find("taken over 2x"), std::string::npos) << name << ": " << line;
    std::printf("[ figures ] %s: %s\n", name.c_str(), line.substr(0, 300).c_str());
  }
}

}  // namespace
}  // namespace kata::test

int main(int argc, char** argv) {
  if (argc >= 2 && std::strcmp(argv[1], "--agent") == 0) return kata::test::run_agent(argc - 2, argv + 2);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
