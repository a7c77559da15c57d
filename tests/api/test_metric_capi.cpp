// The C ABI's "Models and scoring" section, driven through kata.h (libkata.so) only; the stand-in
// model files are made at build time by kata_make_test_models (tests/support).
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <fstream>
#include <iterator>

#include "kata/kata.h"
#include "support/alloc_counter.hpp"
#include "support/capi_teacher.hpp"

namespace kata {
namespace {

const std::string kModels = KATA_TEST_MODELS_DIR;

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

double delta_star_of(const std::string& base) {
  std::ifstream in(base + ".delta");
  double d = 0.0;
  in >> d;
  return d;
}

struct MetricCapi : ::testing::Test {
  void SetUp() override {
    ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
    path = kModels + "/random-r50-s7.kata";
    ASSERT_EQ(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &clip), KATA_OK);
    ASSERT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
  }
  void TearDown() override {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(clip);
    kata_context_destroy(ctx);
  }
  kata_stream open(kata_stencil stencil = KATA_STENCIL_BACKWARD) {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "cmu";
    d.stencil = stencil;
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(ctx, skel, &d, &s), KATA_OK) << kata_context_last_error(ctx);
    return s;
  }
  std::vector<float> positions(uint32_t frame) {
    std::vector<float> p(3 * kata_skeleton_joint_count(skel));
    EXPECT_EQ(kata_clip_positions(clip, frame, p.data(), p.size()), KATA_OK);
    return p;
  }
  kata_context ctx = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  std::string path;
};

TEST_F(MetricCapi, LoadsAModelAndReportsIt) {
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, path.c_str(), &m), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_model_rank(m), 50u);
  EXPECT_DOUBLE_EQ(kata_model_delta_star(m), delta_star_of(kModels + "/random-r50-s7"));
  EXPECT_EQ(kata_model_stencil(m), KATA_STENCIL_BACKWARD);
  EXPECT_STREQ(kata_model_metadata(m, "layout"), "gpd-v1");
  EXPECT_NE(std::string(kata_model_metadata(m, "data")).find("NOT LEARNED"), std::string::npos);
  EXPECT_EQ(kata_model_metadata(m, "nonsense"), nullptr);
  kata_model_destroy(m);
  kata_model_destroy(nullptr);
  EXPECT_EQ(kata_model_rank(nullptr), 0u);
}

TEST_F(MetricCapi, RefusesBadModelsWithTheirReason) {
  kata_model m = reinterpret_cast<kata_model>(1);
  EXPECT_EQ(kata_model_load(ctx, "/nonexistent.kata", &m), KATA_E_IO);
  EXPECT_EQ(m, nullptr);
  std::vector<uint8_t> buf = file_bytes(kModels + "/random-r2-s1.kata");
  ASSERT_GT(buf.size(), 100u);
  buf.resize(buf.size() - 10);
  EXPECT_EQ(kata_model_load_memory(ctx, buf.data(), buf.size(), &m), KATA_E_MODEL);
  EXPECT_NE(std::string(kata_context_last_error(ctx)).find("truncated"), std::string::npos) << kata_context_last_error(ctx);
  EXPECT_EQ(m, nullptr);
  EXPECT_EQ(kata_model_load_memory(ctx, nullptr, 10, &m), KATA_E_NULL_POINTER);
}

TEST_F(MetricCapi, LoadsFromAnUnalignedBuffer) {
  const std::vector<uint8_t> buf = file_bytes(kModels + "/random-r2-s1.kata");
  ASSERT_GT(buf.size(), 100u);
  std::vector<uint8_t> shifted(buf.size() + 3);
  std::copy(buf.begin(), buf.end(), shifted.begin() + 3);
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load_memory(ctx, shifted.data() + 3, buf.size(), &m), KATA_OK) << kata_context_last_error(ctx);
  EXPECT_EQ(kata_model_rank(m), 2u);
  kata_model_destroy(m);
}

// The teacher clip (scores only) and the same clip pushed live: every frame matches its own
// teacher frame with distance 0, and reading scores allocates nothing.
TEST_F(MetricCapi, FollowsAClipTeacherFrameByFrame) {
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, path.c_str(), &m), KATA_OK);
  kata_stream s = open();
  kata_result_record r{};
  r.struct_size = sizeof r;
  EXPECT_EQ(kata_stream_restart_teacher(s), KATA_E_STATE);  // no teacher yet
  ASSERT_EQ(kata::test::attach_clip(s, m, clip, 1), KATA_OK) << kata_stream_last_error(s);
  kata_model_destroy(m);  // the stream keeps what it needs
  EXPECT_EQ(kata::test::read_newest(s, &r), KATA_NO_DATA);
  const double dt = kata_clip_frame_time(clip);
  const uint32_t frames = kata_clip_frame_count(clip);
  std::vector<std::vector<float>> pos;
  for (uint32_t f = 1; f < frames; ++f) pos.push_back(positions(f));
  kata::test::arm_alloc_counter();
  for (uint32_t f = 1; f < frames; ++f) {
    ASSERT_EQ(kata_stream_push(s, (f - 1) * dt, pos[f - 1].data(), kata_skeleton_joint_count(skel)), KATA_OK);
    ASSERT_EQ(kata::test::read_newest(s, &r), KATA_OK) << kata_stream_last_error(s);
    ASSERT_EQ(r.scored, 1);
    ASSERT_EQ(r.frame_index, static_cast<int64_t>(f - 1));
    ASSERT_EQ(r.matched_teacher_frame, static_cast<int32_t>(f - 1));
    ASSERT_DOUBLE_EQ(r.matched_teacher_time, (f - 1) * dt);  // where the student is in the routine
    ASSERT_EQ(r.distance, 0.0f) << f;
    ASSERT_EQ(r.score, 100.0f);
  }
  if (kata::test::kAllocCounting) {
    EXPECT_EQ(kata::test::disarm_alloc_counter(), 0);
  }
  EXPECT_EQ(kata_stream_restart_teacher(s), KATA_OK);
  EXPECT_EQ(kata_stream_detach_teacher(s), KATA_OK);
  EXPECT_EQ(kata_stream_restart_teacher(s), KATA_E_STATE);
  ASSERT_EQ(kata_stream_push(s, frames * dt, pos.back().data(), kata_skeleton_joint_count(skel)), KATA_OK);
  ASSERT_EQ(kata::test::read_newest(s, &r), KATA_OK);
  EXPECT_EQ(r.scored, 0);  // detached: results are not scored
  EXPECT_EQ(r.matched_teacher_frame, -1);
  kata_stream_destroy(s);
}

// Practice: a looped section of the clip. The whole clip pushed live is matched only inside the
// section; on the section's own frames exactly; a section outside the clip and a pose reference
// are refused by name.
TEST_F(MetricCapi, PracticeSectionLoopsAPartOfTheClip) {
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, path.c_str(), &m), KATA_OK);
  kata_stream s = open();
  EXPECT_EQ(kata_stream_set_practice_section(s, 0, -1, 0), KATA_E_STATE);
  ASSERT_EQ(kata::test::attach_clip(s, m, clip, 1), KATA_OK) << kata_stream_last_error(s);
  const uint32_t frames = kata_clip_frame_count(clip);
  EXPECT_EQ(kata_stream_set_practice_section(s, 50, static_cast<int32_t>(frames), 1), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_stream_last_error(s)).find("practice section"), std::string::npos) << kata_stream_last_error(s);
  EXPECT_EQ(kata_stream_set_practice_section(s, 80, 40, 1), KATA_E_INVALID_ARGUMENT);
  ASSERT_EQ(kata_stream_set_practice_section(s, 40, 140, 1), KATA_OK) << kata_stream_last_error(s);
  const double dt = kata_clip_frame_time(clip);
  kata_result_record r{};
  r.struct_size = sizeof r;
  int exact = 0;
  for (uint32_t f = 1; f < frames; ++f) {
    ASSERT_EQ(kata_stream_push(s, (f - 1) * dt, positions(f).data(), kata_skeleton_joint_count(skel)), KATA_OK);
    ASSERT_EQ(kata::test::read_newest(s, &r), KATA_OK) << kata_stream_last_error(s);
    ASSERT_GE(r.matched_teacher_frame, 40) << f;
    ASSERT_LE(r.matched_teacher_frame, 140) << f;
    if (f - 1 >= 50 && f - 1 <= 140 && r.matched_teacher_frame == static_cast<int32_t>(f - 1)) ++exact;
  }
  EXPECT_GE(exact, 85);  // of the 91 frames 50..140 (the first frames of the section settle)
  kata_stream_destroy(s);
  kata_model_destroy(m);
}

TEST_F(MetricCapi, PoseTeacherFromFeaturesScoresOtherFramesLower) {
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, path.c_str(), &m), KATA_OK);
  kata_stream teacher = open(), student = open();
  const double dt = kata_clip_frame_time(clip);
  std::vector<float> feats(KATA_GPD_DIMS);
  for (uint32_t f = 1; f <= 60; ++f) ASSERT_EQ(kata_stream_push(teacher, f * dt, positions(f).data(), kata_skeleton_joint_count(skel)), KATA_OK);
  ASSERT_EQ(kata_stream_features(teacher, feats.data(), feats.size(), nullptr, nullptr), KATA_OK);
  ASSERT_EQ(kata::test::attach_features(student, m, feats.data(), 1), KATA_OK) << kata_stream_last_error(student);
  kata_result_record r{};
  r.struct_size = sizeof r;
  for (uint32_t f = 1; f <= 60; ++f) {
    ASSERT_EQ(kata_stream_push(student, f * dt, positions(f).data(), kata_skeleton_joint_count(skel)), KATA_OK);
    ASSERT_EQ(kata::test::read_newest(student, &r), KATA_OK);
    float sum = 0.0f;
    for (float p : r.parts) sum += p;
    EXPECT_NEAR(sum, r.distance * r.distance, 1e-5f * (1e-6f + r.distance * r.distance));
    if (f < 60) {
      EXPECT_LT(r.score, 100.0f);
    }
  }
  EXPECT_EQ(r.distance, 0.0f);  // frame 60 is the teacher's pose itself
  EXPECT_EQ(r.matched_teacher_frame, 0);
  kata_stream_destroy(teacher);
  kata_stream_destroy(student);
  kata_model_destroy(m);
}

TEST_F(MetricCapi, RefusesAStreamWithAnotherStencil) {
  kata_model m = nullptr;
  ASSERT_EQ(kata_model_load(ctx, path.c_str(), &m), KATA_OK);
  kata_stream s = open(KATA_STENCIL_CENTRAL);
  std::vector<float> feats(KATA_GPD_DIMS, 0.5f);
  EXPECT_EQ(kata::test::attach_features(s, m, feats.data(), 1), KATA_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(kata_stream_last_error(s)).find("stencil"), std::string::npos);
  kata_stream_destroy(s);
  kata_model_destroy(m);
}

}  // namespace
}  // namespace kata
