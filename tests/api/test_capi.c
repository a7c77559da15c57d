/* A C99 program that drives a stream through the C ABI only: it is also the proof that kata.h
 * compiles as C (-std=c99 -Wall -Wextra -pedantic -Werror). Exit code 0 on success. */
#include "kata/kata.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

#define CHECK(cond)                                                   \
  do {                                                                \
    if (!(cond)) {                                                    \
      fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
      ++failures;                                                     \
    }                                                                 \
  } while (0)

int main(void) {
  kata_context ctx = NULL;
  kata_clip clip = NULL;
  kata_skeleton skel = NULL;
  kata_stream stream = NULL;
  kata_stream_desc desc;
  float* positions;
  float features[KATA_GPD_DIMS];
  uint32_t joints, frames, i;
  double t = -1.0;
  int64_t frame_index = -1;
  kata_status st;
  int d;

  CHECK(kata_version() == KATA_VERSION_MAJOR * 10000u + KATA_VERSION_MINOR * 100u + KATA_VERSION_PATCH);
  CHECK(strcmp(kata_status_string(KATA_E_NON_FINITE), "KATA_E_NON_FINITE") == 0);
  CHECK(kata_context_create(&ctx) == KATA_OK);

  /* A missing file is an I/O error with a message. */
  CHECK(kata_clip_load_bvh(ctx, "/nonexistent/clip.bvh", &clip) == KATA_E_IO);
  CHECK(clip == NULL);
  CHECK(strlen(kata_context_last_error(ctx)) > 0);

  CHECK(kata_clip_load_bvh(ctx, KATA_DATA_DIR "/cmu/02_01.bvh", &clip) == KATA_OK);
  CHECK(kata_clip_skeleton(clip, &skel) == KATA_OK);
  joints = kata_skeleton_joint_count(skel);
  frames = kata_clip_frame_count(clip);
  CHECK(joints == 31);
  CHECK(frames == 344);
  CHECK(strcmp(kata_skeleton_joint_name(skel, 0), "Hips") == 0);
  CHECK(kata_skeleton_joint_parent(skel, 0) == -1);

  kata_stream_desc_init(&desc);
  desc.layout = "no-such-preset";
  CHECK(kata_stream_open(ctx, skel, &desc, &stream) == KATA_E_NOT_FOUND);
  desc.layout = "cmu";
  CHECK(kata_stream_open(ctx, skel, &desc, &stream) == KATA_OK);
  kata_skeleton_destroy(skel); /* the stream keeps its own copy */
  CHECK(kata_stream_body_height(stream) > 20.0 && kata_stream_body_height(stream) < 40.0);
  CHECK(kata_stream_features(stream, features, KATA_GPD_DIMS, &t, &frame_index) == KATA_NO_DATA);

  positions = (float*)malloc(sizeof(float) * 3 * joints);
  for (i = 0; i < frames; ++i) {
    CHECK(kata_clip_positions(clip, i, positions, 3 * joints) == KATA_OK);
    st = kata_stream_push(stream, i * kata_clip_frame_time(clip), positions, joints);
    CHECK(st == KATA_OK);
    if (i == 100) {
      /* Bad frames are refused with a status and leave the stream usable. */
      float saved = positions[5];
      positions[5] = (float)NAN;
      CHECK(kata_stream_push(stream, (i + 1) * kata_clip_frame_time(clip), positions, joints) == KATA_E_NON_FINITE);
      CHECK(strlen(kata_stream_last_error(stream)) > 0);
      positions[5] = saved;
      CHECK(kata_stream_push(stream, (i + 1) * kata_clip_frame_time(clip), positions, joints - 1) ==
            KATA_E_WRONG_JOINT_COUNT);
      CHECK(kata_stream_push(stream, i * kata_clip_frame_time(clip), positions, joints) ==
            KATA_E_TIMESTAMP_NOT_INCREASING);
      CHECK(kata_stream_push(stream, 0.0, NULL, joints) == KATA_E_NULL_POINTER);
    }
    CHECK(kata_stream_features(stream, features, KATA_GPD_DIMS, &t, &frame_index) == KATA_OK);
    CHECK(frame_index == (int64_t)i);
    CHECK(fabs(t - i * kata_clip_frame_time(clip)) < 1e-9);
    for (d = 0; d < KATA_GPD_DIMS; ++d) CHECK(isfinite(features[d]));
  }
  CHECK(kata_stream_feature_count(stream) == (int64_t)frames);
  CHECK(kata_stream_features(stream, features, 10, &t, &frame_index) == KATA_E_BUFFER_TOO_SMALL);
  CHECK(kata_clip_positions(clip, frames, positions, 3 * joints) == KATA_E_INVALID_ARGUMENT);
  CHECK(kata_clip_positions(clip, 0, positions, 3) == KATA_E_BUFFER_TOO_SMALL);

  /* A source in C (since 1.1): the clip's skeleton definition and a frame as ingest messages, the
   * size asked first; the result reader takes them for valid kata messages that are no result. */
  {
    static unsigned char message[1 << 16];
    kata_skeleton_message definition;
    kata_frame_message frame;
    kata_skeleton clip_skeleton = NULL;
    size_t size = 0, needed = 0;
    kata_result_record record;
    record.struct_size = sizeof record;
    CHECK(kata_clip_skeleton(clip, &clip_skeleton) == KATA_OK);
    kata_skeleton_message_init(&definition);
    definition.stream_id = 42;
    definition.skeleton = clip_skeleton;
    definition.layout = "cmu";
    CHECK(kata_message_write_skeleton(&definition, NULL, 0, &needed) == KATA_E_BUFFER_TOO_SMALL);
    CHECK(kata_message_write_skeleton(&definition, message, sizeof message, &size) == KATA_OK);
    CHECK(size == needed && memcmp(message, "000000000000002a", 16) == 0 && memcmp(message + 20, "KSKL", 4) == 0);
    CHECK(kata_message_read_result(message, size, &record) == KATA_NO_DATA);
    kata_frame_message_init(&frame);
    frame.stream_id = 42;
    frame.sequence = 1;
    frame.capture_time = kata_clip_frame_time(clip);
    frame.positions = positions;
    frame.joint_count = joints;
    CHECK(kata_message_write_frame(&frame, message, sizeof message, &size) == KATA_OK);
    CHECK(memcmp(message + 20, "KFRM", 4) == 0 && size > 12 * joints);
    CHECK(kata_message_read_result(message, size, &record) == KATA_NO_DATA);
    positions[4] = (float)NAN;
    CHECK(kata_message_write_frame(&frame, message, sizeof message, &size) == KATA_E_NON_FINITE && size == 0);
    CHECK(strstr(kata_context_last_error(ctx), "joint 1") != NULL);
    kata_skeleton_destroy(clip_skeleton);
  }

  free(positions);
  kata_stream_destroy(stream);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
  /* NULL handles are ignored or refused, never a crash. */
  kata_stream_destroy(NULL);
  CHECK(kata_stream_push(NULL, 0.0, NULL, 0) == KATA_E_NULL_POINTER);
  CHECK(kata_stream_features(NULL, features, KATA_GPD_DIMS, NULL, NULL) == KATA_E_NULL_POINTER);

  if (failures) {
    fprintf(stderr, "%d checks failed\n", failures);
    return 1;
  }
  printf("C ABI test: all checks passed\n");
  return 0;
}
