/* Prints kata scores as they arrive: plain C, each message read by libkata's
 * kata_message_read_result (verifies the FlatBuffer; no FlatBuffers library in C needed), from
 * either transport (docs/deploy.md):
 *   c_subscriber ENDPOINT [STREAM_ID] [COUNT]      e.g. c_subscriber tcp://127.0.0.1:5556 7 100
 * ZeroMQ (libzmq): ENDPOINT is kata serve's publish endpoint. CURVE: KATA_CURVE_PUBLIC,
 * KATA_CURVE_SECRET (this subscriber's keys) and KATA_CURVE_SERVER (the server's public key),
 * each 40 Z85 characters, in the environment.
 * NATS (libnats, when this sample was built with it): ENDPOINT is a server URL, or several
 * separated by commas (nats://host:4222, tls://...), of the cluster the kata serve shards use;
 * KATA_NATS_PREFIX is their [transport] subject_prefix (default "kata"), KATA_NATS_CREDS a
 * credentials file. Results come from whichever shard holds the stream's partition, on
 * `<prefix>.out.<stream as 16 hex digits>.<epoch>.<owner>`: a result of a former holder (an older
 * epoch) that arrives after a newer holder's is dropped, as every NATS subscriber must.
 * Exits 0 after COUNT results (0: run forever), 1 when nothing arrives for 10 s. */
#define _POSIX_C_SOURCE 200809L
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <zmq.h>
#ifdef KATA_SAMPLE_NATS
#include <nats/nats.h>
#endif

#include "kata/kata.h"

/* kata_body_part order (kata.h). */
static const char* const kParts[KATA_PART_COUNT] = {"torso_head", "left_arm", "right_arm", "left_leg", "right_leg"};

/* A repetition message (docs/coach/repetitions.md): printed; 1 when it was one. */
static int print_repetition(const void* data, size_t size) {
  kata_repetition p;
  p.struct_size = sizeof p;
  if (kata_message_read_repetition(data, size, &p) != KATA_OK) return 0;
  printf("stream %" PRIu64 " repetition %d%s: %.2f-%.2f s, tempo %.2f, score %.1f, knees %.0f/%.0f deg (teacher %.0f/%.0f)\n",
         p.stream_id, (int)p.index, p.partial ? " (partial)" : "", p.start_time, p.end_time, p.tempo, p.score,
         p.range[KATA_ROM_LEFT_KNEE], p.range[KATA_ROM_RIGHT_KNEE], p.teacher_range[KATA_ROM_LEFT_KNEE],
         p.teacher_range[KATA_ROM_RIGHT_KNEE]);
  fflush(stdout);
  return 1;
}

/* One message: 1 when it was a result (printed), 0 otherwise (a repetition, printed; a skeleton
 * definition, stats, or a message the verifier refused). owner / epoch: the NATS shard and lease
 * tenure, or NULL / 0. */
static int print_result(const void* data, size_t size, const char* owner, uint64_t epoch) {
  kata_result_record r;
  struct timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  r.struct_size = sizeof r;
  if (kata_message_read_result(data, size, &r) != KATA_OK) {
    print_repetition(data, size);
    return 0;
  }
  printf("stream %" PRIu64 " frame %" PRIu64 ": score %.1f (teacher frame %d, ghost %u joints) age %.0f us, fix %s",
         r.stream_id, r.frame_sequence, r.scored ? r.score : 0.0f, (int)r.matched_teacher_frame,
         (unsigned)r.ghost_joint_count,
         ((double)now.tv_sec * 1e9 + (double)now.tv_nsec - (double)r.arrival_ns) / 1000.0,
         r.part_to_fix >= 0 && r.part_to_fix < KATA_PART_COUNT ? kParts[r.part_to_fix] : "-");
  if (KATA_RESULT_HAS(&r, repetition) && r.repetition > 0)
    printf(", rep %d %.0f%%", (int)r.repetition, 100.0 * r.repetition_progress);
  if (owner) printf(" (shard %s, epoch %" PRIu64 ")", owner, epoch);
  printf("\n");
  fflush(stdout);
  return 1;
}

static int run_zmq(const char* endpoint, const char* stream, long count) {
  static unsigned char buffer[1 << 20];
  void* context = zmq_ctx_new();
  void* sub = zmq_socket(context, ZMQ_SUB);
  char topic[17];
  long seen = 0;
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
  if (stream) { /* the topic of one stream: its id as 16 lowercase hex digits */
    snprintf(topic, sizeof topic, "%016" PRIx64, (uint64_t)strtoull(stream, NULL, 10));
    zmq_setsockopt(sub, ZMQ_SUBSCRIBE, topic, 16);
  } else {
    zmq_setsockopt(sub, ZMQ_SUBSCRIBE, "", 0);
  }
  if (zmq_connect(sub, endpoint) != 0) {
    fprintf(stderr, "cannot connect %s: %s\n", endpoint, zmq_strerror(zmq_errno()));
    return 1;
  }
  while (count == 0 || seen < count) {
    zmq_pollitem_t item = {NULL, 0, ZMQ_POLLIN, 0};
    int n;
    item.socket = sub;
    if (zmq_poll(&item, 1, 10000) <= 0) {
      fprintf(stderr, "no message for 10 s\n");
      return 1;
    }
    n = zmq_recv(sub, buffer, sizeof buffer, 0);
    if (n < 0 || (size_t)n > sizeof buffer) continue;
    seen += print_result(buffer, (size_t)n, NULL, 0);
  }
  zmq_close(sub);
  zmq_ctx_term(context);
  return 0;
}

#ifdef KATA_SAMPLE_NATS
/* The newest epoch seen per stream (open addressing; bounded: a stream beyond it is not
 * remembered, so its stale results would pass, as the library's own filter does). */
#define EPOCH_SLOTS 65536
static struct { uint64_t stream, epoch; int used; } g_epochs[EPOCH_SLOTS];

/* 1: deliver (the newest holder so far, or not remembered); 0: a former holder's, dropped. */
static int accept_epoch(uint64_t stream, uint64_t epoch) {
  size_t i = (size_t)((stream * 0x9E3779B97F4A7C15ULL) >> 48) & (EPOCH_SLOTS - 1);
  size_t probes;
  for (probes = 0; probes < 64; ++probes, i = (i + 1) & (EPOCH_SLOTS - 1)) {
    if (!g_epochs[i].used) {
      g_epochs[i].used = 1;
      g_epochs[i].stream = stream;
      g_epochs[i].epoch = epoch;
      return 1;
    }
    if (g_epochs[i].stream == stream) {
      if (epoch < g_epochs[i].epoch) return 0;
      g_epochs[i].epoch = epoch;
      return 1;
    }
  }
  return 1;
}

/* `<prefix>.out.<16 hex digits>.<epoch>.<owner>`: 1 with the parts, 0 when it is not a result's. */
static int parse_subject(const char* subject, const char* prefix, uint64_t* stream, uint64_t* epoch, const char** owner) {
  const size_t p = strlen(prefix);
  const char* s;
  char* end;
  int i;
  if (strncmp(subject, prefix, p) != 0 || strncmp(subject + p, ".out.", 5) != 0) return 0;
  s = subject + p + 5;
  for (i = 0; i < 16; ++i)
    if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f'))) return 0;
  if (s[16] != '.' || s[17] < '0' || s[17] > '9') return 0;
  *stream = (uint64_t)strtoull(s, NULL, 16);
  *epoch = (uint64_t)strtoull(s + 17, &end, 10);
  if (*end != '.' || end[1] == '\0') return 0;
  *owner = end + 1;
  return 1;
}

/* The connection's events, on stderr: which server it follows after losing one. */
static void on_disconnected(natsConnection* nc, void* closure) {
  (void)nc;
  (void)closure;
  fprintf(stderr, "disconnected\n");
}
static void on_reconnected(natsConnection* nc, void* closure) {
  char url[256] = "";
  (void)closure;
  natsConnection_GetConnectedUrl(nc, url, sizeof url);
  fprintf(stderr, "reconnected to %s\n", url);
}

static int run_nats(const char* urls, const char* stream, long count) {
  const char* prefix = getenv("KATA_NATS_PREFIX") ? getenv("KATA_NATS_PREFIX") : "kata";
  const char* creds = getenv("KATA_NATS_CREDS");
  natsOptions* options = NULL;
  natsConnection* connection = NULL;
  natsSubscription* sub = NULL;
  natsStatus s;
  char subject[256];
  long seen = 0, stale = 0, refused = 0;
  if (stream)
    snprintf(subject, sizeof subject, "%s.out.%016" PRIx64 ".>", prefix, (uint64_t)strtoull(stream, NULL, 10));
  else
    snprintf(subject, sizeof subject, "%s.out.>", prefix);
  /* The servers, split at the commas: a cluster's list, tried in turn at the start and when the
   * server this subscriber is connected to is lost. */
  char list[1024];
  const char* servers[16];
  int n = 0;
  snprintf(list, sizeof list, "%s", urls);
  for (char* save = NULL, *url = strtok_r(list, ", ", &save); url && n < 16; url = strtok_r(NULL, ", ", &save)) servers[n++] = url;
  s = natsOptions_Create(&options);
  if (s == NATS_OK) s = n > 0 ? natsOptions_SetServers(options, servers, n) : NATS_INVALID_ARG;
  if (s == NATS_OK && creds) s = natsOptions_SetUserCredentialsFromFiles(options, creds, NULL);
  if (s == NATS_OK) s = natsOptions_SetMaxReconnect(options, -1); /* a cluster: follow it, forever */
  if (s == NATS_OK) s = natsOptions_SetReconnectWait(options, 100); /* per server; another one is tried at once */
  if (s == NATS_OK) s = natsOptions_SetDisconnectedCB(options, on_disconnected, NULL);
  if (s == NATS_OK) s = natsOptions_SetReconnectedCB(options, on_reconnected, NULL);
  if (s == NATS_OK) s = natsConnection_Connect(&connection, options);
  if (s == NATS_OK) s = natsConnection_SubscribeSync(&sub, connection, subject);
  if (s == NATS_OK) s = natsSubscription_SetPendingLimits(sub, 100000, -1);
  if (s == NATS_OK) s = natsConnection_FlushTimeout(connection, 5000); /* the server has the subscription */
  if (s != NATS_OK) {
    fprintf(stderr, "cannot subscribe to %s on %s: %s\n", subject, urls, natsStatus_GetText(s));
    return 1;
  }
  {
    char url[256] = "";
    natsConnection_GetConnectedUrl(connection, url, sizeof url);
    fprintf(stderr, "subscribed to %s on %s\n", subject, url);
  }
  while (count == 0 || seen < count) {
    natsMsg* msg = NULL;
    uint64_t id = 0, epoch = 0;
    const char* owner = NULL;
    s = natsSubscription_NextMsg(&msg, sub, 10000);
    if (s == NATS_TIMEOUT) {
      fprintf(stderr, "no message for 10 s\n");
      return 1;
    }
    if (s == NATS_SLOW_CONSUMER) continue; /* the client dropped some: result_sequence gaps show where */
    if (s != NATS_OK) {
      fprintf(stderr, "%s\n", natsStatus_GetText(s));
      return 1;
    }
    if (!parse_subject(natsMsg_GetSubject(msg), prefix, &id, &epoch, &owner)) {
      ++refused;
    } else if (accept_epoch(id, epoch)) {
      seen += print_result(natsMsg_GetData(msg), (size_t)natsMsg_GetDataLength(msg), owner, epoch);
    } else {
      ++stale;
    }
    natsMsg_Destroy(msg);
  }
  if (stale || refused) fprintf(stderr, "dropped: %ld stale (a former holder's), %ld not a result's subject\n", stale, refused);
  natsSubscription_Destroy(sub);
  natsConnection_Destroy(connection);
  natsOptions_Destroy(options);
  nats_Close();
  return 0;
}
#endif

int main(int argc, char** argv) {
  const char* stream = argc > 2 ? argv[2] : NULL;
  const long count = argc > 3 ? atol(argv[3]) : 0;
  setvbuf(stdout, NULL, _IOLBF, 0); /* a line per result as it arrives, into a pipe or file too */
  if (argc < 2) {
    fprintf(stderr, "usage: %s ENDPOINT [STREAM_ID] [COUNT]\n", argv[0]);
    return 2;
  }
  if (strncmp(argv[1], "nats://", 7) == 0 || strncmp(argv[1], "tls://", 6) == 0) {
#ifdef KATA_SAMPLE_NATS
    return run_nats(argv[1], stream, count);
#else
    fprintf(stderr, "%s: built without libnats (Debian: libnats-dev), so it reads ZeroMQ only\n", argv[0]);
    return 2;
#endif
  }
  return run_zmq(argv[1], stream, count);
}
