// Repetitions through the C ABI (kata/result.h kata_repetition; docs/coach/repetitions.md): a
// stream's kata_stream_read_repetitions, a runtime's on_repetition for the same frames, and the
// Repetition message's writer and reader. libkata only.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kata/kata.h"
#include "support/capi_fixture.hpp"

namespace {

struct Got {
  std::vector<kata_repetition> reps;
  std::vector<int32_t> record_reps;  // the records' repetition field, in order
};
void on_result(void* user, const kata_result_record* r) {
  if (KATA_RESULT_HAS(r, repetition)) static_cast<Got*>(user)->record_reps.push_back(r->repetition);
}
void on_repetition(void* user, const kata_repetition* r) { static_cast<Got*>(user)->reps.push_back(*r); }

// 02_01 (its n frames after the T-pose) played `frames` frames on end against itself, looped, through
// a stream alone and a runtime's stream: the repetitions each saw, the stream's read after it was
// flushed (the take's end) and the runtime's after it stopped.
struct Played {
  std::vector<kata_repetition> read;  // the stream alone's, flushed at the end
  Got got;                            // the runtime's (on_result, on_repetition)
  uint32_t n = 0;
  double ft = 0.0;
};

class reps_capi : public kata::test::CapiClips {
 protected:
  reps_capi() : CapiClips(KATA_DATA_DIR "/cmu/02_01.bvh", KATA_DATA_DIR "/cmu/02_01.bvh") {}

  // A stream with the teacher attached (no ghost), the whole clip its practice section, looped.
  kata_stream open_looped() {
    kata_stream s = open(1024);
    if (!s) return nullptr;
    kata_teacher_desc td = kata::test::clip_teacher_desc(model, teacher);
    td.ghost = 0;
    EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK) << kata_stream_last_error(s);
    EXPECT_EQ(kata_stream_set_practice_section(s, 0, -1, 1), KATA_OK) << kata_stream_last_error(s);
    return s;
  }

  // plays_num / plays_den plays of the clip.
  void play(uint32_t plays_num, uint32_t plays_den, Played* out) {
    kata_stream alone = open_looped(), handed = open_looped();
    ASSERT_TRUE(alone && handed);
    Got& got = out->got;
    kata_runtime_desc rd;
    kata_runtime_desc_init(&rd);
    EXPECT_EQ(rd.on_repetition, nullptr);
    rd = kata::test::callback_runtime_desc(on_result, on_repetition, &got);
    kata_runtime runtime = nullptr;
    ASSERT_EQ(kata_runtime_create(ctx, &rd, &runtime), KATA_OK) << kata_context_last_error(ctx);
    ASSERT_EQ(kata_runtime_add_stream(runtime, 5, &handed, "cmu", 0), KATA_OK) << kata_context_last_error(ctx);
    const uint32_t n = out->n = kata_clip_frame_count(student) - 1;
    const double ft = out->ft = kata_clip_frame_time(student);
    std::vector<kata_repetition>& read = out->read;
    kata_repetition buf[4];
    auto read_some = [&] {
      buf[0].struct_size = sizeof buf[0];
      uint32_t count = 0;
      ASSERT_EQ(kata_stream_read_repetitions(alone, buf, 4, &count), KATA_OK);
      read.insert(read.end(), buf, buf + count);
    };
    const uint32_t frames = plays_num * n / plays_den;
    for (uint32_t k = 0; k < frames; ++k) {
      const std::vector<float> p = frame(student, 1 + k % n);
      ASSERT_EQ(kata_runtime_push(runtime, 5, k, k * ft, p.data(), joints), KATA_OK);
      ASSERT_EQ(kata_stream_push(alone, k * ft, p.data(), joints), KATA_OK);
      read_some();
    }
    // The last repetition is still in progress when the frames stop; the end of the take ends it.
    ASSERT_EQ(read.size(), static_cast<size_t>(plays_num / plays_den - (plays_num % plays_den == 0 ? 1 : 0)));
    ASSERT_EQ(kata_stream_flush(alone), KATA_OK);
    read_some();
    ASSERT_EQ(kata_runtime_stop(runtime), KATA_OK);
    kata_runtime_destroy(runtime);
    kata_stream_destroy(alone);
  }
};

// Three whole plays: three complete repetitions at the teacher's tempo, each ending where its play
// ended, the third closed by the end of the take (the stream's flush, the runtime's stop); the
// runtime's callback and the stream alone see the same ones.
TEST_F(reps_capi, ARuntimeAndAStreamAloneSeeTheSameRepetitions) {
  Played played;
  play(3, 1, &played);
  const std::vector<kata_repetition>& read = played.read;
  const Got& got = played.got;
  const uint32_t n = played.n;
  const double ft = played.ft;
  ASSERT_EQ(read.size(), 3u);
  ASSERT_EQ(got.reps.size(), read.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].index, static_cast<int32_t>(i + 1));
    EXPECT_EQ(read[i].partial, 0);
    EXPECT_EQ(read[i].stream_id, 0u);
    EXPECT_NEAR(read[i].tempo, 1.0, 0.05) << i;
    EXPECT_NEAR(read[i].start_time, i * n * ft, 0.05) << i;
    EXPECT_NEAR(read[i].end_time, (i + 1) * n * ft, 0.05) << i;
    EXPECT_EQ(got.reps[i].stream_id, 5u);
    EXPECT_EQ(got.reps[i].struct_size, sizeof(kata_repetition));
    EXPECT_EQ(got.reps[i].index, read[i].index);
    EXPECT_EQ(got.reps[i].partial, read[i].partial);
    EXPECT_EQ(got.reps[i].start_time, read[i].start_time);
    EXPECT_EQ(got.reps[i].end_time, read[i].end_time);
    EXPECT_EQ(got.reps[i].score, read[i].score);
    for (int j = 0; j < KATA_ROM_JOINT_COUNT; ++j) EXPECT_EQ(got.reps[i].range[j], read[i].range[j]);
  }
  ASSERT_FALSE(got.record_reps.empty());
  EXPECT_EQ(got.record_reps.front(), 1);
  EXPECT_EQ(got.record_reps.back(), 3);
  // The message of a repetition reads back as written; it is no result, and a result reader says so.
  std::vector<unsigned char> message(1024);
  size_t size = 0;
  ASSERT_EQ(kata_message_write_repetition(&got.reps[1], message.data(), message.size(), &size), KATA_OK);
  kata_repetition back;
  back.struct_size = sizeof back;
  ASSERT_EQ(kata_message_read_repetition(message.data(), size, &back), KATA_OK);
  EXPECT_EQ(back.stream_id, 5u);
  EXPECT_EQ(back.index, got.reps[1].index);
  EXPECT_EQ(back.tempo, got.reps[1].tempo);
  EXPECT_EQ(back.teacher_range[KATA_ROM_RIGHT_SHOULDER], got.reps[1].teacher_range[KATA_ROM_RIGHT_SHOULDER]);
  kata_result_record r;
  r.struct_size = sizeof r;
  EXPECT_EQ(kata_message_read_result(message.data(), size, &r), KATA_NO_DATA);
  EXPECT_EQ(kata_message_read_repetition(message.data(), size / 2, &back), KATA_E_PARSE);
  kata_repetition bad = got.reps[1];
  bad.tempo = NAN;
  EXPECT_EQ(kata_message_write_repetition(&bad, message.data(), message.size(), &size), KATA_E_NON_FINITE);
}

// Two and a half plays: two complete repetitions, then the third abandoned halfway when the take
// ends: reported partial (index 3, not counted), from where the third play began to its last
// frame, covering about half of the section; the same through the runtime.
TEST_F(reps_capi, TheEndOfATakeEndsAHalfRepetitionAsPartial) {
  Played played;
  play(5, 2, &played);
  const std::vector<kata_repetition>& read = played.read;
  const Got& got = played.got;
  const uint32_t n = played.n;
  const double ft = played.ft;
  ASSERT_EQ(read.size(), 3u);
  ASSERT_EQ(got.reps.size(), 3u);
  for (size_t i = 0; i < 2; ++i) EXPECT_EQ(read[i].partial, 0) << i;
  const kata_repetition& last = read[2];
  EXPECT_EQ(last.index, 3);
  EXPECT_EQ(last.partial, 1);
  EXPECT_NEAR(last.start_time, 2 * n * ft, 0.05);
  EXPECT_NEAR(last.end_time, (5 * n / 2 - 1) * ft, 0.05);
  EXPECT_NEAR(last.coverage, 0.5, 0.1);
  EXPECT_EQ(got.reps[2].index, 3);
  EXPECT_EQ(got.reps[2].partial, 1);
  EXPECT_EQ(got.reps[2].stream_id, 5u);
  EXPECT_EQ(got.reps[2].start_time, last.start_time);
  EXPECT_EQ(got.reps[2].end_time, last.end_time);
  EXPECT_EQ(got.record_reps.back(), 3);
}

// A stream alone restarted mid-repetition (kata_stream_restart_teacher) after two and a half
// plays: the third repetition ends there, partial (index 3, about half the section), readable at
// once; the count then starts again: the next whole play is repetition 1, complete.
TEST_F(reps_capi, ARestartEndsTheRepetitionInProgressThenCountsFromOne) {
  kata_stream s = open_looped();
  ASSERT_TRUE(s);
  const uint32_t n = kata_clip_frame_count(student) - 1;
  const double ft = kata_clip_frame_time(student);
  std::vector<kata_repetition> read;
  kata_repetition buf[4];
  auto read_some = [&] {
    buf[0].struct_size = sizeof buf[0];
    uint32_t count = 0;
    ASSERT_EQ(kata_stream_read_repetitions(s, buf, 4, &count), KATA_OK);
    read.insert(read.end(), buf, buf + count);
  };
  const uint32_t before = 5 * n / 2;
  for (uint32_t k = 0; k < before; ++k) {
    const std::vector<float> p = frame(student, 1 + k % n);
    ASSERT_EQ(kata_stream_push(s, k * ft, p.data(), joints), KATA_OK);
    read_some();
  }
  ASSERT_EQ(read.size(), 2u);
  ASSERT_EQ(kata_stream_restart_teacher(s), KATA_OK);
  read_some();
  ASSERT_EQ(read.size(), 3u);
  EXPECT_EQ(read[2].index, 3);
  EXPECT_EQ(read[2].partial, 1);
  EXPECT_NEAR(read[2].start_time, 2 * n * ft, 0.05);
  EXPECT_NEAR(read[2].end_time, (before - 1) * ft, 0.05);
  EXPECT_NEAR(read[2].coverage, 0.5, 0.1);
  // The source goes on (its clock too: a stream's time only increases) with a whole play.
  for (uint32_t k = 0; k < n; ++k) {
    const std::vector<float> p = frame(student, 1 + k);
    ASSERT_EQ(kata_stream_push(s, (before + 100 + k) * ft, p.data(), joints), KATA_OK);
    read_some();
  }
  ASSERT_EQ(kata_stream_flush(s), KATA_OK);
  read_some();
  ASSERT_EQ(read.size(), 4u);
  EXPECT_EQ(read[3].index, 1);
  EXPECT_EQ(read[3].partial, 0);
  EXPECT_NEAR(read[3].tempo, 1.0, 0.05);
  kata_stream_destroy(s);
}

}  // namespace
