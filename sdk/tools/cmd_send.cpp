// kata send: plays a BVH clip as a live ZeroMQ source (what a mocap stage sends): its skeleton
// definition, then one Frame per clip frame at the recorded rate (or --speed x), paced by
// sleeping; the definition is re-sent every --definition-interval seconds so a late (or
// restarted) `kata serve` still learns it. --streams N plays N streams (ids stream-id ..
// stream-id+N-1, stream k starting k frames into the clip) from one socket, e.g. into the
// frontend of a `kata proxy` in front of several shards; --warmup sends only definitions first.
#include <zmq.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "command.hpp"
#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "transport/curve.hpp"
#include "transport/wire.hpp"

namespace {

using kata::Error;
using kata::ErrorKind;

struct Options {
  std::string bvh, endpoint, socket = "push", preset = "cmu";
  uint64_t stream_id = 1;
  double speed = 1.0;
  int first_frame = 1, frames = 0, loops = 1, streams = 1;
  double definition_interval = 1.0, warmup = 0.0;
  std::string key, server_key;  // CURVE: this sender's .secret, the server's .pub
  bool close = false;           // end each stream with a closing definition
  bool live_clock = false;      // capture times from this host's clock, not the clip's
};

void run_send(const Options& o) {
  const kata::BvhClip clip = kata::load_bvh(o.bvh);
  const auto positions = kata::clip_positions(clip, o.first_frame);
  const int joints = clip.skeleton.joint_count();
  const int available = clip.frame_count() - o.first_frame;
  const int frames = o.frames > 0 ? std::min(o.frames, available) : available;
  if (frames < 1 || !(o.speed > 0) || o.loops < 1)
    throw Error(ErrorKind::kInvalidArgument, "send: no frames to send (--first-frame, --frames, --speed > 0, --loops >= 1)");
  if (o.streams < 1 || !(o.definition_interval > 0) || !(o.warmup >= 0))
    throw Error(ErrorKind::kInvalidArgument, "send: --streams >= 1, --definition-interval > 0, --warmup >= 0");
  kata::transport::SkeletonDefinition d;
  d.revision = 1;
  d.skeleton = clip.skeleton;
  d.preset = o.preset;
  d.frame_rate = static_cast<float>(1.0 / clip.frame_time);

  void* context = zmq_ctx_new();
  void* socket = zmq_socket(context, o.socket == "pub" ? ZMQ_PUB : ZMQ_PUSH);
  int linger = 2000, hwm = 1000000;
  zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof linger);
  zmq_setsockopt(socket, ZMQ_SNDHWM, &hwm, sizeof hwm);
  if (!o.key.empty() || !o.server_key.empty()) {
    if (o.key.empty() || o.server_key.empty())
      throw Error(ErrorKind::kInvalidArgument, "send: CURVE needs both --key (this sender's .secret) and --server-key");
    kata::transport::CurveOptions curve;
    curve.own = kata::transport::read_key_file(o.key);
    if (curve.own.secret_key.empty()) throw Error(ErrorKind::kInvalidArgument, "send: --key must be a .secret file");
    curve.remote_server = kata::transport::read_key_file(o.server_key).public_key;
    kata::transport::apply_curve(socket, curve);
  }
  const bool bind = o.endpoint.rfind("bind:", 0) == 0;
  const std::string endpoint = bind ? o.endpoint.substr(5) : o.endpoint;
  if ((bind ? zmq_bind(socket, endpoint.c_str()) : zmq_connect(socket, endpoint.c_str())) != 0)
    throw Error(ErrorKind::kIo, "send: cannot use " + o.endpoint + ": " + zmq_strerror(zmq_errno()));
  kata::transport::Encoder encoder;
  // A server that refuses this sender (an unknown key) leaves no peer to queue for: a send that
  // waits 5 s ends the run with an error rather than hanging.
  const int send_timeout_ms = 5000;
  zmq_setsockopt(socket, ZMQ_SNDTIMEO, &send_timeout_ms, sizeof send_timeout_ms);
  auto send = [&](kata::transport::Bytes m) {
    if (zmq_send(socket, m.data, m.size, 0) < 0) {
      const std::string reason = zmq_strerror(zmq_errno());
      zmq_close(socket);
      zmq_ctx_term(context);
      throw Error(ErrorKind::kIo, "send: " + o.endpoint + " took nothing for 5 s (" + reason +
                                      "; with CURVE: is this sender's key in the server's client directory?)");
    }
  };
  auto send_definitions = [&] {
    for (int k = 0; k < o.streams; ++k) {
      d.stream_id = o.stream_id + static_cast<uint64_t>(k);
      send(encoder.skeleton(d));
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
  uint64_t sequence = 0;
  for (int loop = 0; loop < o.loops; ++loop)
    for (int f = 0; f < frames; ++f, ++sequence) {
      const auto due = start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(period * static_cast<double>(sequence)));
      std::this_thread::sleep_until(due);
      if (std::chrono::steady_clock::now() >= next_definition) {
        send_definitions();
        next_definition += interval;
      }
      // Capture time: the clip's time, continuing over loops (the source's clock), or this host's.
      const int64_t capture_ns =
          o.live_clock ? std::chrono::duration_cast<std::chrono::nanoseconds>(
                             std::chrono::steady_clock::now().time_since_epoch()).count()
                       : static_cast<int64_t>(static_cast<double>(sequence) * clip.frame_time * 1e9);
      for (int k = 0; k < o.streams; ++k) {
        const int frame = (f + k) % available;
        send(encoder.frame(o.stream_id + static_cast<uint64_t>(k), sequence, capture_ns,
                           positions.data() + static_cast<size_t>(frame) * 3 * static_cast<size_t>(joints), joints));
      }
    }
  if (o.close) {
    d.closed = true;
    send_definitions();
  }
  zmq_close(socket);
  zmq_ctx_term(context);
  std::fprintf(stderr, "kata send: %llu frames of %d stream(s) from %llu sent\n", static_cast<unsigned long long>(sequence),
               o.streams, static_cast<unsigned long long>(o.stream_id));
}

void setup(CLI::App& app) {
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("send", "play a BVH clip as a live ZeroMQ source of kata frames (for kata serve)");
  cmd->add_option("--bvh", o->bvh, "the clip")->required();
  cmd->add_option("--endpoint", o->endpoint, "where to send (connect; \"bind:\" binds)")->required();
  cmd->add_option("--socket", o->socket, "push or pub")->capture_default_str();
  cmd->add_option("--stream-id", o->stream_id, "the stream id")->capture_default_str();
  cmd->add_option("--preset", o->preset, "GPD joint map named in the skeleton definition")->capture_default_str();
  cmd->add_option("--speed", o->speed, "times the recorded rate")->capture_default_str();
  cmd->add_option("--first-frame", o->first_frame, "first clip frame (1 skips the CMU T-pose)")->capture_default_str();
  cmd->add_option("--frames", o->frames, "frames per loop (0: to the clip's end)")->capture_default_str();
  cmd->add_option("--loops", o->loops, "times to play the clip (the sequence keeps counting)")->capture_default_str();
  cmd->add_option("--streams", o->streams, "streams from --stream-id on (stream k starts k frames later)")->capture_default_str();
  cmd->add_option("--definition-interval", o->definition_interval, "seconds between skeleton definition re-sends")->capture_default_str();
  cmd->add_option("--warmup", o->warmup, "seconds of definitions only before the first frame")->capture_default_str();
  cmd->add_option("--key", o->key, "CURVE: this sender's key pair (kata keygen's .secret)");
  cmd->add_option("--server-key", o->server_key, "CURVE: the server's public key (.pub)");
  cmd->add_flag("--close", o->close, "close the streams at the end (a closing definition)");
  cmd->add_flag("--live-clock", o->live_clock, "capture times from this host's steady clock (stale frames judged)");
  cmd->callback([o] { run_send(*o); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
