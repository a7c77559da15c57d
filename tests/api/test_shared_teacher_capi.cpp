// A teacher built once and shared by many streams (kata_teacher_create,
// kata_stream_attach_shared_teacher; 1.1), through the shipped libkata only. The expected values
// come from the per-stream call: a stream given the shared teacher must produce, result for
// result and bit for bit, what the same stream produces when kata_stream_attach_teacher loads the
// same clip for it. Sharing is checked by the process's resident memory: 32 streams on one shared
// teacher grow it by far less than 32 streams each given its own copy.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <vector>

#include <unistd.h>

#include "kata/kata.h"
#include "support/capi_fixture.hpp"

namespace {

// Resident set size of this process, bytes (/proc/self/statm's second field, in pages).
long long rss_bytes() {
  long long size = 0, resident = 0;
  FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return -1;
  const int n = std::fscanf(f, "%lld %lld", &size, &resident);
  std::fclose(f);
  return n == 2 ? resident * static_cast<long long>(sysconf(_SC_PAGESIZE)) : -1;
}

struct SharedTeacher : kata::test::CapiClips {
  SharedTeacher() : CapiClips(KATA_DATA_DIR "/cmu/02_01.bvh", KATA_DATA_DIR "/cmu/02_02.bvh") {}
  kata_stream open() { return CapiClips::open(512); }
  kata_teacher_desc desc(kata_clip clip) { return kata::test::clip_teacher_desc(model, clip); }
  // Pushes student frames first..first+n-1 (the clip over and over, time running on) and drains
  // every result with its ghost.
  void run(kata_stream s, uint32_t first, uint32_t n, std::vector<kata_result_record>* out,
           std::vector<float>* ghosts) {
    std::vector<float> p(3 * static_cast<size_t>(joints));
    for (uint32_t f = first; f < first + n; ++f) {
      ASSERT_EQ(kata_clip_positions(student, f % kata_clip_frame_count(student), p.data(), p.size()), KATA_OK);
      ASSERT_EQ(kata_stream_push(s, f * kata_clip_frame_time(student), p.data(), joints), KATA_OK)
          << kata_stream_last_error(s);
    }
    const uint32_t pending = kata_stream_results_pending(s);
    out->assign(pending, kata_result_record{});
    (*out)[0].struct_size = sizeof(kata_result_record);
    const size_t g = 3 * static_cast<size_t>(kata_stream_ghost_joint_count(s));
    ghosts->assign(pending * g, 0.0f);
    uint32_t count = 0;
    ASSERT_EQ(kata_stream_read_results(s, out->data(), ghosts->data(), ghosts->size(), nullptr, 0, pending, &count),
              KATA_OK);
    ASSERT_EQ(count, pending);
  }
  // Every field a teacher decides, equal bit for bit (the times of arrival and computation differ).
  static void expect_same(const std::vector<kata_result_record>& a, const std::vector<kata_result_record>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      SCOPED_TRACE(i);
      EXPECT_EQ(a[i].scored, b[i].scored);
      EXPECT_EQ(a[i].frame_index, b[i].frame_index);
      EXPECT_EQ(a[i].matched_teacher_frame, b[i].matched_teacher_frame);
      EXPECT_EQ(std::memcmp(&a[i].matched_teacher_time, &b[i].matched_teacher_time, sizeof(double)), 0);
      EXPECT_EQ(std::memcmp(&a[i].distance, &b[i].distance, sizeof(float)), 0);
      EXPECT_EQ(std::memcmp(&a[i].score, &b[i].score, sizeof(float)), 0);
      EXPECT_EQ(std::memcmp(a[i].parts, b[i].parts, sizeof a[i].parts), 0);
      EXPECT_EQ(std::memcmp(a[i].part_scores, b[i].part_scores, sizeof a[i].part_scores), 0);
      EXPECT_EQ(a[i].state, b[i].state);
      EXPECT_EQ(a[i].part_to_fix, b[i].part_to_fix);
      EXPECT_EQ(a[i].cue_joint, b[i].cue_joint);
      EXPECT_EQ(std::memcmp(&a[i].cue_degrees, &b[i].cue_degrees, sizeof(float)), 0);
      EXPECT_EQ(a[i].ghost_joint_count, b[i].ghost_joint_count);
    }
  }
};

TEST_F(SharedTeacher, ScoresAndGhostsAreBitIdenticalToAPerStreamTeacherEvenAfterTheHandleIsDestroyed) {
  const kata_teacher_desc d = desc(teacher);
  kata_stream own = open();
  ASSERT_EQ(kata_stream_attach_teacher(own, &d), KATA_OK) << kata_stream_last_error(own);
  kata_teacher t = nullptr;
  ASSERT_EQ(kata_teacher_create(ctx, &d, &t), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_teacher_frame_count(t), kata_clip_frame_count(teacher) - 1);
  EXPECT_EQ(kata_teacher_frame_time(t), kata_clip_frame_time(teacher));
  // At least the teacher's joint positions (frames x joints x 3 floats) are held.
  kata_skeleton tskel = nullptr;
  ASSERT_EQ(kata_clip_skeleton(teacher, &tskel), KATA_OK);
  EXPECT_GE(kata_teacher_memory_bytes(t),
            uint64_t{kata_teacher_frame_count(t)} * kata_skeleton_joint_count(tskel) * 3 * sizeof(float));
  kata_skeleton_destroy(tskel);
  kata_stream a = open(), b = open();
  ASSERT_EQ(kata_stream_attach_shared_teacher(a, t, nullptr), KATA_OK) << kata_stream_last_error(a);
  ASSERT_EQ(kata_stream_attach_shared_teacher(b, t, nullptr), KATA_OK) << kata_stream_last_error(b);
  // The streams keep the teacher: the app's handle may go (ASan watches the frames read below).
  kata_teacher_destroy(t);
  const uint32_t n = 300;
  std::vector<kata_result_record> r_own, r_a, r_b;
  std::vector<float> g_own, g_a, g_b;
  run(own, 0, n, &r_own, &g_own);
  run(a, 0, n, &r_a, &g_a);
  run(b, 0, n, &r_b, &g_b);
  ASSERT_GT(r_own.size(), 200u);
  size_t scored = 0;
  for (const kata_result_record& r : r_own) scored += r.scored == 1;
  EXPECT_EQ(scored, r_own.size());
  expect_same(r_own, r_a);
  expect_same(r_own, r_b);
  ASSERT_FALSE(g_own.empty());
  EXPECT_EQ(g_own.size(), g_a.size());
  EXPECT_EQ(std::memcmp(g_own.data(), g_a.data(), g_own.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(g_own.data(), g_b.data(), g_own.size() * sizeof(float)), 0);
  // A practice section set after the attach: the same as on a per-stream teacher.
  ASSERT_EQ(kata_stream_set_practice_section(own, 20, 120, 1), KATA_OK);
  ASSERT_EQ(kata_stream_set_practice_section(a, 20, 120, 1), KATA_OK);
  run(own, n, 200, &r_own, &g_own);
  run(a, n, 200, &r_a, &g_a);
  expect_same(r_own, r_a);
  for (const kata_result_record& r : r_a) EXPECT_TRUE(r.matched_teacher_frame >= 20 && r.matched_teacher_frame <= 120);
  kata_stream_destroy(own);
  kata_stream_destroy(a);
  kata_stream_destroy(b);
}

TEST_F(SharedTeacher, PerStreamOptionsApplyToOneStreamAndAMotionInThemIsRefused) {
  kata_teacher_desc d = desc(teacher);
  kata_teacher t = nullptr;
  ASSERT_EQ(kata_teacher_create(ctx, &d, &t), KATA_OK) << kata_context_last_error(ctx);
  // Scores only on one stream: the same scores as a per-stream teacher without a ghost.
  kata_teacher_desc scores_only;
  kata_teacher_desc_init(&scores_only);
  scores_only.ghost = 0;
  kata_stream a = open(), own = open();
  ASSERT_EQ(kata_stream_attach_shared_teacher(a, t, &scores_only), KATA_OK) << kata_stream_last_error(a);
  EXPECT_EQ(kata_stream_ghost_joint_count(a), 0u);
  d.ghost = 0;
  ASSERT_EQ(kata_stream_attach_teacher(own, &d), KATA_OK);
  std::vector<kata_result_record> r_a, r_own;
  std::vector<float> g;
  run(a, 0, 120, &r_a, &g);
  run(own, 0, 120, &r_own, &g);
  expect_same(r_own, r_a);
  // A motion in the options is refused and leaves the stream's teacher in place.
  kata_teacher_desc motion;
  kata_teacher_desc_init(&motion);
  motion.clip = student;
  EXPECT_EQ(kata_stream_attach_shared_teacher(a, t, &motion), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::strstr(kata_stream_last_error(a), "motion"), nullptr);
  EXPECT_EQ(kata_stream_attach_shared_teacher(a, nullptr, nullptr), KATA_E_NULL_POINTER);
  run(a, 120, 30, &r_a, &g);
  for (const kata_result_record& r : r_a) EXPECT_EQ(r.scored, 1);
  kata_teacher_desc no_model = desc(teacher);
  no_model.model = nullptr;
  kata_teacher none = nullptr;
  EXPECT_EQ(kata_teacher_create(ctx, &no_model, &none), KATA_E_NULL_POINTER);
  EXPECT_EQ(none, nullptr);
  EXPECT_EQ(kata_teacher_frame_count(nullptr), 0u);
  kata_teacher_destroy(nullptr);
  kata_teacher_destroy(t);
  kata_stream_destroy(a);
  kata_stream_destroy(own);
}

TEST_F(SharedTeacher, ThirtyTwoStreamsOnOneTeacherHoldOneCopy) {
  // The longest clip in data/cmu (05_18, 1830 frames), attached to 32 streams both ways.
  kata_clip long_clip = nullptr;
  ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/05_18.bvh", &long_clip), KATA_OK);
  const kata_teacher_desc d = desc(long_clip);
  constexpr int kStreams = 32;
  std::vector<kata_stream> shared(kStreams), copies(kStreams);
  for (kata_stream& s : shared) s = open();
  for (kata_stream& s : copies) s = open();
  const long long before_shared = rss_bytes();
  kata_teacher t = nullptr;
  ASSERT_EQ(kata_teacher_create(ctx, &d, &t), KATA_OK) << kata_context_last_error(ctx);
  for (kata_stream s : shared) ASSERT_EQ(kata_stream_attach_shared_teacher(s, t, nullptr), KATA_OK);
  const long long shared_growth = rss_bytes() - before_shared;
  const long long before_copies = rss_bytes();
  for (kata_stream s : copies) ASSERT_EQ(kata_stream_attach_teacher(s, &d), KATA_OK);
  const long long copies_growth = rss_bytes() - before_copies;
  const long long teacher_bytes = static_cast<long long>(kata_teacher_memory_bytes(t));
  std::printf("teacher %lld bytes; 32 streams: shared +%lld bytes RSS, a copy each +%lld bytes RSS\n", teacher_bytes,
              shared_growth, copies_growth);
  // 31 more copies of the teacher's frames: allow half of them for allocator slack.
  EXPECT_GE(copies_growth - shared_growth, 31 * teacher_bytes / 2);
  EXPECT_LT(shared_growth, copies_growth / 4);
  for (kata_stream s : shared) kata_stream_destroy(s);
  for (kata_stream s : copies) kata_stream_destroy(s);
  kata_teacher_destroy(t);
  kata_clip_destroy(long_clip);
}

}  // namespace
