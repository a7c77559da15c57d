#include "transport/nats/partition.hpp"

#include <cstring>

#include "transport/nats/topic.hpp"

namespace kata::transport::nats {

uint32_t fnv1a32(const void* data, size_t size) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  uint32_t h = 2166136261u;
  for (size_t i = 0; i < size; ++i) {
    h ^= bytes[i];
    h *= 16777619u;
  }
  return h;
}

uint32_t partition_of(uint64_t stream_id, uint32_t partitions) {
  if (partitions == 0) return 0;
  char topic[kStreamTopicBytes];
  write_stream_topic(stream_id, topic);
  return fnv1a32(topic, kStreamTopicBytes) % partitions;
}

namespace {
std::string topic_string(uint64_t stream_id) {
  char topic[kStreamTopicBytes];
  write_stream_topic(stream_id, topic);
  return std::string(topic, kStreamTopicBytes);
}
}  // namespace

std::string ingest_subject(const std::string& prefix, uint64_t stream_id) {
  return prefix + ".in." + topic_string(stream_id);
}

std::string partition_subject(const std::string& prefix, uint32_t partition) {
  return prefix + ".in." + std::to_string(partition) + ".*";
}

std::string result_subject(const std::string& prefix, uint64_t stream_id) {
  return prefix + ".out." + topic_string(stream_id) + ".>";
}

std::string all_results_subject(const std::string& prefix) { return prefix + ".out.>"; }

bool parse_partition_subject(const std::string& prefix, const char* subject, uint32_t* partition,
                             uint64_t* stream_id) {
  // Compared in place: a shard reads every message's subject here (nothing allocated per message).
  if (subject == nullptr || std::strncmp(subject, prefix.c_str(), prefix.size()) != 0 ||
      std::strncmp(subject + prefix.size(), ".in.", 4) != 0)
    return false;
  const char* p = subject + prefix.size() + 4;
  uint32_t value = 0;
  int digits = 0;
  for (; *p >= '0' && *p <= '9'; ++p) {
    if (++digits > 6) return false;
    value = value * 10 + static_cast<uint32_t>(*p - '0');
  }
  if (digits == 0 || *p != '.') return false;
  ++p;
  if (std::strlen(p) != kStreamTopicBytes) return false;
  uint64_t id = 0;
  if (!read_stream_topic(p, &id)) return false;
  *partition = value;
  *stream_id = id;
  return true;
}

std::string server_mapping(const std::string& prefix, uint32_t partitions) {
  return "mappings { \"" + prefix + ".in.*\": \"" + prefix + ".in.{{partition(" + std::to_string(partitions) +
         ",1)}}.{{wildcard(1)}}\" }";
}

bool valid_member_name(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

uint64_t rendezvous_weight(const std::string& member, uint32_t partition) {
  uint64_t h = 14695981039346656037ull;
  for (char c : member) {
    h ^= static_cast<uint8_t>(c);
    h *= 1099511628211ull;
  }
  for (int i = 0; i < 4; ++i) {
    h ^= (partition >> (8 * i)) & 0xffu;
    h *= 1099511628211ull;
  }
  // FNV's low bits mix poorly over the last bytes: finish with splitmix64's mixer so that the
  // order of two members' weights is not decided by the partition's last byte alone.
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  h ^= h >> 31;
  return h;
}

int rendezvous_owner(const std::vector<std::string>& members, uint32_t partition) {
  int best = -1;
  uint64_t best_weight = 0;
  for (size_t i = 0; i < members.size(); ++i) {
    const uint64_t w = rendezvous_weight(members[i], partition);
    if (best < 0 || w > best_weight || (w == best_weight && members[i] < members[static_cast<size_t>(best)])) {
      best = static_cast<int>(i);
      best_weight = w;
    }
  }
  return best;
}

}  // namespace kata::transport::nats
