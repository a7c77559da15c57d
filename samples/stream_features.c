/* stream_features: replay a BVH clip as a live stream and print a few GPD v1 features per frame.
 *
 *   stream_features CLIP.bvh [preset]
 *
 * What it shows: load a clip, open a stream on its skeleton with a preset joint map, push each
 * frame with its timestamp, read the newest feature vector, and handle refused frames. */
#include <kata/kata.h>

#include <stdio.h>
#include <stdlib.h>

static int fail(const char* what, const char* message) {
  fprintf(stderr, "stream_features: %s: %s\n", what, message);
  return 1;
}

int main(int argc, char** argv) {
  kata_context ctx;
  kata_clip clip;
  kata_skeleton skeleton;
  kata_stream stream;
  kata_stream_desc desc;
  float features[KATA_GPD_DIMS];
  float* positions;
  uint32_t i, joints;
  int64_t frame;
  double t;

  if (argc < 2) {
    fprintf(stderr, "usage: stream_features CLIP.bvh [preset]\n");
    return 2;
  }
  if (kata_context_create(&ctx) != KATA_OK) return 1;
  if (kata_clip_load_bvh(ctx, argv[1], &clip) != KATA_OK) return fail("load", kata_context_last_error(ctx));
  kata_clip_skeleton(clip, &skeleton);

  kata_stream_desc_init(&desc);
  desc.layout = argc > 2 ? argv[2] : "cmu";
  desc.stencil = KATA_STENCIL_BACKWARD; /* derivatives at the newest frame: no added latency */
  if (kata_stream_open(ctx, skeleton, &desc, &stream) != KATA_OK) return fail("open", kata_context_last_error(ctx));
  printf("body height H = %.3f (file units)\n", kata_stream_body_height(stream));

  joints = kata_skeleton_joint_count(skeleton);
  positions = malloc(sizeof(float) * 3 * joints); /* allocate once, before the frame loop */
  for (i = 1; i < kata_clip_frame_count(clip); ++i) { /* frame 0 of a CMU clip is a T-pose */
    kata_status status;
    kata_clip_positions(clip, i, positions, 3 * joints);
    status = kata_stream_push(stream, i * kata_clip_frame_time(clip), positions, joints);
    if (status != KATA_OK) { /* a refused frame changes nothing: log it and go on */
      fprintf(stderr, "frame %u refused: %s\n", i, kata_stream_last_error(stream));
      continue;
    }
    if (i % 60 == 0 && kata_stream_features(stream, features, KATA_GPD_DIMS, &t, &frame) == KATA_OK) {
      /* dims 0..2: the chest in the local frame (body heights); 45: hip height; 1591..: kinetics */
      printf("t=%6.3f s  chest=(%+.3f %+.3f %+.3f)  hip height=%.3f  chest velocity=(%+.3f %+.3f %+.3f) H/s\n", t,
             features[0], features[1], features[2], features[45], features[1591], features[1592], features[1593]);
    }
  }
  free(positions);
  kata_stream_destroy(stream);
  kata_skeleton_destroy(skeleton);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
  return 0;
}
