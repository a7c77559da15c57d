/* Prints kata scores as they arrive: plain C over libzmq, each message read by libkata's
 * kata_message_read_result (verifies the FlatBuffer; no FlatBuffers library in C needed).
 *   c_subscriber ENDPOINT [STREAM_ID] [COUNT]      e.g. c_subscriber tcp://127.0.0.1:5556 7 100
 * CURVE (docs/deploy.md): KATA_CURVE_PUBLIC, KATA_CURVE_SECRET (this subscriber's keys) and
 * KATA_CURVE_SERVER (the server's public key), each 40 Z85 characters, in the environment.
 * Exits 0 after COUNT results (0: run forever), 1 when nothing arrives for 10 s. */
#define _POSIX_C_SOURCE 200809L
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <zmq.h>

#include "kata/kata.h"

/* kata_body_part order (kata.h). */
static const char* const kParts[KATA_PART_COUNT] = {"torso_head", "left_arm", "right_arm", "left_leg", "right_leg"};

int main(int argc, char** argv) {
  void* context;
  void* sub;
  char topic[17];
  static unsigned char buffer[1 << 20];
  long count = 0, seen = 0;
  if (argc < 2) {
    fprintf(stderr, "usage: %s ENDPOINT [STREAM_ID] [COUNT]\n", argv[0]);
    return 2;
  }
  if (argc > 3) count = atol(argv[3]);
  context = zmq_ctx_new();
  sub = zmq_socket(context, ZMQ_SUB);
  if (getenv("KATA_CURVE_SERVER")) {
    const char* keys[3] = {getenv("KATA_CURVE_SERVER"), getenv("KATA_CURVE_PUBLIC"), getenv("KATA_CURVE_SECRET")};
    const int options[3] = {ZMQ_CURVE_SERVERKEY, ZMQ_CURVE_PUBLICKEY, ZMQ_CURVE_SECRETKEY};
    int i;
    for (i = 0; i < 3; ++i)
      if (!keys[i] || zmq_setsockopt(sub, options[i], keys[i], 40) != 0) {
        fprintf(stderr, "CURVE: KATA_CURVE_SERVER, KATA_CURVE_PUBLIC and KATA_CURVE_SECRET must be 40-character keys\n");
        return 2;
      }
  }
  if (argc > 2) { /* the topic of one stream: its id as 16 lowercase hex digits */
    snprintf(topic, sizeof topic, "%016" PRIx64, (uint64_t)strtoull(argv[2], NULL, 10));
    zmq_setsockopt(sub, ZMQ_SUBSCRIBE, topic, 16);
  } else {
    zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "", 0);
  }
  if (zmq_connect(sub, argv[1]) != 0) {
    fprintf(stderr, "cannot connect %s: %s\n", argv[1], zmq_strerror(zmq_errno()));
    return 1;
  }
  while (count == 0 || seen < count) {
    zmq_pollitem_t item = {sub, 0, ZMQ_POLLIN, 0};
    kata_result_record r;
    struct timespec now;
    int n;
    if (zmq_poll(&item, 1, 10000) <= 0) {
      fprintf(stderr, "no message for 10 s\n");
      return 1;
    }
    n = zmq_recv(sub, buffer, sizeof buffer, 0);
    if (n < 0 || (size_t)n > sizeof buffer) continue;
    clock_gettime(CLOCK_MONOTONIC, &now);
    r.struct_size = sizeof r;
    if (kata_message_read_result(buffer, (size_t)n, &r) != KATA_OK) continue; /* definitions, refusals */
    printf("stream %" PRIu64 " frame %" PRIu64 ": score %.1f (teacher frame %d, ghost %u joints) age %.0f us, fix %s\n",
           r.stream_id, r.frame_sequence, r.scored ? r.score : 0.0f, (int)r.matched_teacher_frame,
           (unsigned)r.ghost_joint_count,
           ((double)now.tv_sec * 1e9 + (double)now.tv_nsec - (double)r.arrival_ns) / 1000.0,
           r.part_to_fix >= 0 && r.part_to_fix < KATA_PART_COUNT ? kParts[r.part_to_fix] : "-");
    fflush(stdout);
    ++seen;
  }
  zmq_close(sub);
  zmq_ctx_term(context);
  return 0;
}
