// kata serve --config FILE: a live stage from a TOML config. Frames come in over ZeroMQ (SUB or
// PULL; each stream announced by its skeleton definition), every stream is scored against its
// teacher (per stream id, or the default) and ghosted, results go out on a PUB socket. Prints a
// status line every second; SIGINT / SIGTERM stop it cleanly (queued frames finished, every
// result sent, sockets closed). A bad config is refused with file:line.
//
//   [ingest]                                   # required
//   endpoints = ["tcp://127.0.0.1:5555"]       # connected; "bind:tcp://*:5555" binds
//   kind = "sub"                               # or "pull"
//   max_message_bytes = 1048576                # larger: counted and dropped (4x: sender dropped)
//   max_connections = 256                      # connections held at once (0: no limit)
//   max_streams_per_sender = 64                # (sub: default max_streams, one upstream)
//   sequence_window = 65536                    # a larger forward jump is out_of_window
//   max_frame_age_ms = 250                     # older frames (by the stream's clock) dropped; 0 off
//   idle_stream_seconds = 300                  # streams without traffic closed; 0 never
//   server_key = "keys/stage.pub"              # CURVE: the upstream's public key (connecting ingest)
//   [publish]                                  # required
//   endpoints = ["tcp://127.0.0.1:5556"]
//   send_hwm = 10000
//   server_key = "keys/proxy.pub"              # CURVE: a "connect:" proxy's public key
//   [security]                                 # CURVE (docs/deploy.md); without a key only this
//   key = "keys/server.secret"                 #   host may be bound: this server's pair
//   clients = "keys/clients"                   # allowed senders' and subscribers' *.pub
//   insecure = false                           # true: bind beyond this host without keys (warned)
//   [shard]                                    # optional: one of several shards (docs/deploy.md)
//   count = 3                                  # streams split by kata_shard_of(stream id, count)
//   index = 0                                  # this process scores the streams of shard 0
//   [runtime]
//   workers = 2
//   skeleton_resend_seconds = 1.0
//   idle = "park"                              # or "backoff": spin idle_spin_us before sleeping
//   idle_spin_us = 300                         # (runtime.hpp IdleStrategy; docs/runtime.md)
//   [scoring]                                  # optional: without it, features only
//   model = "models/default.kata"              # relative paths: from the config file's directory
//   teacher = "data/cmu/02_01.bvh"             # the default teacher
//   first_frame = 1                            # skip the CMU T-pose
//   ghost = true
//   [scoring.teachers]                         # per stream id (decimal), optional
//   "7" = "data/cmu/05_02.bvh"
//   teacher_start = 300                        # practice (in [scoring], before the subtables): start
//   loop = [300, 600]                          #   at clip frame N, or loop clip frames A..B
//   [scoring.practice]                         # per stream id, optional
//   "7" = { loop = [120, 480] }                # or { teacher_start = N }
//   [[plugins]]                                # any number: sources and sinks (kata_plugin.h)
//   path = "build/plugins/csv-sink.so"
//   config = "path=scores.csv"
//   [transport]                                # optional: frames and results over a NATS cluster
//   kind = "nats"                              #   instead of [ingest] endpoints and [publish]
//   servers = ["nats://10.0.0.1:4222", "nats://10.0.0.2:4222"]
//   credentials = "keys/shard.creds"           # or nkey = "U..." + nkey_seed = "keys/shard.nk"
//   tls = false                                # tls_ca, tls_cert, tls_key: files
//   shard = "shard-a"                          # this shard's name (default kata-<host>-<pid>)
//   subject_prefix = "kata"                    # partitions = 64, lease_bucket = "kata_leases",
//   lease_ttl_ms = 3000                        #   lease_replicas = 3 (docs/deploy.md, "NATS")
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include <toml++/toml.h>
#include <zmq.h>

#include "command.hpp"
#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/model_file.hpp"
#include "load_progress.hpp"
#include "pipeline/pipeline.hpp"
#include "runtime/plugin.hpp"
#include "runtime/plugin_host.hpp"
#include "runtime/runtime.hpp"
#include "serve_config.hpp"
#ifdef KATA_HAVE_NATS
#include <unistd.h>

#include "transport/nats/serve_bridge.hpp"
#endif

namespace {

using kata::Error;
using kata::ErrorKind;

std::atomic<bool> g_stop{false};
void serve_on_signal(int) { g_stop.store(true); }

using kata::serve::ServeConfig;
using kata::serve::TeacherSource;
using kata::serve::parse_config;

// --counters FILE: every stream's counters after the stop, as JSON ({"streams": {"<id>": {name:
// count}}, "ingest": {...}}), by the names of runtime::kDropCauses plus frames_in, results and
// published: what tests/support/accounting.py balances against the frames a test sent.
void write_counters(const std::string& path, const kata::runtime::Runtime& runtime) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw Error(ErrorKind::kIo, "serve: cannot write " + path);
  std::fprintf(f, "{\"streams\": {");
  const char* sep = "";
  for (const auto& [id, c] : runtime.all_stream_counters()) {
    std::fprintf(f, "%s\n  \"%llu\": {\"frames_in\": %llu, \"results\": %llu, \"published\": %llu", sep,
                 static_cast<unsigned long long>(id), static_cast<unsigned long long>(c.frames_in),
                 static_cast<unsigned long long>(c.results), static_cast<unsigned long long>(c.published));
    for (const kata::runtime::DropCause& cause : kata::runtime::kDropCauses)
      std::fprintf(f, ", \"%s\": %llu", cause.name, static_cast<unsigned long long>(c.*cause.count));
    std::fprintf(f, "}");
    sep = ",";
  }
  const kata::transport::IngestCounters i = runtime.counters().ingest;
  std::fprintf(f, "},\n \"ingest\": {\"received\": %llu, \"frames\": %llu, \"dropped\": %llu, \"unknown_stream\": %llu, "
               "\"out_of_order\": %llu, \"sequence_gaps\": %llu, \"other_shard\": %llu, \"batches\": %llu, "
               "\"batch_frames\": %llu}}\n",
               static_cast<unsigned long long>(i.received), static_cast<unsigned long long>(i.frames),
               static_cast<unsigned long long>(i.dropped_total()), static_cast<unsigned long long>(i.unknown_stream),
               static_cast<unsigned long long>(i.out_of_order), static_cast<unsigned long long>(i.sequence_gaps),
               static_cast<unsigned long long>(i.other_shard), static_cast<unsigned long long>(i.batches),
               static_cast<unsigned long long>(i.batch_frames));
  if (std::fclose(f) != 0) throw Error(ErrorKind::kIo, "serve: cannot write " + path);
}

// The drops of the status line by cause, only those that happened ("unknown stream 120,
// definitions refused 2"): a sum alone does not say what to fix.
std::string drop_causes(const kata::runtime::RuntimeCounters& c) {
  const auto& in = c.ingest;
  const std::pair<const char*, uint64_t> causes[] = {
      {"not owner", in.not_owner},
      {"limit", in.refused_limit},
      {"window", in.out_of_window},
      {"stale", in.stale},
      {"malformed", in.malformed_total()},
      {"definitions refused", in.refused_skeletons},
      {"unknown stream", in.unknown_stream},
      {"wrong joint count", in.wrong_joint_count},
      {"out of order", in.out_of_order},
      {"not ingest's kind", in.other_kind},
      {"practice values", in.practice_bad_values},
      {"practice outside the clip", in.practice_outside_clip},
      {"practice without a clip teacher", in.practice_no_clip},
      {"practice queue full", in.practice_queue_full},
      {"refused by the pipeline", c.total.refused},
      {"queues", c.total.queue_full + c.total.result_queue_full + c.total.pipeline_dropped + c.total.send_failed}};
  std::string out;
  for (const auto& [name, count] : causes)
    if (count > 0) out += (out.empty() ? "" : ", ") + std::string(name) + " " + std::to_string(count);
  return out.empty() ? std::string() : " (" + out + ")";
}

// Why a sender's connection failed its handshake, from ZeroMQ's protocol error, and what to change.
std::string handshake_advice(uint32_t error, const ServeConfig& config) {
  const bool sub = config.runtime.ingest.kind == kata::transport::IngestKind::kSub;
  // ZeroMQ reports socket kinds that cannot talk without detail (libzmq 4.3: the peer's READY is
  // refused), or as invalid metadata.
  // Over TCP a keyless sender meeting a CURVE ingest is reported the same way (libzmq 4.3), so with
  // a key here that is named first.
  const bool curve = !config.runtime.ingest.security.curve.own.secret_key.empty();
  if (error == 0 || error == ZMQ_PROTOCOL_ERROR_ZMTP_INVALID_METADATA)
    return std::string(curve ? "most likely CURVE is set on one side only ([security] key here; kata send --key and "
                               "--server-key there), else its socket kind cannot talk to this ingest's ("
                             : "most likely its socket kind cannot talk to this ingest's (") +
           config.ingest_kind_where + "): " +
           (sub ? "a SUB ingest takes PUB senders (kata send --socket pub); kata send's default, --socket push, "
                  "needs kind = \"pull\""
                : "a PULL ingest takes PUSH senders (kata send's default); a PUB sender (--socket pub) needs "
                  "kind = \"sub\"");
  if (error == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH)
    return "CURVE is set on one side only ([security] key here; kata send --key and --server-key there)";
  char code[16];
  std::snprintf(code, sizeof code, "0x%08x", error);
  return std::string("ZeroMQ protocol error ") + code;
}

void run_serve(const std::string& file, const std::string& counters_path) {
  ServeConfig config = parse_config(file);
  for (const std::string& w : config.warnings) std::fprintf(stderr, "kata serve: warning: %s\n", w.c_str());
  // Connections need descriptors: the soft limit up to the hard one (a flood of idle
  // connections is cut by [ingest] max_connections long before either).
  {
    rlimit limit{};
    if (getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur < limit.rlim_max) {
      limit.rlim_cur = limit.rlim_max;
      setrlimit(RLIMIT_NOFILE, &limit);
    }
  }
  std::shared_ptr<const kata::metric::Metric> metric;
  if (!config.model.empty())
    metric = std::make_shared<const kata::metric::Metric>(kata::metric::load_model(config.model));
  // Teachers are loaded once (at start) and shared by every stream that uses them.
  std::map<std::string, std::shared_ptr<const kata::pipeline::Teacher>> teachers;
  auto load_teacher = [&](const TeacherSource& t) {
    if (t.path.empty() || !metric || teachers.count(t.path)) return;
    kata::tools::LoadProgress progress(t.path);  // a line on stderr if loading takes > 1 s
    const kata::BvhClip clip = kata::load_bvh(t.path);
    const auto positions = kata::clip_positions(clip, t.first_frame);
    const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
    teachers[t.path] = kata::pipeline::Teacher::from_positions(
        metric, clip.skeleton, kata::stream_config_for(clip.skeleton, map, metric->stencil()), positions.data(),
        clip.frame_count() - t.first_frame, clip.frame_time, -1, std::ref(progress));
  };
  load_teacher(config.default_teacher);
  for (const auto& [id, t] : config.teachers) load_teacher(t);
  // A practice section in the teacher's clip frames -> the alignment's rows, checked against the
  // clip here (at start), so that a section outside it is refused with its file:line.
  auto alignment_for = [&](const kata::serve::Practice& p, const TeacherSource& t) {
    kata::metric::AlignmentOptions o;
    if (p.where.empty() || t.path.empty() || !metric) return o;
    const int frames = teachers.at(t.path)->reference->frames();
    auto row = [&](int clip_frame) {
      if (clip_frame < t.first_frame || clip_frame - t.first_frame >= frames)
        throw Error(ErrorKind::kParse, p.where + ": practice frame " + std::to_string(clip_frame) + " is outside " +
                                           t.path + " (frames " + std::to_string(t.first_frame) + ".." +
                                           std::to_string(t.first_frame + frames - 1) + ")");
      return clip_frame - t.first_frame;
    };
    if (p.teacher_start >= 0) o.first_frame = row(p.teacher_start);
    if (p.loop_first >= 0) {
      o.first_frame = row(p.loop_first);
      o.last_frame = row(p.loop_last);
      o.loop = true;
    }
    return o;
  };
  auto teacher_of = [&](uint64_t id) -> const TeacherSource& {
    const auto it = config.teachers.find(id);
    return it != config.teachers.end() ? it->second : config.default_teacher;
  };
  auto practice_of = [&](uint64_t id) -> const kata::serve::Practice& {
    const auto it = config.practices.find(id);
    return it != config.practices.end() ? it->second : config.default_practice;
  };
  alignment_for(config.default_practice, config.default_teacher);
  for (const auto& [id, t] : config.teachers) alignment_for(practice_of(id), t);
  for (const auto& [id, p] : config.practices) alignment_for(p, teacher_of(id));

  config.runtime.configure_stream = [&](const kata::transport::SkeletonDefinition& d) {
    kata::runtime::StreamSetup s = kata::runtime::setup_from_definition(d);
    if (!metric) return s;
    s.pipeline.stream.stencil = metric->stencil();
    const TeacherSource& source = teacher_of(d.stream_id);
    const std::string& path = source.path;
    if (!path.empty()) {
      s.teacher = teachers.at(path);
      s.teacher_options.ghost = config.ghost && d.skeleton.has_rest_pose;
      s.teacher_options.alignment = alignment_for(practice_of(d.stream_id), source);  // checked at start
    }
    std::fprintf(stderr, "\nstream %llu: %d joints, %s\n", static_cast<unsigned long long>(d.stream_id),
                 d.skeleton.joint_count(), path.empty() ? "features only" : path.c_str());
    return s;
  };

  // Plugins: every refusal names its file. Sinks are part of the runtime's config; sources are
  // started once it runs and stopped before it stops.
  auto target = std::make_shared<kata::runtime::PluginHostTarget>();
  std::vector<std::unique_ptr<kata::runtime::PluginInstance>> sinks, sources;
  for (const auto& p : config.plugins) {
    std::shared_ptr<kata::runtime::LoadedPlugin> loaded = kata::runtime::LoadedPlugin::load(p.path);
    auto instance = std::make_unique<kata::runtime::PluginInstance>(loaded, p.config, target);
    if (loaded->is_sink()) config.runtime.sinks.push_back(instance->sink());
    (loaded->is_source() ? sources : sinks).push_back(std::move(instance));
  }
  // [transport] kind = "nats": the bridge hands every message to the runtime's direct ingest
  // (Runtime::offer), its sink publishes the results (declared before the runtime: it outlives the
  // runtime's last result; stopped before the runtime is destroyed, below).
#ifdef KATA_HAVE_NATS
  std::unique_ptr<kata::transport::nats::ServeBridge> nats;
  if (config.nats.enabled) {
    const auto& n = config.nats;
    kata::transport::nats::ShardOptions so;
    so.connection.servers = n.servers;
    so.connection.credentials_file = n.credentials;
    so.connection.nkey = n.nkey;
    so.connection.nkey_seed_file = n.nkey_seed;
    so.connection.tls = n.tls;
    so.connection.tls_ca_file = n.tls_ca;
    so.connection.tls_cert_file = n.tls_cert;
    so.connection.tls_key_file = n.tls_key;
    char host[64] = "host";
    gethostname(host, sizeof host - 1);
    std::string fallback = std::string("kata-") + host + "-" + std::to_string(getpid());
    for (char& ch : fallback)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-') ch = '_';
    so.lease.member = n.shard.empty() ? fallback.substr(0, 64) : n.shard;
    so.lease.bucket = n.lease_bucket;
    so.lease.partitions = n.partitions;
    so.lease.ttl_ms = n.lease_ttl_ms;
    // Renewed every ttl / 6: ttl - guard holds 4.5 periods, so three renewals in a row may fail
    // before publishing pauses; a killed shard's leases are held again after about ttl + renew / 2.
    so.lease.renew_ms = std::max<int64_t>(50, n.lease_ttl_ms / 6);
    so.lease.guard_ms = n.lease_ttl_ms / 4;
    so.lease.replicas = n.lease_replicas;
    so.prefix = n.subject_prefix;
    so.max_message_bytes = config.runtime.ingest.max_message_bytes;
    nats = std::make_unique<kata::transport::nats::ServeBridge>(so);
    nats->configure(config.runtime);
  }
#else
  if (config.nats.enabled)
    throw Error(ErrorKind::kInvalidArgument, "serve: [transport] kind = \"nats\": this kata was built without libnats");
#endif
  kata::runtime::Runtime runtime(config.runtime);
  target->runtime = &runtime;
#ifdef KATA_HAVE_NATS
  // Whichever way this scope ends, libnats' delivery thread stops calling runtime.offer before
  // the runtime is destroyed (the normal end stops the bridge after runtime.stop(), below).
  struct StopBridge {
    kata::transport::nats::ServeBridge* bridge;
    ~StopBridge() {
      if (bridge) bridge->stop();
    }
  } stop_bridge{nats.get()};
  if (nats) {
    nats->start(runtime);
    std::fprintf(stderr, "kata serve: NATS shard %s on %s (subjects %s.in.<stream>, results %s.out.<stream>.<epoch>.<shard>)\n",
                 nats->shard()->options().lease.member.c_str(),
                 const_cast<kata::transport::nats::Shard*>(nats->shard())->connection().connected_url().c_str(),
                 config.nats.subject_prefix.c_str(), config.nats.subject_prefix.c_str());
  }
#endif
  for (auto& s : sources) s->start();
  std::signal(SIGINT, serve_on_signal);
  std::signal(SIGTERM, serve_on_signal);
  std::fprintf(stderr, "kata serve: ingest %s, publishing on %s (Ctrl-C stops)\n", runtime.ingest_endpoint().c_str(),
               runtime.publish_endpoint().c_str());
  auto previous = runtime.counters();
  uint64_t previous_out = previous.total.published;
  auto last = std::chrono::steady_clock::now();
  const auto started = last;
  uint64_t handshakes_told = 0;
  bool silence_told = false;
  // Nothing received this long after the start: say so, with the likely cause.
  constexpr double kSilenceSeconds = 10.0;
  // On a terminal the status line rewrites itself (\r); into a file or a pipe each is a line of
  // its own, so a log keeps them apart.
  const bool terminal = isatty(fileno(stderr)) != 0;
  while (!g_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    const double dt = std::chrono::duration<double>(now - last).count();
    if (dt < config.status_seconds) continue;
    const auto c = runtime.counters();
    // Results out: the publisher's, or on NATS the shard's (the runtime hands them to its sink).
    uint64_t out = c.total.published;
#ifdef KATA_HAVE_NATS
    if (nats) out = nats->shard()->counters().results_published;
#endif
    if (c.ingest.handshake_failures > handshakes_told) {
      if (handshakes_told == 0)
        std::fprintf(stderr, "\nkata serve: a sender's connection to %s was refused at the handshake: %s; counted "
                             "(handshakes refused), not logged again\n",
                     runtime.ingest_endpoint().c_str(), handshake_advice(c.ingest.last_handshake_error, config).c_str());
      handshakes_told = c.ingest.handshake_failures;
    }
    if (!silence_told && c.ingest.received == 0 &&
        std::chrono::duration<double>(now - started).count() >= kSilenceSeconds) {
      silence_told = true;
      const auto& in = c.ingest;
      std::string why;
      if (in.handshake_failures > 0)
        why = std::to_string(in.handshake_failures) + " connection(s) refused at the handshake (above)";
      else if (in.connections == 0)
        why = "no sender has connected (a bound endpoint waits for senders to connect; a connecting one needs "
              "the sender to bind)";
      else
        why = std::to_string(in.connections - in.disconnections) + " sender(s) connected but sent nothing (" +
              config.ingest_kind_where + ")";
      std::fprintf(stderr, "\nkata serve: nothing received on %s in %.0f s: %s\n", runtime.ingest_endpoint().c_str(),
                   kSilenceSeconds, why.c_str());
    }
    uint64_t window[kata::runtime::kLatencyBuckets], age[kata::runtime::kLatencyBuckets];
    static_assert(kata::transport::IngestCounters::kAgeBuckets == kata::runtime::kLatencyBuckets, "one bucket scheme");
    for (int i = 0; i < kata::runtime::kLatencyBuckets; ++i) {
      window[i] = c.latency_histogram[i] - previous.latency_histogram[i];
      age[i] = c.ingest.age_histogram[i] - previous.ingest.age_histogram[i];
    }
    // Every frame that came in is scored or counted in one drop cause (the pipeline's refusals
    // included: frames with bad values or a time that does not increase).
    const uint64_t drops = c.total.queue_full + c.total.refused + c.total.result_queue_full +
                           c.total.pipeline_dropped + c.total.send_failed + c.ingest.dropped_total();
    std::fprintf(stderr,
                 "%sstreams %llu | in %.0f frames/s | out %.0f results/s | drops %llu%s | handshakes refused %llu | "
                 "gaps %llu, restarts %llu | latency in->out p50 %.0f us p99 %.0f us | source age p50 %.0f us p99 %.0f us%s",
                 terminal ? "\r" : "", static_cast<unsigned long long>(c.streams),
                 static_cast<double>(c.total.frames_in - previous.total.frames_in) / dt,
                 static_cast<double>(out - previous_out) / dt,
                 static_cast<unsigned long long>(drops), drop_causes(c).c_str(),
                 static_cast<unsigned long long>(c.ingest.handshake_failures),
                 static_cast<unsigned long long>(c.ingest.sequence_gaps), static_cast<unsigned long long>(c.ingest.restarts),
                 kata::runtime::latency_percentile(window, 0.5) / 1000.0,
                 kata::runtime::latency_percentile(window, 0.99) / 1000.0,
                 kata::runtime::latency_percentile(age, 0.5) / 1000.0,
                 kata::runtime::latency_percentile(age, 0.99) / 1000.0, terminal ? "   " : "\n");
    previous = c;
    previous_out = out;
    last = now;
  }
  for (auto& s : sources) s->stop();
  runtime.stop();  // finishes queued frames, sends every result, flushes the sink plugins
  target->runtime = nullptr;
#ifdef KATA_HAVE_NATS
  if (nats) {
    const auto sc = nats->shard()->counters();
    nats->stop();  // gives the partitions back: the other shards take them at once
    std::fprintf(stderr,
                 "kata serve: NATS %llu messages received (%llu handed on; %llu oversized, %llu outside their partition, "
                 "%llu after the partition was given up, %llu dropped as a slow consumer, %llu not taken by the ingest); "
                 "%llu results published, %llu of streams not held; partitions acquired %llu, released %llu, lost %llu, "
                 "paused %llu; reconnects %llu\n",
                 static_cast<unsigned long long>(sc.received), static_cast<unsigned long long>(sc.handed_on),
                 static_cast<unsigned long long>(sc.oversized), static_cast<unsigned long long>(sc.wrong_partition),
                 static_cast<unsigned long long>(sc.not_held), static_cast<unsigned long long>(sc.slow_consumer),
                 static_cast<unsigned long long>(nats->bridge_dropped()), static_cast<unsigned long long>(sc.results_published),
                 static_cast<unsigned long long>(sc.results_not_held), static_cast<unsigned long long>(sc.leases.acquired),
                 static_cast<unsigned long long>(sc.leases.released), static_cast<unsigned long long>(sc.leases.lost),
                 static_cast<unsigned long long>(sc.leases.paused), static_cast<unsigned long long>(sc.reconnects));
  }
#endif
  const auto c = runtime.counters();
  std::fprintf(stderr, "\nkata serve: stopped; %llu frames in, %llu results published, %llu ingest messages dropped\n",
               static_cast<unsigned long long>(c.total.frames_in), static_cast<unsigned long long>(c.total.published),
               static_cast<unsigned long long>(c.ingest.dropped_total()));
  const auto& in = c.ingest;
  std::fprintf(stderr,
               "kata serve: ingest %llu messages received (%llu frame batches counted as their %llu frames) = %llu frames + %llu definitions + %llu repeated + %llu closes"
               " + %llu practice settings + %llu repeated + %llu other shard + %llu dropped (not owner %llu, limit %llu, window %llu,"
               " stale %llu, malformed %llu, unknown stream %llu, joints %llu, order %llu, refused definitions %llu, results %llu,"
               " practice values %llu, practice outside the clip %llu, practice without a clip %llu, practice queue full %llu); frames: %llu "
               "refused by the pipeline, %llu lost in queues; connections %llu (%llu refused, %llu handshakes refused)\n",
               static_cast<unsigned long long>(in.received), static_cast<unsigned long long>(in.batches),
               static_cast<unsigned long long>(in.batch_frames), static_cast<unsigned long long>(in.frames),
               static_cast<unsigned long long>(in.skeletons), static_cast<unsigned long long>(in.repeated_skeletons),
               static_cast<unsigned long long>(in.closes), static_cast<unsigned long long>(in.practices),
               static_cast<unsigned long long>(in.repeated_practices), static_cast<unsigned long long>(in.other_shard),
               static_cast<unsigned long long>(in.dropped_total()), static_cast<unsigned long long>(in.not_owner),
               static_cast<unsigned long long>(in.refused_limit), static_cast<unsigned long long>(in.out_of_window),
               static_cast<unsigned long long>(in.stale), static_cast<unsigned long long>(in.malformed_total()),
               static_cast<unsigned long long>(in.unknown_stream), static_cast<unsigned long long>(in.wrong_joint_count),
               static_cast<unsigned long long>(in.out_of_order), static_cast<unsigned long long>(in.refused_skeletons),
               static_cast<unsigned long long>(in.other_kind), static_cast<unsigned long long>(in.practice_bad_values),
               static_cast<unsigned long long>(in.practice_outside_clip), static_cast<unsigned long long>(in.practice_no_clip),
               static_cast<unsigned long long>(in.practice_queue_full), static_cast<unsigned long long>(c.total.refused),
               static_cast<unsigned long long>(c.total.queue_full + c.total.result_queue_full + c.total.send_failed),
               static_cast<unsigned long long>(in.connections), static_cast<unsigned long long>(in.connections_refused),
               static_cast<unsigned long long>(in.handshake_failures));
  if (!counters_path.empty()) write_counters(counters_path, runtime);
}

void setup(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  auto counters = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("serve", "run a live stage from a TOML config: ZeroMQ frames in, scores and ghosts out");
  cmd->add_option("--config", *path, "the TOML config (see docs/runtime.md)")->required();
  cmd->add_option("--counters", *counters, "after the stop, write every stream's counters to this JSON file (tests)");
  cmd->callback([path, counters] { run_serve(*path, *counters); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
