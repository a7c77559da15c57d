// The ingest's stream table (ingest_table.hpp: the rules).
#include "transport/ingest_table.hpp"

namespace kata::transport {

SenderToken key_sender(const char* user_id) {
  uint64_t h = 14695981039346656037ULL;
  for (const char* c = user_id; *c; ++c) {
    h ^= static_cast<uint8_t>(*c);
    h *= 1099511628211ULL;
  }
  return h | (1ULL << 63);
}

TableVerdict IngestTable::judge_definition(SenderToken sender, uint64_t id, uint32_t revision, bool* is_new) const {
  *is_new = false;
  const auto it = streams_.find(id);
  if (it != streams_.end()) {
    const Stream& s = it->second;
    if (s.owner != sender && s.owner != kNoOwner) return TableVerdict::kNotOwner;
    if (s.owner == sender && s.revision == revision) return TableVerdict::kRepeated;
    return TableVerdict::kAccepted;  // a new revision, or an orphan claimed: a restart
  }
  if (streams_.size() >= limits_.max_streams) return TableVerdict::kLimit;
  const auto sender_it = senders_.find(sender);
  if (sender_it != senders_.end() && sender_it->second.streams >= limits_.max_streams_per_sender)
    return TableVerdict::kLimit;
  *is_new = true;
  return TableVerdict::kAccepted;
}

void IngestTable::commit_definition(SenderToken sender, uint64_t id, uint32_t revision, int joints, int64_t now_ns) {
  Stream& s = streams_[id];
  if (s.owner != sender) {
    if (s.owner != kNoOwner) {
      auto previous = senders_.find(s.owner);
      if (previous != senders_.end() && previous->second.streams > 0) --previous->second.streams;
    }
    ++senders_[sender].streams;
    s.owner = sender;
  }
  const bool reopened = s.any_frame;
  s.revision = revision;
  s.joints = joints;
  s.restart_next = reopened;
  s.any_frame = false;
  s.candidate_run = 0;
  s.has_offset = false;
  s.last_activity_ns = now_ns;
  s.has_practice = false;  // a reopened stream's pipeline takes the setting again
}

TableVerdict IngestTable::judge_practice(SenderToken sender, uint64_t id, uint32_t revision) const {
  const auto it = streams_.find(id);
  if (it == streams_.end()) return TableVerdict::kUnknownStream;
  const Stream& s = it->second;
  if (s.owner != sender) return TableVerdict::kNotOwner;
  if (s.has_practice && s.practice_revision == revision) return TableVerdict::kRepeated;
  return TableVerdict::kAccepted;
}

void IngestTable::commit_practice(uint64_t id, uint32_t revision, int64_t now_ns) {
  const auto it = streams_.find(id);
  if (it == streams_.end()) return;
  it->second.has_practice = true;
  it->second.practice_revision = revision;
  it->second.last_activity_ns = now_ns;
}

TableVerdict IngestTable::judge_close(SenderToken sender, uint64_t id) const {
  const auto it = streams_.find(id);
  if (it == streams_.end()) return TableVerdict::kUnknownStream;
  if (it->second.owner != sender) return TableVerdict::kNotOwner;
  return TableVerdict::kAccepted;
}

void IngestTable::forget(uint64_t id) {
  const auto it = streams_.find(id);
  if (it == streams_.end()) return;
  auto owner = senders_.find(it->second.owner);
  if (owner != senders_.end() && owner->second.streams > 0) --owner->second.streams;
  streams_.erase(it);
}

TableVerdict IngestTable::judge_frame(SenderToken sender, uint64_t id, uint64_t sequence, int64_t capture_ns,
                                      int joints, int64_t now_ns, bool* restarted, uint64_t* gap, int64_t* age_ns) {
  *restarted = false;
  *gap = 0;
  *age_ns = -1;
  const auto it = streams_.find(id);
  if (it == streams_.end()) return TableVerdict::kUnknownStream;
  Stream& s = it->second;
  if (s.owner != sender) return TableVerdict::kNotOwner;
  if (joints != s.joints) return TableVerdict::kWrongJoints;
  bool restart = false;
  if (s.restart_next) {
    restart = true;
  } else if (s.any_frame) {
    if (sequence == 0 && s.last_sequence > 0) {
      restart = true;
    } else if (sequence <= s.last_sequence) {
      return TableVerdict::kOutOfOrder;
    } else if (sequence - s.last_sequence > limits_.sequence_window) {
      // One wild number must not move the stream; a source that really jumped says so again.
      if (s.candidate_run > 0 && sequence > s.candidate && sequence - s.candidate <= limits_.sequence_window) {
        ++s.candidate_run;
      } else {
        s.candidate_run = 1;
      }
      s.candidate = sequence;
      if (s.candidate_run < kResync) return TableVerdict::kOutOfWindow;
      restart = true;
    } else {
      *gap = sequence - s.last_sequence - 1;
    }
  }
  // Age by the stream's clock (a restart starts a new clock).
  const int64_t offset = now_ns - capture_ns;  // wraps harmlessly for wild capture times
  if (restart) s.has_offset = false;
  if (!s.has_offset || offset < s.min_offset_ns) {
    s.min_offset_ns = offset;
    s.has_offset = true;
  }
  const int64_t age = offset - s.min_offset_ns;
  *age_ns = age;
  if (limits_.max_frame_age_ns > 0 && age > limits_.max_frame_age_ns && !restart) {
    // Stale: dropped, but its number is taken (a later fresh frame is not out of order).
    s.last_sequence = sequence;
    s.candidate_run = 0;
    s.last_activity_ns = now_ns;
    if (s.stale_run == 0) s.stale_run_first_ns = now_ns, s.stale_run_first_age = age;
    if (s.stale_run <= kStaleRunToExplain) ++s.stale_run;  // stops one past: explained once per run
    s.stale_run_last_ns = now_ns, s.stale_run_last_age = age;
    return TableVerdict::kStale;
  }
  s.stale_run = 0;
  s.any_frame = true;
  s.restart_next = false;
  s.last_sequence = sequence;
  s.candidate_run = 0;
  s.last_activity_ns = now_ns;
  *restarted = restart;
  return TableVerdict::kAccepted;
}

void IngestTable::sender_gone(SenderToken sender) {
  if (is_key_sender(sender)) return;
  for (auto& [id, s] : streams_)
    if (s.owner == sender) s.owner = kNoOwner;
  senders_.erase(sender);
}

void IngestTable::expire(int64_t now_ns, std::vector<uint64_t>* expired) {
  if (limits_.idle_ns <= 0) return;
  for (auto it = streams_.begin(); it != streams_.end();) {
    if (now_ns - it->second.last_activity_ns > limits_.idle_ns) {
      expired->push_back(it->first);
      auto owner = senders_.find(it->second.owner);
      if (owner != senders_.end() && owner->second.streams > 0) --owner->second.streams;
      it = streams_.erase(it);
    } else {
      ++it;
    }
  }
}

bool IngestTable::stale_run_to_explain(uint64_t id, double* age_growth, int64_t* age_ns) const {
  const auto it = streams_.find(id);
  if (it == streams_.end()) return false;
  const Stream& s = it->second;
  // The frame that made the run kStaleRunToExplain long (the count stops there until a fresh one).
  if (s.stale_run != kStaleRunToExplain || s.stale_run_last_ns == s.stale_run_first_ns) return false;
  if (s.stale_run_last_age <= s.stale_run_first_age) return false;  // a backlog draining: ages fall
  *age_growth = static_cast<double>(s.stale_run_last_age - s.stale_run_first_age) /
                static_cast<double>(s.stale_run_last_ns - s.stale_run_first_ns);
  *age_ns = s.stale_run_last_age;
  return true;
}

bool IngestTable::first_refusal(SenderToken sender, TableVerdict cause) {
  const auto it = senders_.find(sender);
  Sender* s = nullptr;
  if (it != senders_.end()) {
    s = &it->second;
  } else {
    // Bounded: one entry per connection (dropped when it closes) or allowed key.
    s = &senders_[sender];
  }
  const uint32_t bit = 1u << static_cast<int>(cause);
  if (s->logged & bit) return false;
  s->logged |= bit;
  return true;
}

}  // namespace kata::transport
