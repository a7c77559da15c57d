/* The C baseline of the binding benchmarks (bindings/bench/bench_overhead.py runs it side by side
 * with the Python and C# loops): the same stream, the same frames, the same calls, straight from C.
 *   kata_binding_bench_c REPO_DIR [REPS] [FRAMES] [CHUNK]
 * prints "single NS" (ns per frame of push one + read one) and "chunked NS" (push CHUNK frames, then
 * read them in one kata_stream_read_results), each the median over REPS timed runs of FRAMES frames. */
#include <kata/kata.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static int cmp_double(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

#define CHECK(call)                                                     \
  do {                                                                  \
    kata_status s_ = (call);                                            \
    if (s_ != KATA_OK) {                                                \
      fprintf(stderr, "%s: %s\n", #call, kata_status_string(s_));       \
      exit(1);                                                          \
    }                                                                   \
  } while (0)

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s REPO_DIR [REPS] [FRAMES] [CHUNK]\n", argv[0]);
    return 2;
  }
  const int reps = argc > 2 ? atoi(argv[2]) : 7;
  const int frames = argc > 3 ? atoi(argv[3]) : 3000;
  const uint32_t chunk = argc > 4 ? (uint32_t)atoi(argv[4]) : 64;
  char path[4096];
  snprintf(path, sizeof path, "%s/data/cmu/02_01.bvh", argv[1]);

  kata_context ctx;
  kata_clip clip;
  kata_skeleton skel;
  kata_stream stream;
  CHECK(kata_context_create(&ctx));
  CHECK(kata_clip_load_bvh(ctx, path, &clip));
  CHECK(kata_clip_skeleton(clip, &skel));
  const uint32_t joints = kata_skeleton_joint_count(skel), clip_frames = kata_clip_frame_count(clip);
  const double dt = kata_clip_frame_time(clip);
  float* xyz = malloc(sizeof(float) * 3 * joints * clip_frames);
  for (uint32_t f = 0; f < clip_frames; ++f) CHECK(kata_clip_positions(clip, f, xyz + (size_t)f * 3 * joints, 3 * joints));
  kata_stream_desc desc;
  kata_stream_desc_init(&desc);
  desc.layout = "cmu";
  CHECK(kata_stream_open(ctx, skel, &desc, &stream));

  kata_result_record* results = calloc(chunk, sizeof *results);
  for (uint32_t i = 0; i < chunk; ++i) results[i].struct_size = sizeof *results;
  double* single = malloc(sizeof(double) * (size_t)reps);
  double* chunked = malloc(sizeof(double) * (size_t)reps);
  double t = 0.0;
  uint32_t count = 0, f = 0;
  for (int r = 0; r < reps; ++r) {
    double start = now_ns();
    for (int i = 0; i < frames; ++i) {
      t += dt;
      CHECK(kata_stream_push(stream, t, xyz + (size_t)f * 3 * joints, joints));
      CHECK(kata_stream_read_results(stream, results, NULL, 0, NULL, 0, 1, &count));
      f = f + 1 < clip_frames ? f + 1 : 0;
    }
    single[r] = (now_ns() - start) / frames;
    start = now_ns();
    for (int i = 0; i < frames; i += (int)chunk) {
      for (uint32_t k = 0; k < chunk; ++k) {
        t += dt;
        CHECK(kata_stream_push(stream, t, xyz + (size_t)f * 3 * joints, joints));
        f = f + 1 < clip_frames ? f + 1 : 0;
      }
      CHECK(kata_stream_read_results(stream, results, NULL, 0, NULL, 0, chunk, &count));
    }
    chunked[r] = (now_ns() - start) / (double)((frames + (int)chunk - 1) / (int)chunk * (int)chunk);
  }
  qsort(single, (size_t)reps, sizeof(double), cmp_double);
  qsort(chunked, (size_t)reps, sizeof(double), cmp_double);
  printf("single %.1f\nchunked %.1f\n", single[reps / 2], chunked[reps / 2]);
  kata_stream_destroy(stream);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
  free(xyz);
  free(results);
  free(single);
  free(chunked);
  return 0;
}
