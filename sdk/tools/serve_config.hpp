// The `kata serve` config file (TOML; the keys are documented in cmd_serve.cpp and
// docs/deploy.md): parsed and checked completely before anything starts, every refusal a
// cli::Failure (failure.hpp) naming file:line, or the file when it cannot be read.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>


namespace kata::serve {

struct TeacherSource {
  std::string path;
  int first_frame = 1;
};

// Practice (kata score --teacher-start / --loop): which teacher clip frames a stream
// follows. Clip frame numbers (as the teacher file counts them, first_frame included); checked
// against the clip once it is loaded (Practice::where names the setting in a refusal).
struct Practice {
  int teacher_start = -1;  // the lesson starts at this clip frame; -1: the clip's first
  int loop_first = -1;     // loop = [A, B]: clip frames A..B over and over; -1: no loop
  int loop_last = -1;
  std::string where;       // "file:line" of the setting; empty: none set
};

// [transport] kind = "nats" (docs/deploy.md, "NATS"): frames in and results out over a NATS
// cluster instead of the [ingest] / [publish] ZeroMQ sockets; the fields of
// transport/nats/{connection,lease}.hpp, read here as plain values (the CLI links libnats only
// where it is built).
struct NatsTransport {
  bool enabled = false;
  std::vector<std::string> servers;
  std::string credentials, nkey, nkey_seed;    // a .creds file, or an NKEY user and its seed file
  bool tls = false;
  std::string tls_ca, tls_cert, tls_key;
  std::string shard;                           // this shard's name (empty: kata-<host>-<pid>)
  std::string subject_prefix = "kata";
  uint32_t partitions = 64;
  std::string lease_bucket = "kata_leases";
  int64_t lease_ttl_ms = 3000;
  int lease_replicas = 3;
};

// The runtime's settings as plain values, what kata_runtime_desc takes (kata/runtime.h; defaults
// there), read from [ingest], [publish], [shard], [runtime] and [security].
struct RuntimeSettings {
  std::vector<std::string> ingest_endpoints;  // connected, or bound with "bind:"
  bool ingest_pull = false;                   // kind = "pull"; else "sub"
  uint32_t max_message_bytes = 1u << 20;
  bool require_checksum = true;
  uint32_t max_connections = 256;
  uint32_t max_streams_per_sender = 64;
  uint64_t sequence_window = 1u << 16;
  int64_t max_frame_age_ms = 250;             // 0: not judged
  int64_t idle_stream_seconds = 300;          // 0: never closed
  std::vector<std::string> publish_endpoints;
  int send_hwm = 10000;
  uint32_t shard_count = 1, shard_index = 0;
  int workers = 2;
  double skeleton_resend_seconds = 1.0;
  int max_streams = 1024;
  int frame_queue_capacity = 4096;
  bool idle_backoff = false;                  // idle = "backoff"
  // CURVE (checked when the config is read): resolved paths, empty when not set.
  std::string key_file, client_keys_dir, ingest_server_key_file, publish_server_key_file;
};

// [vmc] (docs/vmc.md, "kata serve"): a stream's ghost and / or student sent as VMC performers.
struct VmcStream {
  uint64_t stream_id = 0;
  std::string ghost, student;  // "HOST:PORT" (checked), "" : not sent
  double rate = 0.0;           // bundles a second per performer at most; 0: every frame
  std::string where;           // "FILE:LINE" of the stream's entry
};

struct ServeConfig {
  NatsTransport nats;
  RuntimeSettings runtime;
  std::string model;  // empty: features only
  TeacherSource default_teacher;
  std::map<uint64_t, TeacherSource> teachers;
  Practice default_practice;                 // [scoring] teacher_start / loop
  std::map<uint64_t, Practice> practices;    // [scoring.practice] per stream id
  bool ghost = true;
  // [scoring] tolerance: every stream's (kata_teacher_desc.tolerance); "" for the default (normal).
  std::string tolerance;
  double status_seconds = 1.0;
  struct Plugin {
    std::string path, config;
  };
  std::vector<Plugin> plugins;
  std::vector<VmcStream> vmc;        // [vmc.streams], by stream id
  bool insecure = false;              // [security] insecure = true
  std::vector<std::string> warnings;  // printed at start (an insecure endpoint beyond this host)
  // Where the ingest's kind is set ("FILE:LINE: kind = \"pull\""), or that it is the default:
  // named when senders cannot talk to it.
  std::string ingest_kind_where;
};

// Reads and checks a config file; relative paths resolve from the file's directory.
ServeConfig parse_config(const std::string& file);
// The same from text in memory; `name` stands for the file in messages and its directory
// resolves relative paths.
ServeConfig parse_config_text(const std::string& text, const std::string& name);

}  // namespace kata::serve
