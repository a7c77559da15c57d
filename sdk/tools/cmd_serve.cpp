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
//   tolerance = "normal"                       # or "strict", "lenient", degrees (kata_teacher_desc)
//   [scoring.teachers]                         # per stream id (decimal), optional
//   "7" = "data/cmu/05_02.bvh"
//   teacher_start = 300                        # practice (in [scoring], before the subtables): start
//   loop = [300, 600]                          #   at clip frame N, or loop clip frames A..B
//   [scoring.practice]                         # per stream id, optional
//   "7" = { loop = [120, 480] }                # or { teacher_start = N }
//   [[plugins]]                                # any number: sources and sinks (kata_plugin.h)
//   path = "build/plugins/csv-sink.so"
//   config = "path=scores.csv"
//   [vmc]                                      # optional: streams as VMC performers (docs/vmc.md)
//   rate = 60                                  # bundles a second per performer at most (0: every frame)
//   [vmc.streams]                              # per stream id: its ghost and / or its student, each
//   "7" = { ghost = "127.0.0.1:39539", student = "127.0.0.1:39540" }  # to a VMC receiver
//   [transport]                                # optional: frames and results over a NATS cluster
//   kind = "nats"                              #   instead of [ingest] endpoints and [publish]
//   servers = ["nats://10.0.0.1:4222", "nats://10.0.0.2:4222"]  # or "nats://10.0.0.1:4222,nats://..."
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
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <zmq.h>

#include "coach/vmc_out.hpp"
#include "data_files.hpp"
#include "command.hpp"
#include "failure.hpp"
#include "kata/kata.h"
#include "load_progress.hpp"
#include "serve_config.hpp"
#ifdef KATA_HAVE_NATS
#include "transport/nats/serve_bridge.hpp"
#endif

namespace {

using kata::cli::fail;

std::atomic<bool> g_stop{false};
void serve_on_signal(int) { g_stop.store(true); }

using kata::serve::ServeConfig;
using kata::serve::TeacherSource;
using kata::serve::parse_config;

// The C ABI's objects serve holds, released in the reverse order (the runtime before the teachers
// and the model its streams use; the context last).
struct Handles {
  kata_context context = nullptr;
  kata_model model = nullptr;
  std::map<std::string, kata_teacher> teachers;
  kata_runtime runtime = nullptr;
  ~Handles() {
    kata_runtime_destroy(runtime);
    for (auto& [path, t] : teachers) kata_teacher_destroy(t);
    kata_model_destroy(model);
    kata_context_destroy(context);
  }
  // The library's own message (it names the file), as kata::Error's used to be printed.
  [[noreturn]] void failed() const { fail(kata_context_last_error(context)); }
};

kata_runtime_counters counters_of(kata_runtime runtime) {
  kata_runtime_counters c{};
  c.struct_size = sizeof c;
  kata_runtime_get_counters(runtime, &c);
  return c;
}

// The people frames' counters (kata_runtime_counters.people_*) by their names without "people_".
std::vector<std::pair<const char*, uint64_t>> people_counts(const kata_runtime_counters& c) {
  return {{"frames", c.people_frames},
          {"empty_frames", c.people_empty_frames},
          {"refused_frames", c.people_refused_frames},
          {"poses", c.people_poses},
          {"poses_tracked", c.people_poses_tracked},
          {"refused_non_finite", c.people_refused_non_finite},
          {"refused_out_of_range", c.people_refused_out_of_range},
          {"refused_few_joints", c.people_refused_few_joints},
          {"refused_too_many_poses", c.people_refused_too_many_poses},
          {"refused_table_full", c.people_refused_table_full},
          {"streams_opened", c.people_streams_opened},
          {"streams_closed", c.people_streams_closed},
          {"streams_refused", c.people_streams_refused},
          {"poses_unopened", c.people_poses_unopened}};
}

// --counters FILE: every stream's counters after the stop, as JSON ({"streams": {"<id>": {name:
// count}}, "people": {...}, "ingest": {...}}), by the names of the runtime's drop causes plus frames_in, results and
// published: what tests/support/accounting.py balances against the frames a test sent.
void write_counters(const std::string& path, kata_runtime runtime, const std::string& more = "") {
  uint32_t count = 0;
  kata_runtime_get_stream_counters(runtime, nullptr, 0, &count);
  std::vector<kata_stream_counters> streams(count);
  if (count > 0) {
    streams[0].struct_size = sizeof streams[0];
    if (kata_runtime_get_stream_counters(runtime, streams.data(), count, &count) != KATA_OK)
      fail("serve: cannot read the streams' counters");
  }
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) fail("serve: cannot write " + path);
  std::fprintf(f, "{\"streams\": {");
  const char* sep = "";
  for (const kata_stream_counters& c : streams) {
    std::fprintf(f, "%s\n  \"%llu\": {\"frames_in\": %llu, \"results\": %llu, \"published\": %llu", sep,
                 static_cast<unsigned long long>(c.stream_id), static_cast<unsigned long long>(c.frames_in),
                 static_cast<unsigned long long>(c.results), static_cast<unsigned long long>(c.published));
    const std::pair<const char*, uint64_t> causes[] = {
        {"queue_full", c.queue_full},         {"stopped", c.stopped},
        {"stale", c.stale},                   {"unauthorised", c.unauthorised},
        {"out_of_sequence", c.out_of_sequence}, {"wrong_joints", c.wrong_joints},
        {"refused", c.refused},               {"pipeline_dropped", c.pipeline_dropped},
        {"result_queue_full", c.result_queue_full}, {"send_failed", c.send_failed}};
    for (const auto& [name, n] : causes) std::fprintf(f, ", \"%s\": %llu", name, static_cast<unsigned long long>(n));
    std::fprintf(f, "}");
    sep = ",";
  }
  const kata_runtime_counters i = counters_of(runtime);
  std::fprintf(f, "},\n \"people\": {");
  sep = "";
  for (const auto& [name, n] : people_counts(i)) {
    std::fprintf(f, "%s\"%s\": %llu", sep, name, static_cast<unsigned long long>(n));
    sep = ", ";
  }
  std::fprintf(f, "},\n \"ingest\": {\"received\": %llu, \"frames\": %llu, \"dropped\": %llu, \"unknown_stream\": %llu, "
               "\"out_of_order\": %llu, \"sequence_gaps\": %llu, \"other_shard\": %llu, \"batches\": %llu, "
               "\"batch_frames\": %llu}%s}\n",
               static_cast<unsigned long long>(i.ingest_received), static_cast<unsigned long long>(i.ingest_frames),
               static_cast<unsigned long long>(i.ingest_dropped), static_cast<unsigned long long>(i.ingest_unknown_stream),
               static_cast<unsigned long long>(i.ingest_out_of_order), static_cast<unsigned long long>(i.ingest_sequence_gaps),
               static_cast<unsigned long long>(i.ingest_other_shard), static_cast<unsigned long long>(i.ingest_batches),
               static_cast<unsigned long long>(i.ingest_batch_frames), more.c_str());
  if (std::fclose(f) != 0) fail("serve: cannot write " + path);
}

// The drops of the status line by cause, only those that happened ("unknown stream 120,
// definitions refused 2"): a sum alone does not say what to fix.
std::string drop_causes(const kata_runtime_counters& c) {
  const std::pair<const char*, uint64_t> causes[] = {
      {"not owner", c.ingest_not_owner},
      {"limit", c.ingest_refused_limit},
      {"window", c.ingest_out_of_window},
      {"stale", c.ingest_stale},
      {"malformed", c.ingest_malformed},
      {"definitions refused", c.ingest_refused_skeletons},
      {"unknown stream", c.ingest_unknown_stream},
      {"wrong joint count", c.ingest_wrong_joint_count},
      {"out of order", c.ingest_out_of_order},
      {"not ingest's kind", c.ingest_other_kind},
      {"practice values", c.ingest_practice_bad_values},
      {"practice outside the clip", c.ingest_practice_outside_clip},
      {"practice without a clip teacher", c.ingest_practice_no_clip},
      {"practice queue full", c.ingest_practice_queue_full},
      {"refused by the pipeline", c.refused},
      {"queues", c.queue_full + c.result_queue_full + c.pipeline_dropped + c.send_failed}};
  std::string out;
  for (const auto& [name, count] : causes)
    if (count > 0) out += (out.empty() ? "" : ", ") + std::string(name) + " " + std::to_string(count);
  return out.empty() ? std::string() : " (" + out + ")";
}

// Why a sender's connection failed its handshake, from ZeroMQ's protocol error, and what to change.
std::string handshake_advice(uint64_t error, const ServeConfig& config) {
  const bool sub = !config.runtime.ingest_pull;
  // ZeroMQ reports socket kinds that cannot talk without detail (libzmq 4.3: the peer's READY is
  // refused), or as invalid metadata.
  // Over TCP a keyless sender meeting a CURVE ingest is reported the same way (libzmq 4.3), so with
  // a key here that is named first.
  const bool curve = !config.runtime.key_file.empty();
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
  std::snprintf(code, sizeof code, "0x%08x", static_cast<uint32_t>(error));
  return std::string("ZeroMQ protocol error ") + code;
}

// The comma-separated endpoint list kata_runtime_desc takes.
std::string joined(const std::vector<std::string>& endpoints) {
  std::string out;
  for (const std::string& e : endpoints) out += (out.empty() ? "" : ",") + e;
  return out;
}

// What on_stream_open needs: each stream's teacher and practice section, found by stream id.
struct StreamSetup {
  const ServeConfig* config = nullptr;
  const std::map<std::string, kata_teacher>* teachers = nullptr;
  bool scoring = false;  // a model: streams are scored against their teacher
  kata::coach::VmcStreams* vmc = nullptr;  // [vmc]: each listed stream's rig, once it opens
  const TeacherSource& teacher_of(uint64_t id) const {
    const auto it = config->teachers.find(id);
    return it != config->teachers.end() ? it->second : config->default_teacher;
  }
  const kata::serve::Practice& practice_of(uint64_t id) const {
    const auto it = config->practices.find(id);
    return it != config->practices.end() ? it->second : config->default_practice;
  }
};

// A practice section in the teacher's clip frames -> the alignment's rows (first, last, loop;
// first -1: none set), checked against the clip at start so that a section outside it is refused
// with its file:line.
struct Rows {
  int32_t first = -1, last = -1, loop = 0;
};
Rows rows_for(const kata::serve::Practice& p, const TeacherSource& t, kata_teacher teacher) {
  Rows r;
  if (p.where.empty() || t.path.empty() || !teacher) return r;
  const int frames = static_cast<int>(kata_teacher_frame_count(teacher));
  auto row = [&](int clip_frame) {
    if (clip_frame < t.first_frame || clip_frame - t.first_frame >= frames)
      fail(p.where + ": practice frame " + std::to_string(clip_frame) + " is outside " + t.path + " (frames " +
           std::to_string(t.first_frame) + ".." + std::to_string(t.first_frame + frames - 1) + ")");
    return clip_frame - t.first_frame;
  };
  if (p.teacher_start >= 0) r.first = row(p.teacher_start);
  if (p.loop_first >= 0) {
    r.first = row(p.loop_first);
    r.last = row(p.loop_last);
    r.loop = 1;
  }
  return r;
}

// Each stream a definition opens: its teacher (shared, built at start) with a ghost when the
// definition has a rest pose, and its practice section; on the runtime's I/O thread.
kata_status attach_teacher(const StreamSetup& s, const kata_stream_open_info* info, kata_stream stream) {
  if (!s.scoring) return KATA_OK;  // no model: features only, and nothing to say per stream
  const TeacherSource& source = s.teacher_of(info->stream_id);
  const std::string& path = source.path;
  if (!path.empty()) {
    const kata_teacher teacher = s.teachers->at(path);
    kata_teacher_desc options;
    kata_teacher_desc_init(&options);
    options.ghost = s.config->ghost && info->has_rest_pose ? 1 : 0;
    if (!s.config->tolerance.empty()) options.tolerance = s.config->tolerance.c_str();
    if (const kata_status status = kata_stream_attach_shared_teacher(stream, teacher, &options)) return status;
    const Rows r = rows_for(s.practice_of(info->stream_id), source, teacher);  // checked at start
    if (r.first >= 0)
      if (const kata_status status = kata_stream_set_practice_section(stream, r.first, r.last, r.loop)) return status;
  }
  std::fprintf(stderr, "\nstream %llu: %u joints, %s\n", static_cast<unsigned long long>(info->stream_id),
               info->joint_count, path.empty() ? "features only" : path.c_str());
  return KATA_OK;
}

// ... then, for a stream [vmc] sends, its humanoid rig (after the teacher: the rig reads its ghosts).
kata_status on_stream_open(void* user, const kata_stream_open_info* info, kata_stream stream) {
  const StreamSetup& s = *static_cast<const StreamSetup*>(user);
  if (const kata_status status = attach_teacher(s, info, stream)) return status;
  if (s.vmc) s.vmc->open(info->stream_id, stream);
  return KATA_OK;
}

// What the runtime hands over inside the process: every result (to NATS, and each ghost to [vmc])
// and, for [vmc], every student frame queued. Never blocks (VmcStreams copies into its ring).
struct InProcess {
#ifdef KATA_HAVE_NATS
  kata::transport::nats::ServeBridge* nats = nullptr;
#endif
  kata::coach::VmcStreams* vmc = nullptr;
};
void on_result(void* user, const kata_result_record* r) {
  const InProcess& p = *static_cast<const InProcess*>(user);
#ifdef KATA_HAVE_NATS
  if (p.nats) p.nats->publish(*r);
#endif
  if (p.vmc && r->ghost) p.vmc->offer_ghost(r->stream_id, r->capture_time, r->ghost, r->ghost_joint_count);
}
#ifdef KATA_HAVE_NATS
void on_repetition(void* user, const kata_repetition* repetition) {
  const InProcess& p = *static_cast<const InProcess*>(user);
  if (p.nats) p.nats->publish_repetition(*repetition);
}
#endif
void on_frame(void* user, uint64_t stream_id, uint64_t, double capture_time, const float* xyz, uint32_t joints) {
  static_cast<kata::coach::VmcStreams*>(user)->offer_student(stream_id, capture_time, xyz, joints);
}

// [vmc]'s figures at the stop: a line on stderr per stream, and for --counters a JSON member.
std::string vmc_report(kata::coach::VmcStreams& vmc) {
  vmc.close();  // what is in its ring is sent first
  std::string json = ",\n \"vmc\": {";
  const char* sep = "";
  for (const auto& c : vmc.counters()) {
    std::fprintf(stderr, "kata serve: vmc stream %llu: %llu offered, %llu bundles sent, %llu sends failed, %llu thinned "
                         "to the rate, %llu dropped (queue full), %llu not posed\n",
                 static_cast<unsigned long long>(c.stream_id), static_cast<unsigned long long>(c.offered),
                 static_cast<unsigned long long>(c.sent), static_cast<unsigned long long>(c.send_failed),
                 static_cast<unsigned long long>(c.thinned), static_cast<unsigned long long>(c.dropped),
                 static_cast<unsigned long long>(c.pose_failed));
    char one[320];
    std::snprintf(one, sizeof one,
                  "%s\"%llu\": {\"offered\": %llu, \"sent\": %llu, \"send_failed\": %llu, \"thinned\": %llu, "
                  "\"dropped\": %llu, \"pose_failed\": %llu}",
                  sep, static_cast<unsigned long long>(c.stream_id), static_cast<unsigned long long>(c.offered),
                  static_cast<unsigned long long>(c.sent), static_cast<unsigned long long>(c.send_failed),
                  static_cast<unsigned long long>(c.thinned), static_cast<unsigned long long>(c.dropped),
                  static_cast<unsigned long long>(c.pose_failed));
    json += one;
    sep = ", ";
  }
  return json + "}";
}

void progress_of(void* user, uint32_t done, uint32_t frames) {
  (*static_cast<kata::tools::LoadProgress*>(user))(static_cast<int>(done), static_cast<int>(frames));
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
  // [vmc]: declared before the handles, so it outlives the runtime that calls it.
  std::unique_ptr<kata::coach::VmcStreams> vmc;
  InProcess in_process;
  Handles h;
  if (kata_context_create(&h.context) != KATA_OK) fail("serve: cannot create a kata context");
  if (!config.model.empty() && kata_model_load(h.context, config.model.c_str(), &h.model) != KATA_OK)
    h.failed();
  // Teachers are loaded once (at start) and shared by every stream that uses them.
  auto load_teacher = [&](const TeacherSource& t) {
    if (t.path.empty() || !h.model || h.teachers.count(t.path)) return;
    kata::tools::LoadProgress progress(t.path);  // a line on stderr if loading takes > 1 s
    kata_clip clip = nullptr;
    if (kata_clip_load_bvh(h.context, t.path.c_str(), &clip) != KATA_OK) h.failed();
    kata_teacher_desc d;
    kata_teacher_desc_init(&d);
    d.model = h.model;
    d.clip = clip;
    d.first_frame = static_cast<uint32_t>(t.first_frame);
    d.on_progress = progress_of;
    d.on_progress_user = &progress;
    kata_teacher teacher = nullptr;
    const kata_status status = kata_teacher_create(h.context, &d, &teacher);
    kata_clip_destroy(clip);
    if (status != KATA_OK) h.failed();
    h.teachers[t.path] = teacher;
  };
  load_teacher(config.default_teacher);
  for (const auto& [id, t] : config.teachers) load_teacher(t);
  StreamSetup setup;
  setup.config = &config;
  setup.teachers = &h.teachers;
  setup.scoring = h.model != nullptr;
  auto teacher_handle = [&](const TeacherSource& t) {
    const auto it = h.teachers.find(t.path);
    return it != h.teachers.end() ? it->second : nullptr;
  };
  rows_for(config.default_practice, config.default_teacher, teacher_handle(config.default_teacher));
  for (const auto& [id, t] : config.teachers) rows_for(setup.practice_of(id), t, teacher_handle(t));
  for (const auto& [id, p] : config.practices) rows_for(p, setup.teacher_of(id), teacher_handle(setup.teacher_of(id)));

  const kata::serve::RuntimeSettings& rs = config.runtime;
  const std::string ingest_endpoints = joined(rs.ingest_endpoints), publish_endpoints = joined(rs.publish_endpoints);
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  rd.workers = static_cast<uint32_t>(rs.workers);
  rd.max_streams = static_cast<uint32_t>(rs.max_streams);
  rd.queue_capacity = static_cast<uint32_t>(rs.frame_queue_capacity);
  rd.result_queue_capacity = 4096;  // the runtime's own default: serve sizes only the frame queue
  rd.publish_endpoints = publish_endpoints.c_str();
  rd.send_hwm = rs.send_hwm;
  rd.ingest_endpoints = ingest_endpoints.c_str();
  rd.ingest_pull = rs.ingest_pull ? 1 : 0;
  rd.max_message_bytes = rs.max_message_bytes;
  rd.skeleton_resend_seconds = rs.skeleton_resend_seconds;
  rd.key_file = rs.key_file.empty() ? nullptr : rs.key_file.c_str();
  rd.client_keys_dir = rs.client_keys_dir.empty() ? nullptr : rs.client_keys_dir.c_str();
  rd.ingest_server_key_file = rs.ingest_server_key_file.empty() ? nullptr : rs.ingest_server_key_file.c_str();
  rd.publish_server_key_file = rs.publish_server_key_file.empty() ? nullptr : rs.publish_server_key_file.c_str();
  rd.max_streams_per_sender = rs.max_streams_per_sender;
  rd.max_connections = rs.max_connections;
  rd.max_frame_age_seconds = static_cast<double>(rs.max_frame_age_ms) / 1000.0;
  rd.idle_stream_seconds = static_cast<double>(rs.idle_stream_seconds);
  rd.shard_count = rs.shard_count;
  rd.shard_index = rs.shard_index;
  rd.require_checksum = rs.require_checksum ? 1 : 0;
  rd.idle_backoff = rs.idle_backoff ? 1 : 0;
  rd.sequence_window = rs.sequence_window;
  rd.on_stream_open = on_stream_open;
  rd.on_stream_open_user = &setup;
  if (!config.vmc.empty()) {
    std::vector<kata::coach::VmcStreamTarget> targets;
    for (const kata::serve::VmcStream& v : config.vmc)
      targets.push_back({v.stream_id, v.ghost, v.student, v.rate, v.where});
    vmc = std::make_unique<kata::coach::VmcStreams>(targets, rd.max_joints);
    setup.vmc = vmc.get();
    in_process.vmc = vmc.get();
    rd.on_result = on_result;
    rd.on_result_user = &in_process;
    rd.on_frame = on_frame;
    rd.on_frame_user = vmc.get();
    for (const kata::serve::VmcStream& v : config.vmc)
      std::fprintf(stderr, "kata serve: vmc: stream %llu%s%s%s%s\n", static_cast<unsigned long long>(v.stream_id),
                   v.ghost.empty() ? "" : ", its ghost to ", v.ghost.c_str(), v.student.empty() ? "" : ", its student to ",
                   v.student.c_str());
  }
  if (h.model) rd.stream_stencil = kata_model_stencil(h.model);
  // Plugins: hosted by the runtime; every refusal names its file.
  std::vector<kata_runtime_plugin> plugins;
  for (const auto& p : config.plugins) plugins.push_back({p.path.c_str(), p.config.c_str()});
  rd.plugins = plugins.empty() ? nullptr : plugins.data();
  rd.plugin_count = static_cast<uint32_t>(plugins.size());
  // [transport] kind = "nats": the bridge hands every message to the runtime's direct ingest
  // (kata_runtime_offer), on_result publishes the results (declared before the handles: it
  // outlives the runtime's last result; stopped before the runtime is destroyed, below).
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
    so.max_message_bytes = rs.max_message_bytes;
    nats = std::make_unique<kata::transport::nats::ServeBridge>(so);
    rd.ingest_endpoints = nullptr;
    rd.direct_ingest = 1;
    in_process.nats = nats.get();
    rd.on_result = on_result;
    rd.on_repetition = on_repetition;  // on the results' subject, as ZeroMQ's publisher
    rd.on_result_user = &in_process;
  }
#else
  if (config.nats.enabled) fail("serve: [transport] kind = \"nats\": this kata was built without libnats");
#endif
  if (kata_runtime_create(h.context, &rd, &h.runtime) != KATA_OK) fail(kata_context_last_error(h.context));
  kata_runtime runtime = h.runtime;
#ifdef KATA_HAVE_NATS
  // Whichever way this scope ends, libnats' delivery thread stops calling kata_runtime_offer
  // before the runtime is destroyed (the normal end stops the bridge after kata_runtime_stop).
  struct StopBridge {
    kata::transport::nats::ServeBridge* bridge;
    ~StopBridge() {
      if (bridge) bridge->stop();
    }
  } stop_bridge{nats.get()};
  if (nats) {
    nats->start([runtime](const void* data, size_t size) { return kata_runtime_offer(runtime, data, size) == KATA_OK; });
    std::fprintf(stderr, "kata serve: NATS shard %s on %s (subjects %s.in.<stream>, results %s.out.<stream>.<epoch>.<shard>)\n",
                 nats->shard()->options().lease.member.c_str(),
                 const_cast<kata::transport::nats::Shard*>(nats->shard())->connection().connected_url().c_str(),
                 config.nats.subject_prefix.c_str(), config.nats.subject_prefix.c_str());
  }
#endif
  std::signal(SIGINT, serve_on_signal);
  std::signal(SIGTERM, serve_on_signal);
  const std::string ingest_at = kata_runtime_ingest_endpoint(runtime);
  std::fprintf(stderr, "kata serve: ingest %s, publishing on %s (Ctrl-C stops)\n", ingest_at.c_str(),
               kata_runtime_publish_endpoint(runtime));
  kata_runtime_counters previous = counters_of(runtime);
  uint64_t previous_out = previous.published;
  std::vector<uint64_t> latency_before(KATA_LATENCY_BUCKETS), age_before(KATA_LATENCY_BUCKETS);
  std::vector<uint64_t> latency_now(KATA_LATENCY_BUCKETS), age_now(KATA_LATENCY_BUCKETS);
  std::vector<uint64_t> window(KATA_LATENCY_BUCKETS), age(KATA_LATENCY_BUCKETS);
  kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_LATENCY, latency_before.data(), KATA_LATENCY_BUCKETS);
  kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_SOURCE_AGE, age_before.data(), KATA_LATENCY_BUCKETS);
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
    const kata_runtime_counters c = counters_of(runtime);
    // Results out: the publisher's, or on NATS the shard's (the runtime hands them to on_result).
    uint64_t out = c.published;
#ifdef KATA_HAVE_NATS
    if (nats) out = nats->shard()->counters().results_published;
#endif
    if (c.ingest_handshake_failures > handshakes_told) {
      if (handshakes_told == 0)
        std::fprintf(stderr, "\nkata serve: a sender's connection to %s was refused at the handshake: %s; counted "
                             "(handshakes refused), not logged again\n",
                     ingest_at.c_str(), handshake_advice(c.ingest_last_handshake_error, config).c_str());
      handshakes_told = c.ingest_handshake_failures;
    }
    if (!silence_told && c.ingest_received == 0 &&
        std::chrono::duration<double>(now - started).count() >= kSilenceSeconds) {
      silence_told = true;
      std::string why;
      if (c.ingest_handshake_failures > 0)
        why = std::to_string(c.ingest_handshake_failures) + " connection(s) refused at the handshake (above)";
      else if (c.ingest_connections == 0)
        why = "no sender has connected (a bound endpoint waits for senders to connect; a connecting one needs "
              "the sender to bind)";
      else
        why = std::to_string(c.ingest_connections - c.ingest_disconnections) + " sender(s) connected but sent nothing (" +
              config.ingest_kind_where + ")";
      std::fprintf(stderr, "\nkata serve: nothing received on %s in %.0f s: %s\n", ingest_at.c_str(), kSilenceSeconds,
                   why.c_str());
    }
    // The status window's histograms: this second's copy minus the last one's.
    kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_LATENCY, latency_now.data(), KATA_LATENCY_BUCKETS);
    kata_runtime_get_histogram(runtime, KATA_HISTOGRAM_SOURCE_AGE, age_now.data(), KATA_LATENCY_BUCKETS);
    for (int i = 0; i < KATA_LATENCY_BUCKETS; ++i) {
      window[i] = latency_now[i] - latency_before[i];
      age[i] = age_now[i] - age_before[i];
    }
    // Every frame that came in is scored or counted in one drop cause (the pipeline's refusals
    // included: frames with bad values or a time that does not increase).
    const uint64_t drops =
        c.queue_full + c.refused + c.result_queue_full + c.pipeline_dropped + c.send_failed + c.ingest_dropped;
    auto pct = [](const std::vector<uint64_t>& histogram, double q) {
      return kata_histogram_percentile(histogram.data(), KATA_LATENCY_BUCKETS, q) / 1000.0;
    };
    std::fprintf(stderr,
                 "%sstreams %llu | in %.0f frames/s | out %.0f results/s | drops %llu%s | handshakes refused %llu | "
                 "gaps %llu, restarts %llu | latency in->out p50 %.0f us p99 %.0f us | source age p50 %.0f us p99 %.0f us%s",
                 terminal ? "\r" : "", static_cast<unsigned long long>(c.streams),
                 static_cast<double>(c.frames_in - previous.frames_in) / dt,
                 static_cast<double>(out - previous_out) / dt,
                 static_cast<unsigned long long>(drops), drop_causes(c).c_str(),
                 static_cast<unsigned long long>(c.ingest_handshake_failures),
                 static_cast<unsigned long long>(c.ingest_sequence_gaps), static_cast<unsigned long long>(c.ingest_restarts),
                 pct(window, 0.5), pct(window, 0.99), pct(age, 0.5), pct(age, 0.99), terminal ? "   " : "\n");
    previous = c;
    previous_out = out;
    latency_before.swap(latency_now);
    age_before.swap(age_now);
    last = now;
  }
  // Stops the source plugins, finishes queued frames, sends every result, flushes the sink plugins.
  if (kata_runtime_stop(runtime) != KATA_OK) fail(kata_context_last_error(h.context));
  std::string counters_more;  // --counters: [vmc]'s figures; on NATS, each partition's pauses and why
  if (vmc) counters_more += vmc_report(*vmc);
#ifdef KATA_HAVE_NATS
  if (nats) {
    const auto sc = nats->shard()->counters();
    const auto pauses = nats->shard()->leases().pauses();
    nats->stop();  // gives the partitions back: the other shards take them at once
    if (nats->results_refused() > 0)
      std::fprintf(stderr, "kata serve: warning: %llu results could not be written as messages (not published)\n",
                   static_cast<unsigned long long>(nats->results_refused()));
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
    // How long each partition went without results from here, and why (lease lapsed, election, moved).
    std::fprintf(stderr, "kata serve: NATS partition pauses: %s\n", kata::transport::nats::describe_pauses(pauses).c_str());
    counters_more += ",\n \"nats_partitions\": " + kata::transport::nats::pauses_json(pauses);
  }
#endif
  const kata_runtime_counters c = counters_of(runtime);
  std::fprintf(stderr, "\nkata serve: stopped; %llu frames in, %llu results published, %llu ingest messages dropped\n",
               static_cast<unsigned long long>(c.frames_in), static_cast<unsigned long long>(c.published),
               static_cast<unsigned long long>(c.ingest_dropped));
  std::fprintf(stderr,
               "kata serve: ingest %llu messages received (%llu frame batches counted as their %llu frames) = %llu frames + %llu definitions + %llu repeated + %llu closes"
               " + %llu practice settings + %llu repeated + %llu other shard + %llu dropped (not owner %llu, limit %llu, window %llu,"
               " stale %llu, malformed %llu, unknown stream %llu, joints %llu, order %llu, refused definitions %llu, results %llu,"
               " practice values %llu, practice outside the clip %llu, practice without a clip %llu, practice queue full %llu); frames: %llu "
               "refused by the pipeline, %llu lost in queues; connections %llu (%llu refused, %llu handshakes refused)\n",
               static_cast<unsigned long long>(c.ingest_received), static_cast<unsigned long long>(c.ingest_batches),
               static_cast<unsigned long long>(c.ingest_batch_frames), static_cast<unsigned long long>(c.ingest_frames),
               static_cast<unsigned long long>(c.ingest_skeletons), static_cast<unsigned long long>(c.ingest_repeated_skeletons),
               static_cast<unsigned long long>(c.ingest_closes), static_cast<unsigned long long>(c.ingest_practices),
               static_cast<unsigned long long>(c.ingest_repeated_practices), static_cast<unsigned long long>(c.ingest_other_shard),
               static_cast<unsigned long long>(c.ingest_dropped), static_cast<unsigned long long>(c.ingest_not_owner),
               static_cast<unsigned long long>(c.ingest_refused_limit), static_cast<unsigned long long>(c.ingest_out_of_window),
               static_cast<unsigned long long>(c.ingest_stale), static_cast<unsigned long long>(c.ingest_malformed),
               static_cast<unsigned long long>(c.ingest_unknown_stream), static_cast<unsigned long long>(c.ingest_wrong_joint_count),
               static_cast<unsigned long long>(c.ingest_out_of_order), static_cast<unsigned long long>(c.ingest_refused_skeletons),
               static_cast<unsigned long long>(c.ingest_other_kind), static_cast<unsigned long long>(c.ingest_practice_bad_values),
               static_cast<unsigned long long>(c.ingest_practice_outside_clip), static_cast<unsigned long long>(c.ingest_practice_no_clip),
               static_cast<unsigned long long>(c.ingest_practice_queue_full), static_cast<unsigned long long>(c.refused),
               static_cast<unsigned long long>(c.queue_full + c.result_queue_full + c.send_failed),
               static_cast<unsigned long long>(c.ingest_connections), static_cast<unsigned long long>(c.ingest_connections_refused),
               static_cast<unsigned long long>(c.ingest_handshake_failures));
  if (c.people_frames + c.people_refused_frames > 0)
    std::fprintf(stderr,
                 "kata serve: people frames %llu tracked (%llu empty) + %llu refused; poses %llu = %llu tracked + "
                 "%llu refused (non-finite %llu, out of range %llu, too few joints %llu, too many poses %llu, table "
                 "full %llu); person streams %llu opened, %llu closed, %llu refused (%llu poses dropped)\n",
                 static_cast<unsigned long long>(c.people_frames), static_cast<unsigned long long>(c.people_empty_frames),
                 static_cast<unsigned long long>(c.people_refused_frames), static_cast<unsigned long long>(c.people_poses),
                 static_cast<unsigned long long>(c.people_poses_tracked),
                 static_cast<unsigned long long>(c.people_poses - c.people_poses_tracked),
                 static_cast<unsigned long long>(c.people_refused_non_finite),
                 static_cast<unsigned long long>(c.people_refused_out_of_range),
                 static_cast<unsigned long long>(c.people_refused_few_joints),
                 static_cast<unsigned long long>(c.people_refused_too_many_poses),
                 static_cast<unsigned long long>(c.people_refused_table_full),
                 static_cast<unsigned long long>(c.people_streams_opened),
                 static_cast<unsigned long long>(c.people_streams_closed),
                 static_cast<unsigned long long>(c.people_streams_refused),
                 static_cast<unsigned long long>(c.people_poses_unopened));
  if (!counters_path.empty()) write_counters(counters_path, runtime, counters_more);
}

void setup(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  auto counters = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("serve", "run a live stage from a TOML config: ZeroMQ frames in, scores and ghosts out");
  cmd->add_option("--config", *path, "the TOML config (every key: " + kata::cli::doc_file("config.md") + ")")->required();
  cmd->add_option("--counters", *counters, "after the stop, write every stream's counters to this JSON file (tests)");
  cmd->callback([path, counters] {
#ifdef KATA_HAVE_NATS
    try {
      run_serve(*path, *counters);
    } catch (const kata::transport::nats::Error& e) {
      kata::cli::fail(e.what());  // NATS could not start (options, servers, lease bucket): a user's error
    }
#else
    run_serve(*path, *counters);
#endif
  });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
