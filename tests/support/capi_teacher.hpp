// Score-only teachers through kata.h, for the C ABI tests: a clip, GPD features or one pose
// attached with kata_stream_attach_teacher (ghost = 0), in one line each. (The 0.x
// kata_stream_set_reference_* calls these replace were removed at 1.0.)
#ifndef KATA_TESTS_SUPPORT_CAPI_TEACHER_HPP
#define KATA_TESTS_SUPPORT_CAPI_TEACHER_HPP

#include <cstdint>

#include "kata/kata.h"

namespace kata::test {

// A clip teacher, frames first_frame.. (pose_frame >= first_frame: that frame alone), no ghost.
inline kata_status attach_clip(kata_stream s, kata_model m, kata_clip clip, uint32_t first_frame,
                               int32_t pose_frame = -1, const char* layout = "cmu") {
  kata_teacher_desc t;
  kata_teacher_desc_init(&t);
  t.model = m;
  t.clip = clip;
  t.layout = layout;
  t.first_frame = first_frame;
  t.pose_frame = pose_frame;
  t.ghost = 0;
  return kata_stream_attach_teacher(s, &t);
}

// GPD feature vectors as the teacher: `frames` x KATA_GPD_DIMS floats, frame_time apart (one
// frame: a single pose).
inline kata_status attach_features(kata_stream s, kata_model m, const float* features, uint32_t frames,
                                   double frame_time = 0.0) {
  kata_teacher_desc t;
  kata_teacher_desc_init(&t);
  t.model = m;
  t.features = features;
  t.frames = frames;
  t.frame_time = frame_time;
  t.ghost = 0;
  return kata_stream_attach_teacher(s, &t);
}

// The newest unread result into *r (r->struct_size set by the caller): KATA_NO_DATA when none.
inline kata_status read_newest(kata_stream s, kata_result_record* r) {
  return kata_stream_read_newest(s, r, nullptr, 0, nullptr, 0);
}

}  // namespace kata::test

#endif  // KATA_TESTS_SUPPORT_CAPI_TEACHER_HPP
