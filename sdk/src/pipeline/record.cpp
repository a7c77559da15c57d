#include "pipeline/record.hpp"

#include <algorithm>
#include <cstring>

namespace kata::pipeline {

void fill_record(const Result& r, uint32_t ghost_joint_count, kata_result_record* out) noexcept {
  kata_result_record k{};
  k.struct_size = sizeof k;
  k.scored = r.scored ? 1 : 0;
  k.result_sequence = r.sequence;
  k.frame_sequence = static_cast<uint64_t>(r.frame_index);
  k.frame_index = r.frame_index;
  k.capture_time = r.capture_time;
  k.arrival_ns = r.arrival_ns;
  k.computed_ns = r.computed_ns;
  k.matched_teacher_frame = -1;
  k.matched_teacher_time = -1.0;
  k.part_to_fix = -1;
  k.cue_joint = -1;
  k.cue_action = -1;
  if (r.scored) {
    const metric::ScoreRecord& s = r.score;
    k.matched_teacher_frame = r.matched_frame;
    k.matched_teacher_time = s.matched_time;
    k.state = static_cast<int32_t>(s.state);
    k.distance = s.distance;
    k.score = s.score;
    std::copy(s.parts, s.parts + KATA_PART_COUNT, k.parts);
    std::copy(s.part_scores, s.part_scores + KATA_PART_COUNT, k.part_scores);
    k.part_to_fix = s.part_to_fix;
    k.cue_joint = s.cue_joint;
    k.cue_degrees = s.cue_degrees;
    k.cue_action = s.cue_action;
    k.repetition = r.repetition;
    k.repetition_progress = r.repetition_progress;
  }
  k.ghost_joint_count = r.has_ghost ? ghost_joint_count : 0u;
  *out = k;
}

void fill_repetition(const metric::Repetition& r, uint64_t stream_id, kata_repetition* out) noexcept {
  kata_repetition k{};
  k.struct_size = sizeof k;
  k.index = r.index;
  k.stream_id = stream_id;
  k.start_time = r.start_time;
  k.end_time = r.end_time;
  k.tempo = r.tempo;
  k.score = r.score;
  k.partial = r.partial ? 1 : 0;
  k.part_to_fix = r.part_to_fix;
  k.cue_joint = r.cue_joint;
  k.cue_degrees = r.cue_degrees;
  k.cue_action = r.cue_action;
  static_assert(KATA_ROM_JOINT_COUNT == metric::kRomJoints, "the ABI's joints are the counter's");
  std::copy(r.range, r.range + KATA_ROM_JOINT_COUNT, k.range);
  std::copy(r.teacher_range, r.teacher_range + KATA_ROM_JOINT_COUNT, k.teacher_range);
  k.coverage = r.coverage;
  *out = k;
}

void copy_record_out(const kata_result_record& record, uint32_t caller_size, void* out) noexcept {
  std::memcpy(out, &record, std::min<size_t>(caller_size, sizeof record));
  std::memcpy(out, &caller_size, sizeof caller_size);
}

void copy_record_in(const kata_result_record* record, kata_result_record* out) noexcept {
  std::memcpy(static_cast<void*>(out), record, std::min<size_t>(record->struct_size, sizeof *out));
  out->struct_size = sizeof *out;
}

}  // namespace kata::pipeline
