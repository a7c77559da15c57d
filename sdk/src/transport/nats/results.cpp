#include "transport/nats/results.hpp"

#include <cstdio>
#include <cstring>

#include "transport/nats/topic.hpp"

namespace kata::transport::nats {

bool format_result_subject(char* out, size_t capacity, const std::string& prefix, uint64_t stream_id,
                           uint64_t epoch, const std::string& owner) {
  char topic[kStreamTopicBytes + 1];
  write_stream_topic(stream_id, topic);
  topic[kStreamTopicBytes] = '\0';
  const int n = std::snprintf(out, capacity, "%s.out.%s.%llu.%s", prefix.c_str(), topic,
                              static_cast<unsigned long long>(epoch), owner.c_str());
  return n > 0 && static_cast<size_t>(n) < capacity;
}

bool parse_result_subject(const std::string& prefix, const char* subject, uint64_t* stream_id, uint64_t* epoch,
                          const char** owner) {
  if (subject == nullptr || std::strncmp(subject, prefix.c_str(), prefix.size()) != 0 ||
      std::strncmp(subject + prefix.size(), ".out.", 5) != 0)
    return false;
  const char* p = subject + prefix.size() + 5;
  if (std::strlen(p) < kStreamTopicBytes + 4 || p[kStreamTopicBytes] != '.') return false;
  uint64_t id = 0;
  if (!read_stream_topic(p, &id)) return false;
  p += kStreamTopicBytes + 1;
  uint64_t e = 0;
  int digits = 0;
  for (; *p >= '0' && *p <= '9'; ++p) {
    if (++digits > 19) return false;
    e = e * 10 + static_cast<uint64_t>(*p - '0');
  }
  if (digits == 0 || *p != '.' || p[1] == '\0') return false;
  *stream_id = id;
  *epoch = e;
  *owner = p + 1;
  return true;
}

bool EpochFilter::accept(uint64_t stream_id, uint64_t epoch) {
  auto it = newest_.find(stream_id);
  if (it == newest_.end()) {
    if (newest_.size() >= max_streams_) {
      ++untracked_;
      return true;
    }
    newest_.emplace(stream_id, epoch);
    return true;
  }
  if (epoch < it->second) {
    ++stale_;
    return false;
  }
  if (epoch > it->second) {
    ++handovers_;
    it->second = epoch;
  }
  return true;
}

}  // namespace kata::transport::nats
