/* vmc_send_clip: a BVH clip played as a VMC performer: each frame's joints -> a humanoid pose
 * (kata/humanoid.h) -> one VMC bundle (kata/vmc.h) -> UDP, at the clip's rate. Point it at any VMC
 * receiver (an avatar in Unity with EVMC4U, Unreal with VMC4UE, Blender with VMC4B, Godot;
 * docs/vmc.md) or at samples/vmc/vmc_receive.py.
 *
 *   vmc_send_clip CLIP.bvh [HOST [PORT [LAYOUT [SPEED [FRAMES]]]]]
 *   (defaults 127.0.0.1, 39539, cmu, 1 = real time; SPEED 0: as fast as possible; FRAMES 0: all)
 *
 * Frame 0 of a CMU clip is its T-pose (the rig's rest comes from the skeleton's offsets); frames
 * 1.. are played. Public headers only; plain POSIX sockets. */
#define _POSIX_C_SOURCE 200809L
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "kata/kata.h"

static int check(kata_context ctx, kata_status s, const char* what) {
  if (s == KATA_OK) return 0;
  fprintf(stderr, "vmc_send_clip: %s: %s (%s)\n", what, kata_context_last_error(ctx), kata_status_string(s));
  return 1;
}

int main(int argc, char** argv) {
  const char* host = argc > 2 ? argv[2] : "127.0.0.1";
  const int port = argc > 3 ? atoi(argv[3]) : KATA_VMC_PORT;
  const char* layout = argc > 4 ? argv[4] : "cmu";
  const double speed = argc > 5 ? atof(argv[5]) : 1.0;
  const long limit = argc > 6 ? atol(argv[6]) : 0;
  kata_context ctx = NULL;
  kata_clip clip = NULL;
  kata_skeleton skel = NULL;
  kata_humanoid_rig rig = NULL;
  kata_humanoid_desc desc;
  struct sockaddr_in to;
  unsigned char bundle[4096];
  float* xyz = NULL;
  uint32_t joints, frames, f;
  long sent = 0, failed = 0;
  int fd = -1, rc = 1;
  if (argc < 2) {
    fprintf(stderr, "usage: vmc_send_clip CLIP.bvh [HOST [PORT [LAYOUT [SPEED [FRAMES]]]]]\n");
    return 2;
  }
  memset(&to, 0, sizeof to);
  to.sin_family = AF_INET;
  to.sin_port = htons((uint16_t)port);
  if (inet_pton(AF_INET, host, &to.sin_addr) != 1) {
    fprintf(stderr, "vmc_send_clip: '%s' is not an IPv4 address\n", host);
    return 2;
  }
  if (kata_context_create(&ctx) != KATA_OK) return 1;
  if (check(ctx, kata_clip_load_bvh(ctx, argv[1], &clip), argv[1]) ||
      check(ctx, kata_clip_skeleton(clip, &skel), "skeleton"))
    goto done;
  kata_humanoid_desc_init(&desc);
  desc.layout = layout;
  if (check(ctx, kata_humanoid_rig_create(ctx, skel, &desc, &rig), "rig")) goto done;
  joints = kata_skeleton_joint_count(skel);
  frames = kata_clip_frame_count(clip);
  xyz = (float*)malloc(sizeof(float) * 3 * joints);
  fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (!xyz || fd < 0) goto done;
  {
    struct timespec start;
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (f = 1; f < frames && (limit <= 0 || (long)f <= limit); ++f) {
      kata_humanoid_pose pose;
      size_t n = 0;
      const double t = (f - 1) * kata_clip_frame_time(clip);
      pose.struct_size = sizeof pose;
      if (speed > 0) { /* wait for the frame's time */
        const double at = t / speed;
        struct timespec due = start;
        due.tv_sec += (time_t)at;
        due.tv_nsec += (long)((at - (double)(time_t)at) * 1e9);
        if (due.tv_nsec >= 1000000000L) due.tv_sec += 1, due.tv_nsec -= 1000000000L;
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, NULL);
      }
      kata_clip_positions(clip, f, xyz, 3 * (size_t)joints);
      if (check(ctx, kata_humanoid_rig_pose(rig, xyz, joints, KATA_HUMANOID_RIGHT_HANDED, &pose), "pose") ||
          check(ctx, kata_vmc_write_pose(&pose, t, 1.0f, bundle, sizeof bundle, &n), "bundle"))
        goto done;
      if (sendto(fd, bundle, n, 0, (struct sockaddr*)&to, sizeof to) == (ssize_t)n) ++sent;
      else ++failed; /* nothing listening: UDP goes on */
    }
  }
  printf("vmc_send_clip: %ld bundles sent to %s:%d (%ld failed)\n", sent, host, port, failed);
  rc = 0;
done:
  if (fd >= 0) close(fd);
  free(xyz);
  kata_humanoid_rig_destroy(rig);
  kata_skeleton_destroy(skel);
  kata_clip_destroy(clip);
  kata_context_destroy(ctx);
  return rc;
}
