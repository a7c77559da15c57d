// kata send: plays a BVH clip as a live ZeroMQ source (what a mocap stage sends): its skeleton
// definition, then one Frame per clip frame at the recorded rate (or --speed x), paced by
// sleeping; the definition is re-sent every --definition-interval seconds so a late (or
// restarted) `kata serve` still learns it. --streams N plays N streams (ids stream-id ..
// stream-id+N-1, stream k starting k frames into the clip) from one socket, e.g. into the
// frontend of a `kata proxy` in front of several shards; --warmup sends only definitions first.
// Nothing is sent before a peer is there (--connect-timeout): no peer, or one whose socket kind
// cannot talk to this one, ends the run with the likely cause; the run ends saying how many
// frames a peer took. --teacher-start SECONDS or --loop A B sends each stream's practice setting
// (schemas/practice.fbs, revision 1) after its definition, and again with every re-sent definition
// (a re-send of the revision in force changes nothing; a restarted kata serve learns it).
// --transport nats publishes the same messages on NATS instead (docs/deploy.md, "NATS"): each
// stream's on its own subject `<prefix>.in.<stream id as 16 hex digits>`, which the servers'
// mapping puts in the stream's partition; --nats-server (repeatable) and --nats-creds say where and
// as whom. --results ENDPOINT (the server's [publish] endpoint) subscribes to the streams' results
// topics: a definition the server refuses comes back there (kata_message_read_refusal), and the run
// ends with its reason and a failure; without word from there by the end, the run waits up to
// --connect-timeout for it.
// A client of the public C ABI (kata.h) for what any third-party sender needs: the clip is read
// with kata_clip_* and every message is written by kata_message_write_* (kata/runtime.h). The
// sockets (ZeroMQ, CURVE, NATS) are this tool's own transport, not libkata's.
#include <zmq.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "command.hpp"
#include "data_files.hpp"
#include "failure.hpp"  // cli::Failure: how this command reports a failure
#include "kata/kata.h"
#ifdef KATA_HAVE_NATS
#include "transport/nats/connection.hpp"
#include "transport/nats/partition.hpp"
#endif

namespace {

using kata::cli::fail;

struct Options {
  std::string bvh, endpoint, socket = "push", preset = "cmu";
  uint64_t stream_id = 1;
  double speed = 1.0;
  int first_frame = 1, frames = 0, loops = 1, streams = 1;
  double definition_interval = 1.0, warmup = 0.0;
  double connect_timeout = 5.0;  // seconds to wait for a peer before the first message
  std::string key, server_key;  // CURVE: this sender's .secret, the server's .pub
  bool close = false;           // end each stream with a closing definition
  std::string results;          // the server's results endpoint: hear whether it refused a stream
  bool live_clock = false;      // capture times from this host's clock, not the clip's
  // Practice (kata score's --teacher-start / --loop, but in teacher seconds from the teacher's
  // first frame, the axis of a result's matched_teacher_time: the sender does not know the
  // server's teacher clip or its frame rate).
  double teacher_start = -1.0;   // < 0: not given
  std::vector<double> loop;      // A B, or empty
  // --transport nats: the servers, a credentials file, the subject prefix.
  std::string transport = "zmq";
  std::vector<std::string> nats_servers;
  std::string nats_creds, nats_prefix = "kata";
};

// A clip as the sender plays it, read through the C ABI: its frames from --first-frame on as
// positions (joints x 3 floats each, file units), and the skeleton its definition announces.
class Clip {
 public:
  Clip(const std::string& path, int first_frame) {
    kata_context context = nullptr;
    kata_clip clip = nullptr;
    kata_skeleton skeleton = nullptr;
    if (kata_context_create(&context) != KATA_OK) fail("send: cannot create a kata context");
    context_.reset(context);
    if (kata_clip_load_bvh(context, path.c_str(), &clip) != KATA_OK) fail_with_last_error();
    clip_.reset(clip);
    if (kata_clip_skeleton(clip, &skeleton) != KATA_OK) fail_with_last_error();
    skeleton_.reset(skeleton);
    frame_time = kata_clip_frame_time(clip);
    joints = kata_skeleton_joint_count(skeleton);
    const int count = static_cast<int>(kata_clip_frame_count(clip));
    if (first_frame < 0 || first_frame > count)
      fail(path + ": first frame " + std::to_string(first_frame) + " out of range (the clip has " +
           std::to_string(count) + " frames; --first-frame takes 0.." + std::to_string(count) + ")");
    available = count - first_frame;
    const size_t stride = 3 * static_cast<size_t>(joints);
    positions.resize(static_cast<size_t>(available) * stride);
    for (int f = 0; f < available; ++f)
      if (kata_clip_positions(clip, static_cast<uint32_t>(first_frame + f), positions.data() + static_cast<size_t>(f) * stride,
                              stride) != KATA_OK)
        fail_with_last_error();
  }

  kata_context context() const { return context_.get(); }
  kata_skeleton skeleton() const { return skeleton_.get(); }
  // Frame f (0 = --first-frame) of the clip.
  const float* frame(int f) const { return positions.data() + static_cast<size_t>(f) * 3 * joints; }

  double frame_time = 0.0;  // seconds between frames
  uint32_t joints = 0;
  int available = 0;        // frames from --first-frame to the clip's end
  std::vector<float> positions;

 private:
  [[noreturn]] void fail_with_last_error() const { fail(kata_context_last_error(context_.get())); }
  // Released in reverse order: the skeleton and clip before their context.
  std::unique_ptr<kata_context_s, void (*)(kata_context)> context_{nullptr, kata_context_destroy};
  std::unique_ptr<kata_clip_s, void (*)(kata_clip)> clip_{nullptr, kata_clip_destroy};
  std::unique_ptr<kata_skeleton_s, void (*)(kata_skeleton)> skeleton_{nullptr, kata_skeleton_destroy};
};

// One message's bytes (16-byte topic + FlatBuffer); valid until the writer's next call.
struct Message {
  const uint8_t* data = nullptr;
  size_t size = 0;
};

// The sender's messages, written by libkata's public writers into one buffer that grows to the
// largest message. The definition, practice setting and frame fields are set by the caller.
class Writer {
 public:
  explicit Writer(const Clip& clip) : context_(clip.context()), buffer_(4096) {
    kata_skeleton_message_init(&definition);
    kata_practice_message_init(&practice);
    kata_frame_message_init(&frame);
    definition.skeleton = clip.skeleton();
    frame.joint_count = clip.joints;
  }
  Message skeleton() { return write(kata_message_write_skeleton, definition); }
  Message practice_setting() { return write(kata_message_write_practice, practice); }
  Message frame_message() { return write(kata_message_write_frame, frame); }
  // Why the last write was refused.
  const char* last_error() const { return kata_context_last_error(context_); }

  kata_skeleton_message definition;
  kata_practice_message practice;
  kata_frame_message frame;

 private:
  template <typename M>
  Message write(kata_status (*writer)(const M*, void*, size_t, size_t*), const M& message) {
    size_t size = 0;
    kata_status status = writer(&message, buffer_.data(), buffer_.size(), &size);
    if (status == KATA_E_BUFFER_TOO_SMALL) {
      buffer_.resize(size);
      status = writer(&message, buffer_.data(), buffer_.size(), &size);
    }
    if (status != KATA_OK) fail(std::string("send: ") + last_error());
    return Message{buffer_.data(), size};
  }
  kata_context context_;
  std::vector<uint8_t> buffer_;
};

// One event of a socket monitor (zmq_socket_monitor): two parts, (uint16 event, uint32 value) and
// the endpoint. False when none is waiting.
bool read_socket_event(void* monitor, uint16_t* kind, uint32_t* value) {
  uint8_t event[6];
  if (zmq_recv(monitor, event, sizeof event, ZMQ_DONTWAIT) < 0) return false;
  char endpoint[256];
  zmq_recv(monitor, endpoint, sizeof endpoint, 0);
  std::memcpy(kind, event, 2);
  std::memcpy(value, event + 2, 4);
  return true;
}

// The sender's peers, from its socket's connection events (and, for pub, from the subscriptions
// its XPUB socket hands up): whether someone takes the frames now, and if nobody ever did, why.
class PeerWatch {
 public:
  PeerWatch(void* context, void* socket, bool pub) : socket_(socket), pub_(pub) {
    static std::atomic<int> counter{0};
    const std::string endpoint = "inproc://kata-send-monitor-" + std::to_string(counter++);
    if (zmq_socket_monitor(socket, endpoint.c_str(),
                           ZMQ_EVENT_CONNECTED | ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_DISCONNECTED | ZMQ_EVENT_CONNECT_RETRIED |
                               ZMQ_EVENT_HANDSHAKE_SUCCEEDED | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                               ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) != 0)
      fail(std::string("send: cannot watch the socket: ") + zmq_strerror(zmq_errno()));
    monitor_ = zmq_socket(context, ZMQ_PAIR);
    int linger = 0;
    zmq_setsockopt(monitor_, ZMQ_LINGER, &linger, sizeof linger);
    if (zmq_connect(monitor_, endpoint.c_str()) != 0)
      fail(std::string("send: cannot watch the socket: ") + zmq_strerror(zmq_errno()));
  }
  ~PeerWatch() {
    zmq_socket_monitor(socket_, nullptr, 0);
    zmq_close(monitor_);
  }
  PeerWatch(const PeerWatch&) = delete;
  PeerWatch& operator=(const PeerWatch&) = delete;

  // Reads the events and subscriptions so far (never blocks).
  void poll() {
    uint16_t kind;
    uint32_t value;
    while (read_socket_event(monitor_, &kind, &value)) {
      if (kind == ZMQ_EVENT_CONNECTED || kind == ZMQ_EVENT_ACCEPTED) {
        ++connections_;
        ++handshaking_;
      } else if (kind == ZMQ_EVENT_HANDSHAKE_SUCCEEDED) {
        if (handshaking_ > 0) --handshaking_;
        ++peers_;
        ++ever_;
      } else if (kind == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL) {
        protocol_error_ = value;
      } else if (kind == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
        refused_auth_ = true;
      } else if (kind == ZMQ_EVENT_CONNECT_RETRIED) {
        ++retries_;
      } else if (kind == ZMQ_EVENT_DISCONNECTED) {
        // Gone during its handshake (refused) or after it (a peer leaving).
        if (handshaking_ > 0) {
          --handshaking_;
          ++refused_;
        } else if (peers_ > 0) {
          --peers_;
        }
      }
    }
    if (!pub_) return;
    // XPUB: 1 + topic subscribes, 0 + topic unsubscribes (kata serve subscribes to everything).
    uint8_t message[256];
    for (int n; (n = zmq_recv(socket_, message, sizeof message, ZMQ_DONTWAIT)) >= 0;)
      if (n >= 1) subscriptions_ += message[0] == 1 ? 1 : (subscriptions_ > 0 ? -1 : 0);
  }
  // Someone takes a frame sent now: a peer past its handshake (for pub: one that subscribed).
  bool ready() const { return peers_ > 0 && (!pub_ || subscriptions_ > 0); }
  int connections() const { return connections_; }

  // Why no peer took anything, and what to do.
  std::string why_nobody(const Options& o, bool bind) const {
    const std::string peer_kind = o.socket == "pub" ? "SUB ([ingest] kind = \"sub\")" : "PULL ([ingest] kind = \"pull\")";
    if (refused_auth_)
      return "the peer refused this sender's CURVE key (is its .pub in the server's [security] clients directory?)";
    if (protocol_error_ == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH)
      return "CURVE is set on one side only (the server's [security] key needs --key and --server-key here)";
    if (refused_ > 0)
      return std::to_string(refused_) + " connection(s) closed during the handshake: most likely the peer's socket kind "
             "cannot talk to --socket " + o.socket + ", which needs a " + peer_kind + (o.socket == "pub" ? "" : 
             "; a SUB ingest needs --socket pub") + (o.key.empty() ? "" : ", or the server does not use CURVE");
    if (pub_ && ever_ > 0)
      return "a peer connected but subscribed to nothing (a kata proxy with no subscriber behind it?)";
    if (bind) return "no peer connected to this bound endpoint";
    return "nobody listens there (" + std::to_string(retries_) + " connection attempt(s) failed; is kata serve running, "
           "with [ingest] endpoints = [\"bind:" + o.endpoint + "\"] and kind = \"" + (o.socket == "pub" ? "sub" : "pull") +
           "\"?)";
  }

 private:
  void* socket_;
  void* monitor_ = nullptr;
  bool pub_;
  int connections_ = 0, handshaking_ = 0, peers_ = 0, ever_ = 0, refused_ = 0, retries_ = 0, subscriptions_ = 0;
  uint32_t protocol_error_ = 0;
  bool refused_auth_ = false;
};

// The server's verdict on the streams' definitions, heard on its results endpoint (--results): a
// refusal (a skeleton message with `refused`, kata_message_read_refusal) or anything else on a
// stream's topic (the accepted definition echoed to subscribers, a result).
class Verdicts {
 public:
  Verdicts(void* context, const Options& o) {
    socket_ = zmq_socket(context, ZMQ_SUB);
    int linger = 0;
    zmq_setsockopt(socket_, ZMQ_LINGER, &linger, sizeof linger);
    for (int k = 0; k < o.streams; ++k) {
      char topic[17];
      std::snprintf(topic, sizeof topic, "%016llx", static_cast<unsigned long long>(o.stream_id + static_cast<uint64_t>(k)));
      zmq_setsockopt(socket_, ZMQ_SUBSCRIBE, topic, 16);
    }
  }
  ~Verdicts() { zmq_close(socket_); }
  Verdicts(const Verdicts&) = delete;
  Verdicts& operator=(const Verdicts&) = delete;
  void* socket() const { return socket_; }

  // Reads what arrived (never blocks): false once a refusal was heard (refusal() says it).
  bool poll() {
    for (int n; (n = zmq_recv(socket_, message_.data(), message_.size(), ZMQ_DONTWAIT)) >= 0;) {
      if (static_cast<size_t>(n) > message_.size()) {  // a large result (ghost, features): the topic says enough
        heard_ = true;
        continue;
      }
      uint64_t id = 0;
      char reason[1024];
      const kata_status st = kata_message_read_refusal(message_.data(), static_cast<size_t>(n), &id, reason, sizeof reason);
      if (st == KATA_OK) {
        refusal_ = "kata serve refused stream " + std::to_string(id) + ": " + reason;
        return false;
      }
      if (st == KATA_NO_DATA) heard_ = true;
    }
    return refusal_.empty();
  }
  bool heard() const { return heard_; }
  const std::string& refusal() const { return refusal_; }

 private:
  void* socket_ = nullptr;
  std::vector<uint8_t> message_ = std::vector<uint8_t>(1 << 16);  // a definition's size (a result may be cut)
  bool heard_ = false;
  std::string refusal_;
};

// The capture time of the frame with this sequence number, seconds: the clip's time, continuing
// over loops (the source's clock), or this host's steady clock (--live-clock).
double capture_time(const Options& o, const Clip& clip, uint64_t sequence) {
  if (o.live_clock)
    return static_cast<double>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                   std::chrono::steady_clock::now().time_since_epoch()).count()) * 1e-9;
  return static_cast<double>(sequence) * clip.frame_time;
}

// Plays the frames through send(message, is_frame) with the definitions re-sent on time: the
// pacing both transports share. tick() runs once per frame time, before that time's frames.
// Returns the frames sent.
template <typename Send, typename Tick>
uint64_t play(const Options& o, const Clip& clip, int frames, Writer& w, bool practice, Send send, Tick tick) {
  auto send_definitions = [&] {
    for (int k = 0; k < o.streams; ++k) {
      w.definition.stream_id = o.stream_id + static_cast<uint64_t>(k);
      send(w.skeleton(), false);
      if (practice && !w.definition.closed) {
        w.practice.stream_id = w.definition.stream_id;
        send(w.practice_setting(), false);
      }
    }
  };
  const auto interval = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(o.definition_interval));
  send_definitions();
  if (o.warmup > 0) {
    const auto warm_end = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                                  std::chrono::duration<double>(o.warmup));
    while (std::chrono::steady_clock::now() < warm_end) {
      std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(interval, warm_end - std::chrono::steady_clock::now()));
      send_definitions();
    }
  }
  const auto start = std::chrono::steady_clock::now();
  auto next_definition = start + interval;
  const double period = clip.frame_time / o.speed;
  uint64_t sequence = 0, sent = 0;
  for (int loop = 0; loop < o.loops; ++loop)
    for (int f = 0; f < frames; ++f, ++sequence) {
      std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                std::chrono::duration<double>(period * static_cast<double>(sequence))));
      if (std::chrono::steady_clock::now() >= next_definition) {
        send_definitions();
        next_definition += interval;
      }
      w.frame.sequence = sequence;
      w.frame.capture_time = capture_time(o, clip, sequence);
      tick();
      for (int k = 0; k < o.streams; ++k) {
        w.frame.stream_id = o.stream_id + static_cast<uint64_t>(k);
        w.frame.positions = clip.frame((f + k) % clip.available);
        send(w.frame_message(), true);
        ++sent;
      }
    }
  if (o.close) {
    w.definition.closed = 1;
    send_definitions();
  }
  return sent;
}

// --transport nats: every message on its stream's ingest subject (the topic, its first 16 bytes,
// names the stream). NATS says nothing of who listens: the run ends saying what was published.
void run_send_nats(const Options& o, const Clip& clip, int frames, Writer& w, bool practice) {
#ifdef KATA_HAVE_NATS
  namespace kn = kata::transport::nats;
  kn::ConnectionOptions co;
  for (const auto& list : o.nats_servers)  // each a URL or a comma-separated list of them
    for (auto& url : kn::split_servers(list)) co.servers.push_back(url);
  co.credentials_file = o.nats_creds;
  co.name = "kata-send";
  std::unique_ptr<kn::Connection> connected;
  try {
    connected = std::make_unique<kn::Connection>(co);
  } catch (const kn::Error& e) {
    fail(e.what());  // no server reachable, unusable options: the user's to fix
  }
  kn::Connection& connection = *connected;
  constexpr size_t kTopicBytes = 16;  // a message's first bytes: the stream id as 16 hex digits (kata/runtime.h)
  std::string subject = o.nats_prefix + ".in.";
  const size_t head = subject.size();
  uint64_t refused = 0;
  const uint64_t sent = play(
      o, clip, frames, w, practice,
      [&](Message m, bool) {
        subject.replace(head, std::string::npos, reinterpret_cast<const char*>(m.data), kTopicBytes);
        if (!connection.publish(subject, m.data, m.size)) ++refused;
      },
      [] {});
  const bool flushed = connection.flush(5000);
  std::fprintf(stderr, "kata send: %llu frames (%d stream(s) from %llu) published on NATS at %s%s%s\n",
               static_cast<unsigned long long>(sent), o.streams, static_cast<unsigned long long>(o.stream_id),
               connection.connected_url().c_str(), refused ? "; some refused by the client (disconnected, buffer full)" : "",
               flushed ? "" : "; the server did not confirm the last of them");
  if (sent == 0 || refused == sent) fail("send: nothing was published on NATS");
#else
  (void)o, (void)clip, (void)frames, (void)w, (void)practice;
  fail("send: this kata was built without NATS (libnats-dev)");
#endif
}

void run_send(const Options& o) {
  const Clip clip(o.bvh, o.first_frame);
  const int available = clip.available;
  const int frames = o.frames > 0 ? std::min(o.frames, available) : available;
  if (frames < 1 || !(o.speed > 0) || o.loops < 1)
    fail("send: no frames to send (--first-frame, --frames, --speed > 0, --loops >= 1)");
  if (o.streams < 1 || !(o.definition_interval > 0) || !(o.warmup >= 0))
    fail("send: --streams >= 1, --definition-interval > 0, --warmup >= 0");
  // Slower than recorded, the clip's capture times run ahead of the frames: to the receiver each
  // frame is later behind its capture time than the last, like a source falling behind, and an
  // ingest that judges age drops them all once they are max_frame_age behind (kata serve's PULL
  // default, 250 ms: after 0.5 s at --speed 0.5). Say so before the run, not after it.
  if (o.speed < 1.0 && !o.live_clock)
    std::fprintf(stderr,
                 "kata send: --speed %g with the clip's capture times: the frames fall %.2f s further behind their "
                 "capture times every second, so a receiver that drops stale frames (kata serve's PULL ingest: "
                 "max_frame_age_ms = 250) drops every frame after %.2f s; --live-clock stamps this host's time "
                 "(the motion slowed down), or set max_frame_age_ms = 0 in the receiver's [ingest]\n",
                 o.speed, 1.0 - o.speed, 0.25 / (1.0 - o.speed));
  Writer w(clip);
  // The practice setting, checked here as the server's verifier would (the clip's bounds are the
  // server's): the writer refuses what no clip allows.
  const bool practice = o.teacher_start >= 0.0 || !o.loop.empty();
  w.practice.revision = 1;
  if (o.teacher_start >= 0.0) w.practice.teacher_start = o.teacher_start;
  if (!o.loop.empty()) {
    w.practice.loop = 1;
    w.practice.loop_start = o.loop[0];
    w.practice.loop_end = o.loop[1];
  }
  if (practice) {
    size_t size = 0;
    if (kata_message_write_practice(&w.practice, nullptr, 0, &size) != KATA_E_BUFFER_TOO_SMALL) {
      std::string why = w.last_error();
      const std::string call = "kata_message_write_practice: ";
      if (why.rfind(call, 0) == 0) why.erase(0, call.size());
      fail("send: --teacher-start / --loop: " + why);
    }
  }
  w.definition.revision = 1;
  w.definition.layout = o.preset.c_str();
  w.definition.frame_rate = static_cast<float>(1.0 / clip.frame_time);
  w.skeleton();  // a definition the writer refuses (--layout "") is refused before any socket opens

  if (o.transport == "nats") return run_send_nats(o, clip, frames, w, practice);
  void* context = zmq_ctx_new();
  // pub is an XPUB socket (a PUB to its peers) so that the subscriptions tell who listens; a PUSH
  // queues only on connections whose handshake is done (ZMQ_IMMEDIATE), so a frame it takes went
  // to a peer.
  const bool pub = o.socket == "pub";
  void* socket = zmq_socket(context, pub ? ZMQ_XPUB : ZMQ_PUSH);
  int linger = 2000, hwm = 1000000, immediate = 1;
  zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof linger);
  zmq_setsockopt(socket, ZMQ_SNDHWM, &hwm, sizeof hwm);
  if (!pub) zmq_setsockopt(socket, ZMQ_IMMEDIATE, &immediate, sizeof immediate);
  auto watch = std::make_unique<PeerWatch>(context, socket, pub);
  if (!o.key.empty() || !o.server_key.empty()) {
    if (o.key.empty() || o.server_key.empty())
      fail("send: CURVE needs both --key (this sender's .secret) and --server-key");
    // The key files through the C ABI's reader (what kata serve's config and runtime read them
    // with), then this socket a CURVE client of the server's public key.
    char public_key[KATA_KEY_TEXT_SIZE], secret_key[KATA_KEY_TEXT_SIZE], server_key[KATA_KEY_TEXT_SIZE];
    auto read_keys = [](const std::string& path, char* public_out, char* secret_out) {
      const kata_status status = kata_key_file_read(nullptr, path.c_str(), public_out, secret_out);
      if (status != KATA_OK) fail(kata_context_last_error(nullptr));
    };
    read_keys(o.key, public_key, secret_key);
    if (secret_key[0] == '\0') fail("send: --key must be a .secret file");
    read_keys(o.server_key, server_key, nullptr);
    auto set_key = [&](int option, const char* key, const char* what) {
      if (zmq_setsockopt(socket, option, key, std::strlen(key)) != 0)
        fail(std::string("ZeroMQ: cannot set ") + what + ": " + zmq_strerror(zmq_errno()));
    };
    set_key(ZMQ_CURVE_SERVERKEY, server_key, "ZMQ_CURVE_SERVERKEY");
    set_key(ZMQ_CURVE_PUBLICKEY, public_key, "ZMQ_CURVE_PUBLICKEY");
    set_key(ZMQ_CURVE_SECRETKEY, secret_key, "ZMQ_CURVE_SECRETKEY");
  }
  std::unique_ptr<Verdicts> verdicts;
  if (!o.results.empty()) {
    verdicts = std::make_unique<Verdicts>(context, o);
    // CURVE: the results endpoint is the same server's, with the same keys.
    for (int option : {ZMQ_CURVE_SERVERKEY, ZMQ_CURVE_PUBLICKEY, ZMQ_CURVE_SECRETKEY}) {
      char key[64];
      size_t size = sizeof key;
      if (zmq_getsockopt(socket, option, key, &size) == 0 && size == 41 && key[0] != '\0' && !o.key.empty())
        zmq_setsockopt(verdicts->socket(), option, key, 40);
    }
    if (zmq_connect(verdicts->socket(), o.results.c_str()) != 0)
      fail("send: cannot use --results " + o.results + ": " + zmq_strerror(zmq_errno()));
  }
  const bool bind = o.endpoint.rfind("bind:", 0) == 0;
  const std::string endpoint = bind ? o.endpoint.substr(5) : o.endpoint;
  if ((bind ? zmq_bind(socket, endpoint.c_str()) : zmq_connect(socket, endpoint.c_str())) != 0)
    fail("send: cannot use " + o.endpoint + ": " + zmq_strerror(zmq_errno()));
  auto close_all = [&] {
    watch.reset();
    verdicts.reset();
    zmq_close(socket);
    zmq_ctx_term(context);
  };
  auto give_up = [&](const std::string& what) {
    close_all();
    fail("send: " + o.endpoint + " took nothing: " + what);
  };
  // A refusal heard on --results ends the run: its frames are dropped by the server.
  auto refused = [&] {
    const std::string why = verdicts->refusal();
    close_all();
    fail("send: " + why + " (its frames were dropped)");
  };
  // Nothing goes out before someone takes it: wait for a peer (its handshake done; for pub, its
  // subscription).
  {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                              std::chrono::duration<double>(o.connect_timeout));
    for (watch->poll(); !watch->ready() && std::chrono::steady_clock::now() < until; watch->poll())
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (!watch->ready()) {
      char seconds[32];
      std::snprintf(seconds, sizeof seconds, "%g", o.connect_timeout);
      give_up("no peer in " + std::string(seconds) + " s (--connect-timeout): " + watch->why_nobody(o, bind));
    }
  }
  // A peer that leaves (or a server that refuses this sender) leaves nobody to queue for: a send
  // that waits 5 s ends the run with an error rather than hanging.
  const int send_timeout_ms = 5000;
  zmq_setsockopt(socket, ZMQ_SNDTIMEO, &send_timeout_ms, sizeof send_timeout_ms);
  uint64_t taken = 0, not_taken = 0;  // frames (not definitions) a peer took / sent with nobody there
  auto send = [&](Message m) {
    if (zmq_send(socket, m.data, m.size, 0) < 0)
      give_up("the peer took nothing more for 5 s (" + std::string(zmq_strerror(zmq_errno())) + ") after " +
           std::to_string(taken) + " frame(s); " + watch->why_nobody(o, bind));
  };
  bool someone = false;  // pub: a frame sent with no subscriber is dropped by ZeroMQ
  play(
      o, clip, frames, w, practice,
      [&](Message m, bool frame) {
        send(m);
        if (frame) ++(pub && !someone ? not_taken : taken);
      },
      [&] {
        watch->poll();
        someone = watch->ready();
        if (verdicts && !verdicts->poll()) refused();
      });
  if (verdicts) {
    // No word yet (a short run, or the subscription still on its way when the definitions went):
    // the definitions again every --definition-interval, until the server answers or
    // --connect-timeout passes.
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                              std::chrono::duration<double>(o.connect_timeout));
    auto next = std::chrono::steady_clock::now();
    while (verdicts->poll() && !verdicts->heard() && std::chrono::steady_clock::now() < until) {
      if (std::chrono::steady_clock::now() >= next && !o.close) {
        for (int k = 0; k < o.streams; ++k) {
          w.definition.stream_id = o.stream_id + static_cast<uint64_t>(k);
          send(w.skeleton());
        }
        next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::chrono::duration<double>(o.definition_interval));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!verdicts->refusal().empty()) refused();
    if (!verdicts->heard())
      std::fprintf(stderr, "kata send: no word from %s in %g s (--results: the server's [publish] endpoint?)\n",
                   o.results.c_str(), o.connect_timeout);
  }
  const int connections = watch->connections();
  close_all();
  // "Taken": queued to a peer past its handshake (push), or sent while a subscriber was there (pub).
  std::fprintf(stderr, "kata send: %llu of %llu frames (%d stream(s) from %llu) taken by a peer at %s (%d connection(s))%s\n",
               static_cast<unsigned long long>(taken), static_cast<unsigned long long>(taken + not_taken), o.streams,
               static_cast<unsigned long long>(o.stream_id), o.endpoint.c_str(), connections,
               not_taken ? "; the rest were sent while no subscriber was there (dropped by ZeroMQ)" : "");
  if (taken == 0) fail("send: no frame was taken by a peer");
}

void setup(CLI::App& app) {
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("send", "play a BVH clip as a live ZeroMQ source of kata frames (for kata serve)");
  cmd->add_option("--bvh", o->bvh, "the clip")->required();
  cmd->add_option("--endpoint", o->endpoint, "where to send (connect; \"bind:\" binds); ZeroMQ only");
  cmd->add_option("--transport", o->transport, "zmq, or nats (--nats-server)")
      ->capture_default_str()
      ->check(CLI::IsMember({"zmq", "nats"}));
  cmd->add_option("--nats-server", o->nats_servers, "NATS: the servers, nats://host:4222 or a comma-separated list of URLs (or repeat the option)");
  cmd->add_option("--nats-creds", o->nats_creds, "NATS: a credentials file (user JWT and NKEY seed)");
  cmd->add_option("--nats-prefix", o->nats_prefix, "NATS: the subject prefix (as kata serve's [transport])")
      ->capture_default_str();
  cmd->add_option("--socket", o->socket, "push or pub")->capture_default_str();
  cmd->add_option("--stream-id", o->stream_id, "the stream id")->capture_default_str();
  cmd->add_option("--layout,--preset", o->preset, "layout named in the skeleton definition (--preset: its name before 1.0)")->capture_default_str();
  cmd->add_option("--speed", o->speed, "times the recorded rate")->capture_default_str();
  cmd->add_option("--first-frame", o->first_frame, "first clip frame (1 skips the CMU T-pose)")->capture_default_str();
  cmd->add_option("--frames", o->frames, "frames per loop (0: to the clip's end)")->capture_default_str();
  cmd->add_option("--loops", o->loops, "times to play the clip (the sequence keeps counting)")->capture_default_str();
  cmd->add_option("--streams", o->streams, "streams from --stream-id on (stream k starts k frames later)")->capture_default_str();
  cmd->add_option("--definition-interval", o->definition_interval, "seconds between skeleton definition re-sends")->capture_default_str();
  cmd->add_option("--warmup", o->warmup, "seconds of definitions only before the first frame")->capture_default_str();
  cmd->add_option("--key", o->key, "CURVE: this sender's key pair (kata keygen's .secret)");
  cmd->add_option("--server-key", o->server_key, "CURVE: the server's public key (.pub)");
  cmd->add_option("--connect-timeout", o->connect_timeout,
                  "seconds to wait for a peer (push: a connection; pub: a subscriber) before sending; none: an error")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--teacher-start", o->teacher_start,
                  "practice: the lesson starts at this teacher time, seconds from the teacher's first frame (as a "
                  "result's matched_teacher_time; the server rounds it to a teacher frame)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--loop", o->loop, "practice: loop the teacher section A..B, seconds from its first frame (two numbers: A B)")
      ->expected(2)
      ->excludes("--teacher-start");
  cmd->add_flag("--close", o->close, "close the streams at the end (a closing definition)");
  cmd->add_option("--results", o->results,
                  "the server's results endpoint ([publish], e.g. tcp://127.0.0.1:5556): a stream it refuses (an "
                  "unknown layout, a skeleton that does not fit it) ends the run with its reason and a failure; "
                  "ZeroMQ only");
  cmd->add_flag("--live-clock", o->live_clock, "capture times from this host's steady clock (stale frames judged)");
  cmd->callback([o] {
    if (o->transport == "zmq" && o->endpoint.empty()) throw CLI::RequiredError("--endpoint");
    if (o->transport == "nats" && o->nats_servers.empty()) throw CLI::RequiredError("--nats-server");
    o->bvh = kata::cli::default_data_file(o->bvh);
    run_send(*o);
  });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
