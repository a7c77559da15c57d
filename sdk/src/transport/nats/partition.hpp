// Where a stream's messages travel on NATS and which shard scores it (docs/deploy.md, "NATS").
//
// Sources publish a stream's frames and skeleton definitions on `<prefix>.in.<topic>` (topic: the
// stream id as 16 lowercase hex digits, kata/runtime.h; topic.hpp). Every NATS server of the cluster carries the
// subject mapping server_mapping() writes, which rewrites that subject to
// `<prefix>.in.<partition>.<topic>` with partition = FNV-1a 32 of the topic modulo the partition
// count (the server's `{{partition(n,1)}}`); a shard subscribes to `<prefix>.in.<p>.*` for each
// partition p it holds, so it receives only its own streams' traffic. Results go out on
// `<prefix>.out.<topic>.<epoch>.<owner>` (results.hpp). partition_of() computes the server's partition here, so a shard can
// refuse a message that reached a partition subject its stream does not hash to (published to the
// mapped subject directly), and a test can check both sides agree.
//
// Partitions are assigned to the live shards by rendezvous (highest random weight) hashing: each
// partition goes to the member with the largest weight(member, partition), so adding or removing
// one member moves only the partitions that member wins or held (about 1/N of them).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace kata::transport::nats {

// 64 partitions by default: enough for 64 shards, few enough that a shard's subscriptions and
// leases (one KV key each) stay cheap. Every server's mapping and every shard must agree on it.
inline constexpr uint32_t kDefaultPartitions = 64;
// Subjects start with this unless configured otherwise ([transport] subject_prefix).
inline constexpr const char* kDefaultPrefix = "kata";

// FNV-1a 32 (offset basis 2166136261, prime 16777619) over bytes: the hash of the servers'
// `{{partition(n, ...)}}` subject transform.
uint32_t fnv1a32(const void* data, size_t size);

// The partition the servers' mapping puts a stream in: fnv1a32 of its 16-hex-digit topic modulo
// partitions (0 when partitions is 0).
uint32_t partition_of(uint64_t stream_id, uint32_t partitions);

// `<prefix>.in.<topic>`: where a source publishes a stream's frames and definitions.
std::string ingest_subject(const std::string& prefix, uint64_t stream_id);
// `<prefix>.in.<partition>.*`: what the holder of a partition subscribes to.
std::string partition_subject(const std::string& prefix, uint32_t partition);
// `<prefix>.out.<topic>.>`: one stream's results (published on `<topic>.<epoch>.<owner>`, results.hpp).
std::string result_subject(const std::string& prefix, uint64_t stream_id);
// `<prefix>.out.>`: every stream's results.
std::string all_results_subject(const std::string& prefix);
// Reads a mapped ingest subject `<prefix>.in.<partition>.<topic>`; false when it is not one.
bool parse_partition_subject(const std::string& prefix, const char* subject, uint32_t* partition,
                             uint64_t* stream_id);

// The `mappings` block every server of the cluster carries (one line, NATS server config syntax).
std::string server_mapping(const std::string& prefix, uint32_t partitions);

// A member name usable as a KV key token and a NATS header value: 1..64 of [A-Za-z0-9_-].
bool valid_member_name(const std::string& name);

// The rendezvous weight of (member, partition): a 64-bit mix of FNV-1a 64 over the member name
// and the partition number. Stable across versions and machines (every shard computes the same).
uint64_t rendezvous_weight(const std::string& member, uint32_t partition);
// The member that should hold a partition: the largest weight (ties: the smaller name); -1 when
// members is empty, else its index in members.
int rendezvous_owner(const std::vector<std::string>& members, uint32_t partition);

}  // namespace kata::transport::nats
