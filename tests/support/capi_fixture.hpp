// The set-up most C ABI tests share, through kata.h only: a context, the shipped model, a teacher
// clip and a student clip of the CMU layout, and the student's skeleton; streams opened on it for
// the model's stencil; one frame of either clip as positions. Each test's fixture derives from it
// with its two clips (paths under KATA_DATA_DIR).
#ifndef KATA_TESTS_SUPPORT_CAPI_FIXTURE_HPP
#define KATA_TESTS_SUPPORT_CAPI_FIXTURE_HPP

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "kata/kata.h"

namespace kata::test {

class CapiClips : public ::testing::Test {
 protected:
  CapiClips(std::string teacher_path, std::string student_path)
      : teacher_path_(std::move(teacher_path)), student_path_(std::move(student_path)) {}

  void SetUp() override {
    ASSERT_EQ(kata_context_create(&ctx), KATA_OK);
    ASSERT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK)
        << kata_context_last_error(ctx);
    ASSERT_EQ(kata_clip_load_bvh(ctx, teacher_path_.c_str(), &teacher), KATA_OK) << kata_context_last_error(ctx);
    ASSERT_EQ(kata_clip_load_bvh(ctx, student_path_.c_str(), &student), KATA_OK) << kata_context_last_error(ctx);
    ASSERT_EQ(kata_clip_skeleton(student, &skel), KATA_OK);
    joints = kata_skeleton_joint_count(skel);
  }
  void TearDown() override {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(student);
    kata_clip_destroy(teacher);
    kata_model_destroy(model);
    kata_context_destroy(ctx);
  }
  // A CMU-layout stream on the student's skeleton, for the model's stencil.
  kata_stream open(uint32_t result_capacity) {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "cmu";
    d.stencil = kata_model_stencil(model);
    d.result_capacity = result_capacity;
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(ctx, skel, &d, &s), KATA_OK) << kata_context_last_error(ctx);
    return s;
  }
  // Frame f of a clip on the student's skeleton, as 3 x joints positions.
  std::vector<float> frame(kata_clip clip, uint32_t f) const {
    std::vector<float> p(3 * static_cast<size_t>(joints));
    EXPECT_EQ(kata_clip_positions(clip, f, p.data(), p.size()), KATA_OK);
    return p;
  }

  kata_context ctx = nullptr;
  kata_model model = nullptr;
  kata_clip teacher = nullptr, student = nullptr;
  kata_skeleton skel = nullptr;
  uint32_t joints = 0;

 private:
  std::string teacher_path_, student_path_;
};

}  // namespace kata::test

#endif  // KATA_TESTS_SUPPORT_CAPI_FIXTURE_HPP
