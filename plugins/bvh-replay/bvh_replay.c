/* bvh-replay: plays a BVH clip as a live source at its recorded rate (or speed x), looping
 * optionally. Config: "path=CLIP;stream=ID;speed=1;loops=1;first_frame=1;preset=cmu".
 * Frame 0 of the clip gives the rest offsets (the CMU convention: a zero-rotation T-pose).
 * Public headers only: kata_plugin.h, and kata.h to read the clip. */
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "kata/kata.h"
#include "kata/kata_plugin.h"
#include "plugin_config.h"

typedef struct replay {
  const kata_plugin_host* host;
  uint64_t stream_id;
  double frame_time; /* seconds between played frames (clip frame time / speed) */
  double clip_frame_time;
  int loops;
  uint32_t joints, frames;
  float* positions; /* frames x joints x 3 */
  char** names;
  int32_t* parents;
  float* rest;
  char preset[64];
  pthread_t thread;
  atomic_int stop;
  int running;
} replay;

static void free_replay(replay* r) {
  uint32_t i;
  if (!r) return;
  if (r->names)
    for (i = 0; i < r->joints; ++i) free(r->names[i]);
  free(r->names);
  free(r->parents);
  free(r->rest);
  free(r->positions);
  free(r);
}

static void* activate(const kata_plugin_host* host, const char* config, char* error, size_t capacity) {
  char path[4096], value[64];
  kata_context ctx = NULL;
  kata_clip clip = NULL;
  kata_skeleton skel = NULL;
  uint32_t first = 1, i, f;
  double speed = 1.0;
  replay* r = (replay*)calloc(1, sizeof *r);
  if (!r) return NULL;
  r->host = host;
  r->loops = 1;
  strcpy(r->preset, "cmu");
  if (!plugin_config_value(config, "path", path, sizeof path)) {
    snprintf(error, capacity, "bvh-replay: config needs path=CLIP.bvh");
    goto fail;
  }
  if (plugin_config_value(config, "stream", value, sizeof value)) r->stream_id = strtoull(value, NULL, 10);
  if (plugin_config_value(config, "speed", value, sizeof value)) speed = atof(value);
  if (plugin_config_value(config, "loops", value, sizeof value)) r->loops = atoi(value);
  if (plugin_config_value(config, "first_frame", value, sizeof value)) first = (uint32_t)atoi(value);
  plugin_config_value(config, "preset", r->preset, sizeof r->preset);
  if (!(speed > 0.0) || r->loops < 1) {
    snprintf(error, capacity, "bvh-replay: speed must be > 0 and loops >= 1");
    goto fail;
  }
  if (kata_context_create(&ctx) != KATA_OK || kata_clip_load_bvh(ctx, path, &clip) != KATA_OK) {
    snprintf(error, capacity, "bvh-replay: %s", ctx ? kata_context_last_error(ctx) : "no context");
    goto fail;
  }
  kata_clip_skeleton(clip, &skel);
  r->joints = kata_skeleton_joint_count(skel);
  if (first >= kata_clip_frame_count(clip)) {
    snprintf(error, capacity, "bvh-replay: first_frame is past the clip's end");
    goto fail;
  }
  r->frames = kata_clip_frame_count(clip) - first;
  r->clip_frame_time = kata_clip_frame_time(clip);
  r->frame_time = r->clip_frame_time / speed;
  r->positions = (float*)malloc(sizeof(float) * 3 * r->joints * r->frames);
  r->names = (char**)calloc(r->joints, sizeof(char*));
  r->parents = (int32_t*)malloc(sizeof(int32_t) * r->joints);
  r->rest = (float*)malloc(sizeof(float) * 3 * r->joints);
  if (!r->positions || !r->names || !r->parents || !r->rest) goto fail;
  for (f = 0; f < r->frames; ++f)
    kata_clip_positions(clip, first + f, r->positions + (size_t)f * 3 * r->joints, 3 * (size_t)r->joints);
  kata_clip_positions(clip, 0, r->rest, 3 * (size_t)r->joints); /* frame 0: world rest positions */
  for (i = r->joints; i-- > 0;) {
    const int32_t p = kata_skeleton_joint_parent(skel, i);
    r->parents[i] = p;
    r->names[i] = strdup(kata_skeleton_joint_name(skel, i));
    if (p >= 0) { /* offsets from the parent (parents come first, so they are still world here) */
      r->rest[3 * i] -= r->rest[3 * p];
      r->rest[3 * i + 1] -= r->rest[3 * p + 1];
      r->rest[3 * i + 2] -= r->rest[3 * p + 2];
    }
  }
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
  return r;
fail:
  if (skel) kata_skeleton_destroy(skel);
  if (clip) kata_clip_destroy(clip);
  if (ctx) kata_context_destroy(ctx);
  free_replay(r);
  return NULL;
}

static void deactivate(void* instance) { free_replay((replay*)instance); }

static void* play(void* arg) {
  replay* r = (replay*)arg;
  struct timespec start, due;
  uint64_t sequence = 0;
  int loop;
  uint32_t f;
  clock_gettime(CLOCK_MONOTONIC, &start);
  for (loop = 0; loop < r->loops && !atomic_load(&r->stop); ++loop)
    for (f = 0; f < r->frames && !atomic_load(&r->stop); ++f, ++sequence) {
      const double at = r->frame_time * (double)sequence;
      due.tv_sec = start.tv_sec + (time_t)at;
      due.tv_nsec = start.tv_nsec + (long)((at - (double)(time_t)at) * 1e9);
      if (due.tv_nsec >= 1000000000L) {
        due.tv_sec += 1;
        due.tv_nsec -= 1000000000L;
      }
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, NULL); /* sleeping, not spinning */
      r->host->push_frame(r->host->host_data, r->stream_id, sequence, r->clip_frame_time * (double)sequence,
                          r->positions + (size_t)f * 3 * r->joints, r->joints);
    }
  return NULL;
}

static int32_t start(void* instance) {
  replay* r = (replay*)instance;
  const int32_t opened = r->host->open_stream(r->host->host_data, r->stream_id, r->joints,
                                              (const char* const*)r->names, r->parents, r->rest, r->preset);
  if (opened != 0) return opened;
  atomic_store(&r->stop, 0);
  if (pthread_create(&r->thread, NULL, play, r) != 0) return 13;
  r->running = 1;
  return 0;
}

static void stop(void* instance) {
  replay* r = (replay*)instance;
  if (!r->running) return;
  atomic_store(&r->stop, 1);
  pthread_join(r->thread, NULL);
  r->running = 0;
}

static const kata_plugin table = {KATA_PLUGIN_ABI_VERSION, sizeof(kata_plugin), "bvh-replay",
                                  "a BVH clip as a live source (config: path=CLIP;stream=ID;speed;loops)",
                                  KATA_PLUGIN_SOURCE, activate, deactivate, start, stop, NULL, NULL, NULL};

KATA_PLUGIN_EXPORT const kata_plugin* kata_plugin_entry(void) { return &table; }
