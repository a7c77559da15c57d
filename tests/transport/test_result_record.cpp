// The one result record (kata/result.h) across its translations: a record encoded by the runtime's
// wire codec (Encoder::result) and read back through the C ABI (kata_message_read_result, libkata)
// keeps every field; the other verified kata messages a subscriber meets on the results' socket
// (stats, practice settings) are "no result" (KATA_NO_DATA), not corrupt.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <deque>
#include <vector>

#include "kata/kata.h"
#include "transport/wire.hpp"

namespace {

using kata::transport::Bytes;
using kata::transport::Encoder;
using kata::transport::ResultFields;

// The record's ghost points into the message (kata.h: valid while the message is), so every copy
// read here is kept until the test ends.
kata_status read(const Bytes& m, kata_result_record* out) {
  static std::deque<std::vector<uint8_t>> kept;
  kept.emplace_back(m.data, m.data + m.size);
  return kata_message_read_result(kept.back().data(), kept.back().size(), out);
}

TEST(runtime_result_record, EveryFieldSurvivesTheWireAndTheCAbi) {
  Encoder encoder;
  ResultFields r;
  r.stream_id = 0x1234;
  r.result_sequence = 11;
  r.frame_sequence = 12;
  r.frame_index = 13;
  r.capture_time = 1712345678.125;  // an epoch-scale source clock: seconds, kept to the ns on the wire
  r.arrival_ns = 2;
  r.computed_ns = 3;
  r.published_ns = 4;
  r.scored = 1;
  r.matched_teacher_frame = 99;
  r.state = KATA_SCORE_TEACHER_FINISHED;
  r.matched_teacher_time = 0.825;
  r.distance = 0.25f;
  r.score = 75.0f;
  for (int i = 0; i < KATA_PART_COUNT; ++i) r.parts[i] = 0.01f * static_cast<float>(i + 1);
  for (int i = 0; i < KATA_PART_COUNT; ++i) r.part_scores[i] = 50.0f + static_cast<float>(i);
  r.part_to_fix = KATA_PART_LEFT_LEG;
  const float ghost[6] = {1, 2, 3, 4, 5, 6};
  r.ghost = ghost;
  r.ghost_joint_count = 2;
  r.has_practice = 1;
  r.practice_revision = 7;
  r.practice_start_time = 1.25;
  r.practice_end_time = 3.5;
  r.practice_loop = 1;
  r.cue_joint = 11;  // LKnee, in part_to_fix
  r.cue_degrees = 29.75f;
  r.cue_action = KATA_CUE_BEND;

  kata_result_record o;
  std::memset(&o, 0xab, sizeof o);
  o.struct_size = sizeof o;
  ASSERT_EQ(read(encoder.result(r), &o), KATA_OK);
  EXPECT_EQ(o.struct_size, sizeof o);
  EXPECT_EQ(o.scored, 1);
  EXPECT_EQ(o.stream_id, 0x1234u);
  EXPECT_EQ(o.result_sequence, 11u);
  EXPECT_EQ(o.frame_sequence, 12u);
  EXPECT_EQ(o.frame_index, 13);
  EXPECT_NEAR(o.capture_time, 1712345678.125, 1e-6);
  EXPECT_EQ(o.arrival_ns, 2);
  EXPECT_EQ(o.computed_ns, 3);
  EXPECT_EQ(o.published_ns, 4);
  EXPECT_EQ(o.matched_teacher_frame, 99);
  EXPECT_EQ(o.state, KATA_SCORE_TEACHER_FINISHED);
  EXPECT_EQ(o.matched_teacher_time, 0.825);
  EXPECT_EQ(o.distance, 0.25f);
  EXPECT_EQ(o.score, 75.0f);
  for (int i = 0; i < KATA_PART_COUNT; ++i) EXPECT_EQ(o.parts[i], r.parts[i]) << i;
  for (int i = 0; i < KATA_PART_COUNT; ++i) EXPECT_EQ(o.part_scores[i], r.part_scores[i]) << i;
  EXPECT_EQ(o.part_to_fix, KATA_PART_LEFT_LEG);
  ASSERT_EQ(o.ghost_joint_count, 2u);
  ASSERT_NE(o.ghost, nullptr);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(o.ghost[i], ghost[i]) << i;
  EXPECT_EQ(o.has_practice, 1);
  EXPECT_EQ(o.practice_revision, 7u);
  EXPECT_EQ(o.practice_start_time, 1.25);
  EXPECT_EQ(o.practice_end_time, 3.5);
  EXPECT_EQ(o.practice_loop, 1);
  EXPECT_EQ(o.cue_joint, 11);
  EXPECT_EQ(o.cue_degrees, 29.75f);
  EXPECT_EQ(o.cue_action, KATA_CUE_BEND);
  EXPECT_STREQ(kata_gpd_joint_name(o.cue_joint), "LKnee");
  char text[64];
  EXPECT_EQ(kata_cue_text(&o, text, sizeof text), std::strlen("left knee: bend 30 deg more"));
  EXPECT_STREQ(text, "left knee: bend 30 deg more");

  // A record built before the cue (up to reserved0): nothing written past it, and no text.
  kata_result_record v10;
  std::memset(&v10, 0xab, sizeof v10);
  v10.struct_size = static_cast<uint32_t>(offsetof(kata_result_record, cue_joint));
  ASSERT_EQ(read(encoder.result(r), &v10), KATA_OK);
  EXPECT_EQ(v10.practice_loop, 1);
  EXPECT_FALSE(KATA_RESULT_HAS(&v10, cue_joint));
  EXPECT_EQ(v10.cue_joint, static_cast<int32_t>(0xabababab));
  EXPECT_EQ(kata_cue_text(&v10, text, sizeof text), 0u);
  EXPECT_STREQ(text, "");

  // No cue (the writer's default, as from a writer older than the cue): -1, 0, -1.
  ResultFields none;
  none.stream_id = 0x1234;
  ASSERT_EQ(read(encoder.result(none), &o), KATA_OK);
  EXPECT_EQ(o.cue_joint, -1);
  EXPECT_EQ(o.cue_degrees, 0.0f);
  EXPECT_EQ(o.cue_action, KATA_CUE_NONE);
  EXPECT_EQ(kata_cue_text(&o, text, sizeof text), 0u);
  EXPECT_EQ(kata_gpd_joint_name(16), nullptr);
  EXPECT_EQ(kata_gpd_joint_name(-1), nullptr);

  // A caller built with a shorter record receives its prefix and nothing past it.
  kata_result_record old;
  std::memset(&old, 0xab, sizeof old);
  old.struct_size = static_cast<uint32_t>(offsetof(kata_result_record, part_scores));
  ASSERT_EQ(read(encoder.result(r), &old), KATA_OK);
  EXPECT_EQ(old.struct_size, offsetof(kata_result_record, part_scores));
  EXPECT_EQ(old.score, 75.0f);
  EXPECT_FALSE(KATA_RESULT_HAS(&old, part_to_fix));
  unsigned char tail[sizeof old - offsetof(kata_result_record, part_scores)];
  std::memcpy(tail, reinterpret_cast<const unsigned char*>(&old) + offsetof(kata_result_record, part_scores), sizeof tail);
  for (unsigned char c : tail) ASSERT_EQ(c, 0xab);
}

// Fails on 1.0's first cut (capi_runtime.cpp returned KATA_E_PARSE for every verified message that
// was not a result or a skeleton definition): Python's read_message raised on a valid stats
// message and Subscriber counted them as refused.
TEST(runtime_result_record, StatsAndPracticeMessagesAreNoResultNotCorrupt) {
  Encoder encoder;
  kata_result_record o;
  o.struct_size = sizeof o;
  kata::transport::StatsFields stats;
  stats.published_ns = 5;
  EXPECT_EQ(read(encoder.stats(stats), &o), KATA_NO_DATA);
  kata::transport::PracticeSetting practice;
  practice.stream_id = 3;
  practice.revision = 1;
  practice.teacher_start = 0.5;
  EXPECT_EQ(read(encoder.practice(practice), &o), KATA_NO_DATA);
  // A truncated stats message is still refused.
  const Bytes m = encoder.stats(stats);
  std::vector<uint8_t> cut(m.data, m.data + m.size - 8);
  EXPECT_EQ(kata_message_read_result(cut.data(), cut.size(), &o), KATA_E_PARSE);
}

}  // namespace
