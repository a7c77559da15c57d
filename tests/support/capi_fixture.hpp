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

// A teacher of a whole CMU clip for the model (the clip's first frame is its T-pose, so scoring
// starts at frame 1), as the runtime and shared-teacher tests attach it.
inline kata_teacher_desc clip_teacher_desc(kata_model model, kata_clip clip) {
  kata_teacher_desc td;
  kata_teacher_desc_init(&td);
  td.model = model;
  td.clip = clip;
  td.first_frame = 1;
  return td;
}

// A runtime fed by kata_runtime_offer whose on_stream_open sets up each stream: one worker, no
// age limit (a clip's capture times are not this host's clock), the model's stencil.
inline kata_runtime_desc hooked_direct_ingest_desc(kata_model model, kata_stream_open_callback hook, void* hook_user,
                                                   kata_result_callback on_result, void* on_result_user) {
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.direct_ingest = 1;
  rd.max_frame_age_seconds = 0.0;
  rd.on_result = on_result;
  rd.on_result_user = on_result_user;
  rd.on_stream_open = hook;
  rd.on_stream_open_user = hook_user;
  rd.stream_stencil = kata_model_stencil(model);
  return rd;
}

// A runtime of one worker that hands every result and every repetition that ends to the
// in-process callbacks (either may be null), `user` passed to both; nothing else set.
inline kata_runtime_desc callback_runtime_desc(kata_result_callback on_result, kata_repetition_callback on_repetition,
                                               void* user) {
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = 1;
  rd.on_result = on_result;
  rd.on_repetition = on_repetition;
  rd.on_result_user = user;
  return rd;
}

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
