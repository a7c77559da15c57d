// The pipeline section of kata.h through the shipped libkata only: a teacher attached in one call,
// results drained at a quarter of the push rate, each equal to what a score-only stream read after
// every push and a separately created retargeter give for the same frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "kata/kata.h"
#include "support/capi_fixture.hpp"
#include "support/capi_teacher.hpp"
#include "support/alloc_counter.hpp"

namespace {

constexpr uint32_t kFrames = 120;

struct PipelineCapi : kata::test::CapiClips {
  PipelineCapi() : CapiClips(KATA_DATA_DIR "/cmu/02_01.bvh", KATA_DATA_DIR "/cmu/07_01.bvh") {}
  kata_stream open(uint32_t capacity = 64) { return CapiClips::open(capacity); }
};

TEST_F(PipelineCapi, EveryFrameScoredAndGhostedWhenReadAtAQuarterOfThePushRate) {
  kata_stream s = open();
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher;
  td.first_frame = 1;
  ASSERT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK) << kata_stream_last_error(s);
  const uint32_t g = kata_stream_ghost_joint_count(s);
  ASSERT_EQ(g, 21u);  // CMU: the joints that carry a bone

  // The same frames through a score-only stream (no ghost) read after every push.
  kata_stream legacy = open();
  ASSERT_EQ(kata::test::attach_clip(legacy, model, teacher, 1), KATA_OK) << kata_stream_last_error(legacy);

  std::vector<kata_result_record> results(64);
  
  std::vector<float> ghosts(64 * 3 * static_cast<size_t>(g));
  std::vector<kata_result_record> all;
  std::vector<kata_result_record> all_scores, want;
  std::vector<float> all_ghosts;
  auto drain = [&] {
    results[0].struct_size = sizeof(kata_result_record);
    uint32_t n = 0;
    ASSERT_EQ(kata_stream_read_results(s, results.data(), ghosts.data(), ghosts.size(), nullptr, 0,
                                       64, &n),
              KATA_OK)
        << kata_stream_last_error(s);
    all.insert(all.end(), results.begin(), results.begin() + n);
    all_scores.insert(all_scores.end(), results.begin(), results.begin() + n);
    all_ghosts.insert(all_ghosts.end(), ghosts.begin(), ghosts.begin() + static_cast<long>(n) * 3 * g);
  };
  for (uint32_t i = 0; i < kFrames; ++i) {
    const std::vector<float> p = frame(student, i + 1);
    const double t = i * kata_clip_frame_time(student);
    ASSERT_EQ(kata_stream_push(s, t, p.data(), joints), KATA_OK);
    ASSERT_EQ(kata_stream_push(legacy, t, p.data(), joints), KATA_OK);
    kata_result_record r;
    r.struct_size = sizeof r;
    ASSERT_EQ(kata::test::read_newest(legacy, &r), KATA_OK);
    want.push_back(r);
    if (i % 4 == 3) drain();
  }
  drain();
  ASSERT_EQ(all.size(), kFrames);
  EXPECT_EQ(kata_stream_results_dropped(s), 0u);
  EXPECT_EQ(kata_stream_results_pending(s), 0u);

  kata_retargeter rt = nullptr;
  ASSERT_EQ(kata_retargeter_create_for_stream(ctx, s, nullptr, &rt), KATA_OK) << kata_context_last_error(ctx);
  ASSERT_EQ(kata_retargeter_joint_count(rt), g);
  std::vector<float> ghost(3 * static_cast<size_t>(g));
  double worst = 0.0;
  for (uint32_t i = 0; i < kFrames; ++i) {
    const kata_result_record& r = all[i];
    EXPECT_EQ(r.result_sequence, i);
    EXPECT_EQ(r.frame_index, static_cast<int64_t>(i));
    EXPECT_EQ(r.scored, 1);
    EXPECT_LE(r.arrival_ns, r.computed_ns);
    EXPECT_EQ(r.ghost_joint_count, g);
    EXPECT_EQ(all_scores[i].distance, want[i].distance) << i;
    EXPECT_EQ(all_scores[i].matched_teacher_frame, want[i].matched_teacher_frame) << i;
    for (int q = 0; q < KATA_PART_COUNT; ++q) EXPECT_EQ(all_scores[i].parts[q], want[i].parts[q]) << i;
    EXPECT_EQ(r.matched_teacher_frame, want[i].matched_teacher_frame);
    EXPECT_EQ(r.matched_teacher_time, want[i].matched_teacher_time);
    EXPECT_EQ(all_scores[i].matched_teacher_time, want[i].matched_teacher_time);
    // The ghost: the matched teacher frame solved by a separate retargeter, placed over the student.
    const std::vector<float> tf = frame(teacher, static_cast<uint32_t>(1 + r.matched_teacher_frame));
    const std::vector<float> sf = frame(student, i + 1);
    ASSERT_EQ(kata_retargeter_solve(rt, tf.data(), joints, ghost.data(), ghost.size(), nullptr), KATA_OK);
    ASSERT_EQ(kata_retargeter_place(rt, sf.data(), joints, ghost.data(), ghost.size()), KATA_OK);
    for (size_t k = 0; k < ghost.size(); ++k)
      worst = std::max(worst, std::abs(double(ghost[k]) - all_ghosts[i * ghost.size() + k]));
  }
  // CMU units: a body is ~30 units tall; 1e-5 of that.
  EXPECT_LE(worst, 1e-5 * kata_stream_body_height(s));
  kata_retargeter_destroy(rt);
  kata_stream_destroy(legacy);
  kata_stream_destroy(s);
}

TEST_F(PipelineCapi, OverflowIsCountedAndReadsRefuseShortBuffers) {
  kata_stream s = open(4);
  for (uint32_t i = 0; i < 10; ++i) {
    const std::vector<float> p = frame(student, i + 1);
    ASSERT_EQ(kata_stream_push(s, i / 120.0, p.data(), joints), KATA_OK);
  }
  EXPECT_EQ(kata_stream_results_pending(s), 4u);
  EXPECT_EQ(kata_stream_results_dropped(s), 6u);
  std::vector<kata_result_record> r(8);
  r[0].struct_size = sizeof(kata_result_record);
  uint32_t n = 99;
  std::vector<float> features(KATA_GPD_DIMS);
  EXPECT_EQ(kata_stream_read_results(s, r.data(), nullptr, 0, features.data(), features.size(), 8, &n),
            KATA_E_BUFFER_TOO_SMALL);
  EXPECT_EQ(n, 0u);
  ASSERT_EQ(kata_stream_read_results(s, r.data(), nullptr, 0, nullptr, 0, 8, &n), KATA_OK);
  ASSERT_EQ(n, 4u);
  EXPECT_EQ(r[0].result_sequence, 6u);
  EXPECT_EQ(r[3].result_sequence, 9u);
  EXPECT_EQ(r[0].scored, 0);  // no teacher: features only
  EXPECT_EQ(r[0].matched_teacher_frame, -1);
  kata_stream_destroy(s);
}

TEST_F(PipelineCapi, AttachRefusesWhatCannotWorkAndKeepsTheOldTeacher) {
  kata_stream s = open();
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_E_NULL_POINTER);  // no model
  td.model = model;
  EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_E_INVALID_ARGUMENT);  // no motion
  EXPECT_NE(std::string(kata_stream_last_error(s)).find("no teacher motion"), std::string::npos);
  td.clip = teacher;
  td.first_frame = 1;
  td.layout = "no-such-preset";
  EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_E_NOT_FOUND);
  td.layout = nullptr;
  td.pose_frame = -2;
  EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_E_INVALID_ARGUMENT);
  td.pose_frame = -1;
  ASSERT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK) << kata_stream_last_error(s);
  td.first_frame = 100000;
  EXPECT_EQ(kata_stream_attach_teacher(s, &td), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_stream_ghost_joint_count(s), 21u);  // the attached teacher stays
  kata_stream_destroy(s);
}

TEST_F(PipelineCapi, PushAndReadAllocateNothing) {
  if (!kata::test::kAllocCounting) GTEST_SKIP() << "allocation counting is off under the sanitizers";
  kata_stream s = open(16);
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = teacher;
  td.first_frame = 1;
  ASSERT_EQ(kata_stream_attach_teacher(s, &td), KATA_OK);
  std::vector<std::vector<float>> frames;
  for (uint32_t i = 0; i < 60; ++i) frames.push_back(frame(student, i + 1));
  std::vector<kata_result_record> r(16);
  
  std::vector<float> ghosts(16 * 3 * 21);
  const long before = kata::test::allocations();
  for (uint32_t i = 0; i < 60; ++i) {
    ASSERT_EQ(kata_stream_push(s, i / 120.0, frames[i].data(), joints), KATA_OK);
    r[0].struct_size = sizeof(kata_result_record);
    uint32_t n = 0;
    ASSERT_EQ(kata_stream_read_results(s, r.data(), ghosts.data(), ghosts.size(), nullptr, 0, 16, &n),
              KATA_OK);
  }
  EXPECT_EQ(kata::test::allocations() - before, 0);
  kata_stream_destroy(s);
}

}  // namespace
