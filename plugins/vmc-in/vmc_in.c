/* vmc-in: a VMC performer (a tracker: SlimeVR, XR Animator, VSeeFace, a game engine) as a live
 * source. Listens for the VMC protocol (OSC over UDP, kata/vmc.h) and pushes each frame it reads
 * as the joints of the "vrm" layout (22 VRM humanoid bones, metres), scored, retargeted and
 * published like any other stream.
 * Config: "port=39539;bind=127.0.0.1;stream=ID;max_packet=65536;max_rate=250;max_datagrams=16000".
 *   port        UDP port (default 39539, the protocol's)
 *   bind        address to listen on (default 127.0.0.1: this host only; 0.0.0.0 for every
 *               interface: a tracker on another machine)
 *   stream      the stream id (default 0)
 *   max_packet  the largest datagram taken, bytes (default 65536; larger are counted oversized)
 *   max_rate    frames pushed per second at most, on average (default 250; bursts of a tenth of a
 *               second's worth pass): a sender faster than this (a flood) has its extra frames
 *               counted and not pushed, so it cannot crowd the runtime's other streams; the newest
 *               pose goes with the next frame pushed
 *   max_datagrams datagrams read per second at most, on average (default 64 x max_rate; bursts of
 *               a tenth of a second's worth pass): beyond it a datagram is taken off the socket
 *               unread and counted (over_budget), so a flood costs the receiving thread a recv
 *               per datagram, not a parse, and leaves the CPU to the runtime's streams
 * On stop it logs what it counted: datagrams, frames pushed, and each cause of a refusal
 * (kata_vmc_counters), datagrams over max_datagrams, frames over max_rate, frames the runtime's
 * queue refused.
 * Public headers only: kata_plugin.h, and kata.h for the VMC reader. */
#define _GNU_SOURCE /* recvmmsg */
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "kata/kata.h"
#include "kata/kata_plugin.h"
#include "plugin_config.h"

typedef struct vmc_in {
  const kata_plugin_host* host;
  uint64_t stream_id;
  char bind[64];
  int port;
  uint32_t max_packet;
  double max_rate;     /* frames pushed per second at most, on average (a token bucket) */
  double burst;        /* frames pushed at once at most (a tenth of a second's worth, at least 2) */
  double max_datagrams; /* datagrams read per second at most, on average (a token bucket) */
  double datagram_burst; /* datagrams read at once at most (a tenth of a second's worth, at least 16) */
  kata_context context;
  kata_vmc_reader reader;
  kata_skeleton skeleton;
  const char* names[KATA_VMC_JOINTS];
  int32_t parents[KATA_VMC_JOINTS];
  unsigned char* buffer; /* max_packet + 1 bytes */
  int fd;
  pthread_t thread;
  atomic_int stop;
  int running;
  uint64_t pushed, over_rate, push_refused, over_budget, sequence;
} vmc_in;

static double now_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void free_vmc_in(vmc_in* v) {
  if (!v) return;
  if (v->fd >= 0) close(v->fd);
  kata_vmc_reader_destroy(v->reader);
  kata_skeleton_destroy(v->skeleton);
  kata_context_destroy(v->context);
  free(v->buffer);
  free(v);
}

static void* activate(const kata_plugin_host* host, const char* config, char* error, size_t capacity) {
  char value[64];
  struct sockaddr_in address;
  double max_rate = 250.0, max_datagrams = 0.0;
  uint32_t i;
  int size = 4 << 20;
  vmc_in* v = (vmc_in*)calloc(1, sizeof *v);
  if (!v) return NULL;
  v->host = host;
  v->fd = -1;
  v->port = KATA_VMC_PORT;
  v->max_packet = KATA_VMC_DEFAULT_MAX_PACKET;
  strcpy(v->bind, "127.0.0.1");
  plugin_config_value(config, "bind", v->bind, sizeof v->bind);
  if (plugin_config_value(config, "port", value, sizeof value)) v->port = atoi(value);
  if (plugin_config_value(config, "stream", value, sizeof value)) v->stream_id = strtoull(value, NULL, 10);
  if (plugin_config_value(config, "max_packet", value, sizeof value)) v->max_packet = (uint32_t)strtoul(value, NULL, 10);
  if (plugin_config_value(config, "max_rate", value, sizeof value)) max_rate = atof(value);
  if (plugin_config_value(config, "max_datagrams", value, sizeof value)) max_datagrams = atof(value);
  else max_datagrams = 64.0 * max_rate;
  if (v->port < 1 || v->port > 65535 || !(max_rate > 0.0) || !(max_datagrams >= max_rate) || v->max_packet < 16 ||
      v->max_packet > (1u << 20)) {
    snprintf(error, capacity, "vmc-in: port must be 1..65535, max_rate > 0, max_datagrams >= max_rate, max_packet 16..1048576");
    goto fail;
  }
  v->max_rate = max_rate;
  v->burst = max_rate / 10.0 < 2.0 ? 2.0 : max_rate / 10.0;
  v->max_datagrams = max_datagrams;
  v->datagram_burst = max_datagrams / 10.0 < 16.0 ? 16.0 : max_datagrams / 10.0;
  if (kata_context_create(&v->context) != KATA_OK ||
      kata_vmc_reader_create(v->context, v->max_packet, &v->reader) != KATA_OK ||
      kata_skeleton_create_layout(v->context, "vrm", &v->skeleton) != KATA_OK) {
    snprintf(error, capacity, "vmc-in: %s", v->context ? kata_context_last_error(v->context) : "no context");
    goto fail;
  }
  for (i = 0; i < KATA_VMC_JOINTS; ++i) {
    v->names[i] = kata_skeleton_joint_name(v->skeleton, i);
    v->parents[i] = kata_skeleton_joint_parent(v->skeleton, i);
  }
  v->buffer = (unsigned char*)malloc((size_t)v->max_packet + 1);
  if (!v->buffer) goto fail;
  memset(&address, 0, sizeof address);
  address.sin_family = AF_INET;
  address.sin_port = htons((uint16_t)v->port);
  if (inet_pton(AF_INET, v->bind, &address.sin_addr) != 1) {
    snprintf(error, capacity, "vmc-in: bind '%s' is not an IPv4 address", v->bind);
    goto fail;
  }
  v->fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (v->fd < 0 || bind(v->fd, (struct sockaddr*)&address, sizeof address) != 0) {
    snprintf(error, capacity, "vmc-in: cannot listen on %s:%d: %s", v->bind, v->port, strerror(errno));
    goto fail;
  }
  setsockopt(v->fd, SOL_SOCKET, SO_RCVBUF, &size, sizeof size); /* a burst waits in the kernel */
  return v;
fail:
  free_vmc_in(v);
  return NULL;
}

static void deactivate(void* instance) { free_vmc_in((vmc_in*)instance); }

static void* receive(void* arg) {
  vmc_in* v = (vmc_in*)arg;
  float xyz[3 * KATA_VMC_JOINTS];
  double tokens = v->burst, last = now_seconds();
  double datagram_tokens = v->datagram_burst, datagram_last = last;
  struct pollfd p;
  p.fd = v->fd;
  p.events = POLLIN;
  while (!atomic_load(&v->stop)) {
    if (poll(&p, 1, 50) <= 0) continue;
    for (;;) { /* every datagram waiting, then poll again */
      int32_t frame = 0;
      double t = 0.0, arrival = now_seconds();
      ssize_t n;
      datagram_tokens += (arrival - datagram_last) * v->max_datagrams; /* refills at max_datagrams */
      if (datagram_tokens > v->datagram_burst) datagram_tokens = v->datagram_burst;
      datagram_last = arrival;
      if (datagram_tokens < 1.0) { /* over the budget: taken off the socket unread, 64 a call */
        unsigned char scratch[64];
        struct iovec io[64];
        struct mmsghdr m[64];
        int k, got;
        memset(m, 0, sizeof m);
        for (k = 0; k < 64; ++k) {
          io[k].iov_base = &scratch[k];
          io[k].iov_len = 1;
          m[k].msg_hdr.msg_iov = &io[k];
          m[k].msg_hdr.msg_iovlen = 1;
        }
        got = recvmmsg(v->fd, m, 64, MSG_DONTWAIT, NULL);
        if (got <= 0) break;
        v->over_budget += (uint64_t)got;
        continue;
      }
      /* MSG_TRUNC: the datagram's real length, so an oversized one is seen as such. */
      n = recv(v->fd, v->buffer, (size_t)v->max_packet + 1, MSG_DONTWAIT | MSG_TRUNC);
      if (n < 0) break;
      datagram_tokens -= 1.0;
      kata_vmc_reader_read(v->reader, v->buffer, (size_t)n, arrival, &frame);
      if (!frame || kata_vmc_reader_positions(v->reader, xyz, 3 * KATA_VMC_JOINTS, &t) != KATA_OK) continue;
      tokens += (arrival - last) * v->max_rate; /* the bucket refills at max_rate, up to burst */
      if (tokens > v->burst) tokens = v->burst;
      last = arrival;
      if (tokens < 1.0) {
        ++v->over_rate;
        continue;
      }
      tokens -= 1.0;
      if (v->host->push_frame(v->host->host_data, v->stream_id, v->sequence++, t, xyz, KATA_VMC_JOINTS) != 0)
        ++v->push_refused;
      else
        ++v->pushed;
    }
  }
  return NULL;
}

static int32_t start(void* instance) {
  vmc_in* v = (vmc_in*)instance;
  /* No rest offsets: the body height comes from the first frames (the sender's own avatar). */
  const int32_t opened =
      v->host->open_stream(v->host->host_data, v->stream_id, KATA_VMC_JOINTS, v->names, v->parents, NULL, "vrm");
  if (opened != 0) return opened;
  atomic_store(&v->stop, 0);
  if (pthread_create(&v->thread, NULL, receive, v) != 0) return KATA_E_INTERNAL;
  v->running = 1;
  return 0;
}

static void stop(void* instance) {
  vmc_in* v = (vmc_in*)instance;
  kata_vmc_counters c;
  char line[640];
  if (!v->running) return;
  atomic_store(&v->stop, 1);
  pthread_join(v->thread, NULL);
  v->running = 0;
  memset(&c, 0, sizeof c);
  c.struct_size = sizeof c;
  kata_vmc_reader_get_counters(v->reader, &c);
  snprintf(line, sizeof line,
           "vmc-in: stream %llu on %s:%d: packets %llu, frames %llu, pushed %llu, over_rate %llu, push_refused %llu, "
           "over_budget %llu, malformed %llu, oversized %llu, wrong_type %llu, unknown_bone %llu, bad_value %llu, out_of_order %llu, "
           "ignored %llu",
           (unsigned long long)v->stream_id, v->bind, v->port, (unsigned long long)c.packets,
           (unsigned long long)c.frames, (unsigned long long)v->pushed, (unsigned long long)v->over_rate,
           (unsigned long long)v->push_refused, (unsigned long long)v->over_budget, (unsigned long long)c.malformed, (unsigned long long)c.oversized,
           (unsigned long long)c.wrong_type, (unsigned long long)c.unknown_bone, (unsigned long long)c.bad_value,
           (unsigned long long)c.out_of_order, (unsigned long long)c.ignored);
  v->host->log(v->host->host_data, line);
}

static const kata_plugin table = {KATA_PLUGIN_ABI_VERSION, sizeof(kata_plugin), "vmc-in",
                                  "a VMC performer (OSC over UDP) as a live stream of the vrm layout "
                                  "(config: port=39539;bind=127.0.0.1;stream=ID;max_packet;max_rate;max_datagrams)",
                                  KATA_PLUGIN_SOURCE, activate, deactivate, start, stop, NULL, NULL, NULL};

KATA_PLUGIN_EXPORT const kata_plugin* kata_plugin_entry(void) { return &table; }
