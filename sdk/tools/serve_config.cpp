// The `kata serve` config file (serve_config.hpp).
#include "serve_config.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <type_traits>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <toml++/toml.h>

#include "coach/vmc_out.hpp"  // parse_vmc_target (inline)
#include "common/quote.hpp"  // bounded, closest_name: std-only, shared with the core
#include "data_files.hpp"
#include "failure.hpp"
#include "kata/kata.h"
#include "serve_config_read.hpp"

namespace kata::serve {

namespace {

[[noreturn]] void refuse(const std::string& file, const toml::source_region& where, const std::string& what) {
  throw cli::Failure(file + ":" + std::to_string(where.begin.line) + ": " + what);
}

// Reads an optional value of type T at `key` in `table`; a present value of the wrong type is refused.
// Integers must be TOML integers (toml++ would convert a float such as 1e300 to int64 with
// undefined behaviour; found by fuzz_serve_config).
template <typename T>
T read(const std::string& file, const toml::table& table, const char* key, T fallback) {
  const toml::node* n = table.get(key);
  if (!n) return fallback;
  if constexpr (std::is_same_v<T, int64_t>) {
    if (!n->is_integer()) refuse(file, n->source(), std::string("'") + key + "' must be an integer");
  }
  if (auto v = n->value<T>()) return *v;
  refuse(file, n->source(), std::string("'") + key + "' has the wrong type");
}

}  // namespace

// An integer in [lo, hi] (serve_config_read.hpp). Only a value the file holds is judged: a
// missing key's fallback is the program's own default.
int64_t detail::read_range(const std::string& file, const toml::table& table, const char* key, int64_t fallback,
                           int64_t lo, int64_t hi) {
  const toml::node* n = table.get(key);
  if (!n) return fallback;
  const int64_t v = read<int64_t>(file, table, key, fallback);
  if (v < lo || v > hi)
    refuse(file, n->source(), std::string("'") + key + "' must be " + std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

namespace {

using detail::read_range;

// A number (integer or float) > 0 and finite.
double read_positive(const std::string& file, const toml::table& table, const char* key, double fallback) {
  const double v = read<double>(file, table, key, fallback);
  if (!(v > 0.0) || !std::isfinite(v)) refuse(file, table.get(key)->source(), std::string("'") + key + "' must be > 0");
  return v;
}

std::vector<std::string> read_strings(const std::string& file, const toml::table& table, const char* key) {
  std::vector<std::string> out;
  const toml::node* n = table.get(key);
  if (!n) return out;
  const toml::array* a = n->as_array();
  if (!a) refuse(file, n->source(), std::string("'") + key + "' must be an array of strings");
  for (const toml::node& e : *a) {
    auto s = e.value<std::string>();
    if (!s) refuse(file, e.source(), std::string("'") + key + "' must hold strings");
    out.push_back(*s);
  }
  return out;
}

// ZeroMQ endpoints: [bind:|connect:]TRANSPORT://ADDRESS. One without a transport would only fail
// later, at bind or connect, with "Invalid argument" and no key; it is refused here with its line.
std::vector<std::string> read_endpoints(const std::string& file, const toml::table& table, const char* section_name) {
  std::vector<std::string> out = read_strings(file, table, "endpoints");
  const toml::array* a = table.get("endpoints") ? table.get("endpoints")->as_array() : nullptr;
  for (size_t i = 0; i < out.size(); ++i) {
    std::string e = out[i];
    for (const char* prefix : {"bind:", "connect:"})
      if (e.rfind(prefix, 0) == 0) e = e.substr(std::string(prefix).size());
    const size_t scheme = e.find("://");
    const std::string transport = scheme == std::string::npos ? std::string() : e.substr(0, scheme);
    if (transport != "tcp" && transport != "ipc" && transport != "inproc")
      refuse(file, (*a)[i].source(),
             "[" + std::string(section_name) + "] endpoints: '" + bounded(out[i]) +
                 "' has no ZeroMQ transport; write tcp://HOST:PORT, ipc://PATH or inproc://NAME (optionally after "
                 "bind: or connect:)");
  }
  return out;
}

const toml::table& section(const std::string& file, const toml::table& root, const char* name, bool required) {
  static const toml::table empty;
  const toml::node* n = root.get(name);
  if (!n) {
    if (required) throw cli::Failure(file + ":1: missing section [" + std::string(name) + "]");
    return empty;
  }
  if (!n->is_table()) refuse(file, n->source(), std::string("'") + name + "' must be a table");
  return *n->as_table();
}

void check_keys(const std::string& file, const toml::table& t, std::initializer_list<const char*> known, const char* where) {
  for (const auto& [key, node] : t) {
    bool ok = false;
    for (const char* k : known) ok = ok || key.str() == k;
    if (ok) continue;
    const std::string hint = closest_name(key.str(), std::vector<std::string>(known.begin(), known.end()));
    refuse(file, node.source(), "unknown key '" + std::string(key.str()) + "' in [" + where + "]" +
                                    (hint.empty() ? std::string() : "; did you mean '" + hint + "'?"));
  }
}

// teacher_start = N or loop = [A, B] (not both) in `table` (the [scoring] table or one stream's
// inline table of [scoring.practice]).
Practice read_practice(const std::string& file, const toml::table& table) {
  Practice p;
  if (table.get("teacher_start"))
    p.teacher_start = static_cast<int>(read_range(file, table, "teacher_start", 0, 0, 1 << 30));
  if (const toml::node* n = table.get("loop")) {
    const toml::array* a = n->as_array();
    if (!a || a->size() != 2 || !(*a)[0].is_integer() || !(*a)[1].is_integer())
      refuse(file, n->source(), "'loop' must be two teacher clip frames [A, B]");
    const int64_t first = *(*a)[0].value<int64_t>(), last = *(*a)[1].value<int64_t>();
    if (first < 0 || last < first || last > (1 << 30)) refuse(file, n->source(), "'loop' = [A, B] needs 0 <= A <= B");
    if (p.teacher_start >= 0) refuse(file, n->source(), "give teacher_start or loop, not both");
    p.loop_first = static_cast<int>(first);
    p.loop_last = static_cast<int>(last);
  }
  const toml::node* at = table.get("loop") ? table.get("loop") : table.get("teacher_start");
  if (at) p.where = file + ":" + std::to_string(at->source().begin.line);
  return p;
}

// tolerance = "strict" | "normal" | "lenient" | DEGREES (a number, 5..120: the angle at which a part
// scores 50; kata_teacher_desc.tolerance, which the streams' attach checks again). "" when absent.
std::string read_tolerance(const std::string& file, const toml::table& table) {
  const toml::node* n = table.get("tolerance");
  if (!n) return "";
  if (n->is_integer() || n->is_floating_point()) {
    const double v = *n->value<double>();
    if (!(v >= 5.0 && v <= 120.0))
      refuse(file, n->source(), "'tolerance' in degrees must be within 5..120 (the angle at which a part scores 50)");
    char text[32];
    std::snprintf(text, sizeof text, "%.9g", v);
    return text;
  }
  const auto s = n->value<std::string>();
  if (!s || (*s != "strict" && *s != "normal" && *s != "lenient"))
    refuse(file, n->source(),
           "'tolerance' must be \"strict\", \"normal\", \"lenient\" or the angle in degrees (5..120) at which a part "
           "scores 50");
  return *s;
}

}  // namespace

ServeConfig parse_root(const std::string& file, const toml::table& root) {
  check_keys(file, root, {"ingest", "publish", "runtime", "scoring", "status", "plugins", "shard", "security", "transport", "vmc"},
             "top level");
  const std::filesystem::path base = std::filesystem::path(file).parent_path();
  // Key files and directories: relative paths from the config file's directory.
  auto resolve = [&](const std::string& p) { return std::filesystem::path(p).is_absolute() ? p : (base / p).string(); };
  // A file the config names: relative paths from the config file's directory; failing that, the
  // files kata ships (PREFIX/share/kata, e.g. "models/default.kata"), so a stage config written in
  // any directory finds the shipped model. A missing file is refused here, with its key's line.
  auto resolve_at = [&](const toml::node& at, const std::string& p, const char* what) {
    std::error_code ec;
    if (std::filesystem::path(p).is_absolute()) {
      if (!std::filesystem::exists(p, ec)) refuse(file, at.source(), std::string(what) + ": no such file '" + p + "'");
      return p;
    }
    const std::string local = (base / p).string();
    if (std::filesystem::exists(local, ec)) return local;
    const std::string shipped = (std::filesystem::path(kata::cli::share_dir()) / p).string();
    if (std::filesystem::exists(shipped, ec)) return shipped;
    refuse(file, at.source(), std::string(what) + ": no such file '" + p + "' (looked in '" +
                                  (base.empty() ? std::string(".") : base.string()) + "' and '" + kata::cli::share_dir() + "')");
  };
  // A plugin: a path as above, or a bare name ("csv-sink") looked up where kata installs its plugins
  // (PREFIX/lib/kata/plugins/NAME.so; in the build tree, build/plugins/NAME.so).
  auto resolve_plugin = [&](const toml::node& at, const std::string& p) {
    if (p.find('/') != std::string::npos) return resolve_at(at, p, "plugin");
    const std::filesystem::path prefix = std::filesystem::path(kata::cli::share_dir()).parent_path().parent_path();
    std::error_code ec;
    for (const auto& dir : {prefix / "lib" / "kata" / "plugins", prefix / "plugins"}) {
      for (const std::string& name : {p, p + ".so"}) {
        if (std::filesystem::is_regular_file(dir / name, ec)) return (dir / name).string();
      }
    }
    const std::string local = (base / p).string();
    if (std::filesystem::exists(local, ec)) return local;
    refuse(file, at.source(), "plugin '" + p + "': not found (a path to a .so, or the name of a plugin in '" +
                                  (prefix / "lib" / "kata" / "plugins").string() + "' or '" + (prefix / "plugins").string() +
                                  "')");
  };
  ServeConfig c;
  // [transport]: "zmq" (the [ingest] and [publish] sockets) or "nats" (a NATS cluster; [ingest]
  // then only sets the ingest's limits, and [publish] and [shard] have no place).
  const toml::table& transport = section(file, root, "transport", false);
  check_keys(file, transport,
             {"kind", "servers", "credentials", "nkey", "nkey_seed", "tls", "tls_ca", "tls_cert", "tls_key", "shard",
              "subject_prefix", "partitions", "lease_bucket", "lease_ttl_ms", "lease_replicas"},
             "transport");
  const std::string transport_kind = read<std::string>(file, transport, "kind", "zmq");
  if (transport_kind != "zmq" && transport_kind != "nats")
    refuse(file, transport.get("kind")->source(), "kind must be \"zmq\" or \"nats\"");
  const bool nats = transport_kind == "nats";
  if (!nats) {
    for (const auto& [key, node] : transport)
      if (key.str() != "kind") refuse(file, node.source(), "'" + std::string(key.str()) + "' is for kind = \"nats\"");
  } else {
    NatsTransport& n = c.nats;
    n.enabled = true;
    const toml::node* servers = transport.get("servers");
    const toml::array* list = servers ? servers->as_array() : nullptr;
    // An array of URLs, or of comma-separated lists of them, or one such list as a string: the
    // server list as every kata NATS client takes it ("nats://n0:4222,nats://n1:4222").
    const auto add_servers = [&](const toml::node& v) {
      const auto text = v.value<std::string>();
      const size_t before = n.servers.size();
      bool ok = text.has_value();
      for (size_t at = 0; ok && at <= text->size();) {
        size_t end = text->find(',', at);
        if (end == std::string::npos) end = text->size();
        std::string url = text->substr(at, end - at);
        url.erase(0, url.find_first_not_of(" \t"));
        url.erase(url.find_last_not_of(" \t") + 1);
        if (!url.empty()) n.servers.push_back(url);
        at = end + 1;
      }
      if (!ok || n.servers.size() == before) refuse(file, v.source(), "servers must be NATS URLs (nats://host:port, tls://host:port)");
    };
    if (servers != nullptr && servers->is_string()) add_servers(*servers);
    else if (list != nullptr)
      for (const auto& v : *list) add_servers(v);
    if (n.servers.empty()) throw cli::Failure(file + ":1: [transport] kind = \"nats\" needs servers = [\"nats://host:4222\", ...]");
    auto file_key = [&](const char* key) {
      const std::string v = read<std::string>(file, transport, key, "");
      return v.empty() ? v : resolve_at(*transport.get(key), v, key);
    };
    n.credentials = file_key("credentials");
    n.nkey = read<std::string>(file, transport, "nkey", "");
    n.nkey_seed = file_key("nkey_seed");
    if (!n.credentials.empty() && !n.nkey.empty())
      refuse(file, transport.get("nkey")->source(), "give credentials or nkey + nkey_seed, not both");
    if (n.nkey.empty() != n.nkey_seed.empty())
      throw cli::Failure(file + ":1: [transport] nkey needs nkey_seed (and the reverse)");
    n.tls = read<bool>(file, transport, "tls", false);
    n.tls_ca = file_key("tls_ca");
    n.tls_cert = file_key("tls_cert");
    n.tls_key = file_key("tls_key");
    if (n.tls_cert.empty() != n.tls_key.empty())
      throw cli::Failure(file + ":1: [transport] tls_cert needs tls_key (and the reverse)");
    n.shard = read<std::string>(file, transport, "shard", "");
    auto token = [](const std::string& v) {
      if (v.empty() || v.size() > 64) return false;
      for (char ch : v)
        if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-') return false;
      return true;
    };
    if (!n.shard.empty() && !token(n.shard))
      refuse(file, transport.get("shard")->source(), "shard must be 1..64 of [A-Za-z0-9_-] (a NATS subject token)");
    n.subject_prefix = read<std::string>(file, transport, "subject_prefix", "kata");
    if (!token(n.subject_prefix))
      refuse(file, transport.get("subject_prefix")->source(), "subject_prefix must be 1..64 of [A-Za-z0-9_-]");
    n.partitions = static_cast<uint32_t>(read_range(file, transport, "partitions", 64, 1, 4096));
    n.lease_bucket = read<std::string>(file, transport, "lease_bucket", "kata_leases");
    if (!token(n.lease_bucket))
      refuse(file, transport.get("lease_bucket")->source(), "lease_bucket must be 1..64 of [A-Za-z0-9_-]");
    n.lease_ttl_ms = read_range(file, transport, "lease_ttl_ms", 3000, 400, 600'000);
    n.lease_replicas = static_cast<int>(read_range(file, transport, "lease_replicas", 3, 1, 5));
  }
  const toml::table& ingest = section(file, root, "ingest", !nats);
  check_keys(file, ingest,
             {"endpoints", "kind", "max_message_bytes", "require_checksum", "max_connections", "max_streams_per_sender",
              "sequence_window", "max_frame_age_ms", "idle_stream_seconds", "server_key"},
             "ingest");
  if (nats) {
    // The shard hands NATS messages to its ingest over a private local socket (cmd_serve.cpp).
    for (const char* key : {"endpoints", "kind", "max_connections", "server_key"})
      if (const toml::node* n = ingest.get(key))
        refuse(file, n->source(), std::string("'") + key + "' is for ZeroMQ: with [transport] kind = \"nats\" frames come from NATS");
    for (const char* name : {"publish", "shard"})
      if (const toml::node* n = root.get(name))
        refuse(file, n->source(), std::string("[") + name + "] is for ZeroMQ: with [transport] kind = \"nats\" results go out on NATS "
                                  "and shards share the partitions by lease (" + kata::cli::doc_file("deploy.md") + ")");
  }
  c.runtime.ingest_endpoints = nats ? std::vector<std::string>{} : read_endpoints(file, ingest, "ingest");
  if (!nats && c.runtime.ingest_endpoints.empty()) throw cli::Failure(file + ":1: [ingest] endpoints is empty");
  const std::string kind = read<std::string>(file, ingest, "kind", nats ? "pull" : "sub");
  if (kind != "sub" && kind != "pull") refuse(file, ingest.get("kind")->source(), "kind must be \"sub\" or \"pull\"");
  c.runtime.ingest_pull = kind == "pull";
  c.ingest_kind_where = ingest.get("kind") ? file + ":" + std::to_string(ingest.get("kind")->source().begin.line) +
                                                 ": kind = \"" + kind + "\""
                                           : file + ": [ingest] has no kind: \"sub\" by default";
  c.runtime.max_message_bytes = static_cast<uint32_t>(read_range(file, ingest, "max_message_bytes", 1 << 20, 64, 1 << 30));
  c.runtime.require_checksum = read<bool>(file, ingest, "require_checksum", true);
  RuntimeSettings& limits = c.runtime;
  c.runtime.max_connections = static_cast<uint32_t>(read_range(file, ingest, "max_connections", 256, 0, 1 << 20));
  limits.max_streams_per_sender =
      static_cast<uint32_t>(read_range(file, ingest, "max_streams_per_sender", 64, 1, 1 << 20));
  limits.sequence_window = static_cast<uint64_t>(read_range(file, ingest, "sequence_window", 1 << 16, 1, int64_t{1} << 40));
  limits.max_frame_age_ms = read_range(file, ingest, "max_frame_age_ms", 250, 0, 3'600'000);
  limits.idle_stream_seconds = read_range(file, ingest, "idle_stream_seconds", 300, 0, 30 * 86400);

  const toml::table& publish = section(file, root, "publish", !nats);
  check_keys(file, publish, {"endpoints", "send_hwm", "server_key"}, "publish");
  c.runtime.publish_endpoints = read_endpoints(file, publish, "publish");
  if (!nats && c.runtime.publish_endpoints.empty()) throw cli::Failure(file + ":1: [publish] endpoints is empty");
  c.runtime.send_hwm = static_cast<int>(read_range(file, publish, "send_hwm", 10000, 0, 1 << 30));

  const toml::table& shard = section(file, root, "shard", false);
  check_keys(file, shard, {"count", "index"}, "shard");
  const int64_t shard_count = read<int64_t>(file, shard, "count", 1);
  const int64_t shard_index = read<int64_t>(file, shard, "index", 0);
  if (shard_count < 1 || shard_count > 65536) refuse(file, shard.get("count")->source(), "shard count must be 1..65536");
  if (shard_index < 0 || shard_index >= shard_count)
    refuse(file, shard.get("index") ? shard.get("index")->source() : shard.get("count")->source(),
           "shard index must be 0..count-1");
  c.runtime.shard_count = static_cast<uint32_t>(shard_count);
  c.runtime.shard_index = static_cast<uint32_t>(shard_index);

  const toml::table& rt = section(file, root, "runtime", false);
  check_keys(file, rt, {"workers", "skeleton_resend_seconds", "max_streams", "idle", "idle_spin_us", "frame_queue_capacity"},
             "runtime");
  c.runtime.workers = static_cast<int>(read_range(file, rt, "workers", 2, 1, 64));
  c.runtime.skeleton_resend_seconds = read_positive(file, rt, "skeleton_resend_seconds", 1.0);
  c.runtime.max_streams = static_cast<int>(read_range(file, rt, "max_streams", 1024, 1, 1 << 20));
  // Frames queued per worker before a frame is dropped (queue_full); sized at start.
  c.runtime.frame_queue_capacity = static_cast<int>(read_range(file, rt, "frame_queue_capacity", 4096, 2, 1 << 20));
  const std::string idle = read<std::string>(file, rt, "idle", "park");
  if (idle != "park" && idle != "backoff") refuse(file, rt.get("idle")->source(), "idle must be \"park\" or \"backoff\"");
  c.runtime.idle_backoff = idle == "backoff";
  // Checked and accepted for the configs that set it; the runtime's I/O thread no longer spins
  // (its workers send their own results), so nothing reads it.
  read_range(file, rt, "idle_spin_us", 300, 0, 100000);
  // A SUB ingest reads one upstream (a stage, or a frames proxy that carries every source): by
  // default that one sender may define every stream.
  if (!ingest.get("max_streams_per_sender") && !c.runtime.ingest_pull)
    limits.max_streams_per_sender = static_cast<uint32_t>(limits.max_streams);
  // NATS: every message comes through the shard's one local socket, so one sender holds every
  // stream (who may publish a stream's subject is the NATS account's permissions' business).
  if (nats) limits.max_streams_per_sender = static_cast<uint32_t>(limits.max_streams);
  // Stale frames are judged by default on a PULL ingest only: behind a frames proxy (SUB) the
  // 3-shard test (tests/runtime/shard_check.py) saw 3,772 of its frames judged stale, not yet
  // understood (docs/deploy.md); set max_frame_age_ms to judge them there.
  if (!ingest.get("max_frame_age_ms") && !c.runtime.ingest_pull)
    limits.max_frame_age_ms = 0;

  // [security]: CURVE keys (docs/deploy.md). Without them only this host may be bound to.
  const toml::table& security = section(file, root, "security", false);
  check_keys(file, security, {"key", "clients", "insecure"}, "security");
  const std::string key_file = read<std::string>(file, security, "key", "");
  const std::string clients = read<std::string>(file, security, "clients", "");
  c.insecure = read<bool>(file, security, "insecure", false);
  // Key files and the client directory are checked with the C ABI's readers (kata/runtime.h: what
  // kata_runtime_create reads them with), so a bad one is refused here with the config's line.
  char public_key[KATA_KEY_TEXT_SIZE], secret_key[KATA_KEY_TEXT_SIZE];
  auto read_key_file = [&](const std::string& path) {
    return kata_key_file_read(nullptr, path.c_str(), public_key, secret_key);
  };
  auto check_key_directory = [](const std::string& path) {
    uint32_t count = 0;
    return kata_key_directory_check(nullptr, path.c_str(), &count);
  };
  auto load = [&](const toml::table& t, const char* name, auto&& check) {
    if (check(resolve(read<std::string>(file, t, name, ""))) != KATA_OK)
      refuse(file, t.get(name)->source(), std::string("'") + name + "': " + kata_context_last_error(nullptr));
  };
  if (!key_file.empty()) {
    load(security, "key", read_key_file);
    if (secret_key[0] == '\0')
      refuse(file, security.get("key")->source(), "'key' must be a .secret file (kata keygen), not a public key");
    // Read here so that a bad directory is refused with its line; the runtime reads it again.
    if (!clients.empty()) load(security, "clients", check_key_directory);
    c.runtime.key_file = resolve(key_file);
    if (!clients.empty()) c.runtime.client_keys_dir = resolve(clients);
    if (ingest.get("server_key")) {
      load(ingest, "server_key", read_key_file);
      c.runtime.ingest_server_key_file = resolve(read<std::string>(file, ingest, "server_key", ""));
    }
    if (publish.get("server_key")) {
      load(publish, "server_key", read_key_file);
      c.runtime.publish_server_key_file = resolve(read<std::string>(file, publish, "server_key", ""));
    }
  } else if (!clients.empty() || ingest.get("server_key") || publish.get("server_key")) {
    throw cli::Failure(file + ":1: [security] key is needed with clients or server_key");
  }
  // Beyond this host only with keys, or when the config says insecure = true.
  auto check_reach = [&](const std::vector<std::string>& endpoints, const char* where, bool bind_prefix) {
    for (const std::string& e : endpoints) {
      const bool binds = bind_prefix ? e.rfind("bind:", 0) == 0 : e.rfind("connect:", 0) != 0;
      const std::string endpoint = e.substr(e.find("tcp://") == std::string::npos ? 0 : e.find("tcp://"));
      if (!binds || kata_endpoint_reachable_beyond_host(endpoint.c_str()) == 0 || !key_file.empty()) continue;
      if (!c.insecure)
        throw cli::Failure(file + ":1: [" + where + "] " + e + " is reachable from other hosts without keys: "
                                           "add [security] key and clients (kata keygen; " + kata::cli::doc_file("deploy.md") + "), or "
                                           "insecure = true");
      c.warnings.push_back(std::string("[") + where + "] " + e +
                           " is bound without keys (insecure = true): anyone on the network can send frames and read results");
    }
  };
  check_reach(c.runtime.ingest_endpoints, "ingest", true);
  check_reach(c.runtime.publish_endpoints, "publish", false);

  const toml::table& scoring = section(file, root, "scoring", false);
  check_keys(file, scoring,
             {"model", "teacher", "first_frame", "ghost", "teachers", "teacher_start", "loop", "practice", "tolerance"},
             "scoring");
  if (!scoring.empty()) {
    const std::string model = read<std::string>(file, scoring, "model", "");
    if (model.empty()) throw cli::Failure(file + ":1: [scoring] needs model");
    c.model = resolve_at(*scoring.get("model"), model, "model");
    const std::string teacher = read<std::string>(file, scoring, "teacher", "");
    if (!teacher.empty()) c.default_teacher.path = resolve_at(*scoring.get("teacher"), teacher, "teacher");
    c.default_teacher.first_frame = static_cast<int>(read_range(file, scoring, "first_frame", 1, 0, 1 << 30));
    c.ghost = read<bool>(file, scoring, "ghost", true);
    c.tolerance = read_tolerance(file, scoring);
    if (const toml::node* t = scoring.get("teachers")) {
      if (!t->is_table()) refuse(file, t->source(), "[scoring.teachers] must be a table");
      for (const auto& [key, node] : *t->as_table()) {
        auto path = node.value<std::string>();
        if (!path) refuse(file, node.source(), "a teacher must be a clip path");
        char* end = nullptr;
        const std::string id_text(key.str());
        const unsigned long long id = std::strtoull(id_text.c_str(), &end, 10);
        if (id_text.empty() || *end) refuse(file, node.source(), "teacher keys are stream ids (decimal)");
        c.teachers[id] = TeacherSource{resolve_at(node, *path, "teacher"), c.default_teacher.first_frame};
      }
    }
    c.default_practice = read_practice(file, scoring);
    if (const toml::node* t = scoring.get("practice")) {
      if (!t->is_table()) refuse(file, t->source(), "[scoring.practice] must be a table");
      for (const auto& [key, node] : *t->as_table()) {
        const toml::table* one = node.as_table();
        if (!one) refuse(file, node.source(), "a practice is a table: { teacher_start = N } or { loop = [A, B] }");
        check_keys(file, *one, {"teacher_start", "loop"}, "scoring.practice");
        char* end = nullptr;
        const std::string id_text(key.str());
        const unsigned long long id = std::strtoull(id_text.c_str(), &end, 10);
        if (id_text.empty() || *end) refuse(file, node.source(), "practice keys are stream ids (decimal)");
        Practice p = read_practice(file, *one);
        if (p.where.empty()) p.where = file + ":" + std::to_string(node.source().begin.line);
        c.practices[id] = p;
      }
    }
  }
  if (const toml::node* plugins = root.get("plugins")) {
    const toml::array* a = plugins->as_array();
    if (!a) refuse(file, plugins->source(), "plugins must be an array of tables ([[plugins]])");
    for (const toml::node& e : *a) {
      const toml::table* t = e.as_table();
      if (!t) refuse(file, e.source(), "each [[plugins]] entry must be a table");
      check_keys(file, *t, {"path", "config"}, "plugins");
      const std::string path = read<std::string>(file, *t, "path", "");
      if (path.empty()) refuse(file, e.source(), "a plugin needs path");
      c.plugins.push_back({resolve_plugin(*t->get("path"), path), read<std::string>(file, *t, "config", "")});
    }
  }
  // [vmc]: streams sent as VMC performers (docs/vmc.md). Targets are checked here (HOST:PORT);
  // names are resolved at start.
  const toml::table& vmc = section(file, root, "vmc", false);
  check_keys(file, vmc, {"rate", "streams"}, "vmc");
  auto read_rate = [&](const toml::table& t, double fallback) {
    const toml::node* n = t.get("rate");
    if (!n) return fallback;
    const double v = read<double>(file, t, "rate", fallback);
    if (!(v >= 0.0 && v <= 1000.0))
      refuse(file, n->source(), "'rate' must be 0..1000 (bundles a second per performer; 0: every frame)");
    return v;
  };
  const double vmc_rate = read_rate(vmc, 0.0);
  if (const toml::node* t = vmc.get("streams")) {
    if (!t->is_table()) refuse(file, t->source(), "[vmc.streams] must be a table: \"ID\" = { ghost = \"HOST:PORT\" }");
    for (const auto& [key, node] : *t->as_table()) {
      const toml::table* one = node.as_table();
      if (!one)
        refuse(file, node.source(), "a [vmc.streams] entry is a table: { ghost = \"HOST:PORT\", student = \"HOST:PORT\" }");
      check_keys(file, *one, {"ghost", "student", "rate"}, "vmc.streams");
      char* end = nullptr;
      const std::string id_text(key.str());
      const unsigned long long id = std::strtoull(id_text.c_str(), &end, 10);
      if (id_text.empty() || *end) refuse(file, node.source(), "[vmc.streams] keys are stream ids (decimal)");
      VmcStream v;
      v.stream_id = id;
      v.where = file + ":" + std::to_string(node.source().begin.line);
      for (const char* performer : {"ghost", "student"}) {
        const std::string target = read<std::string>(file, *one, performer, "");
        std::string host, why;
        int port = 0;
        if (one->get(performer) && !coach::parse_vmc_target(target, &host, &port, &why))
          refuse(file, one->get(performer)->source(), std::string("'") + performer + "': " + why);
        (std::string(performer) == "ghost" ? v.ghost : v.student) = target;
      }
      if (v.ghost.empty() && v.student.empty())
        refuse(file, node.source(), "stream " + id_text + " in [vmc.streams] sends nothing: give ghost and / or student");
      v.rate = read_rate(*one, vmc_rate);
      c.vmc.push_back(v);
    }
  }
  const toml::table& status = section(file, root, "status", false);
  check_keys(file, status, {"interval_seconds"}, "status");
  c.status_seconds = read_positive(file, status, "interval_seconds", 1.0);
  return c;
}

namespace {

// toml++ 3.3 (Debian's) reaches __builtin_unreachable in its character classes for some code points
// (U+00A1..U+0499, U+2CEE..U+30E7, U+FB26..U+FEFE) and for malformed UTF-8: undefined behaviour,
// which fuzzing finds upstream too. So toml++ is given ASCII only: a code point in a basic string
// or a comment becomes its \u escape (the same value; a comment is ignored anyway); malformed UTF-8,
// and a code point anywhere else (a bare key, or a literal string, whose text has no escapes), is
// refused with its line. The states below are TOML's lexical ones; on a malformed file they may be
// wrong, which only changes which error is given: what toml++ reads is ASCII either way.
std::string ascii_toml(const std::string& text, const std::string& name) {
  enum class In { kCode, kComment, kBasic, kLiteral, kMultiBasic, kMultiLiteral } in = In::kCode;
  std::string out;
  out.reserve(text.size() + 16);
  std::size_t i = 0, line = 1;
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) i = 3;  // a byte order mark
  const auto starts = [&](const char* s) { return text.compare(i, std::char_traits<char>::length(s), s) == 0; };
  const auto refuse_here = [&](const char* what) { throw cli::Failure(name + ":" + std::to_string(line) + ": " + what); };
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x80) {
      // One UTF-8 sequence: its length from the lead byte, continuation bytes, no overlong form,
      // no surrogate, at most U+10FFFF.
      const std::size_t n = c >= 0xF0 && c <= 0xF4 ? 4 : c >= 0xE0 && c < 0xF0 ? 3 : c >= 0xC2 && c < 0xE0 ? 2 : 0;
      char32_t cp = n == 4 ? c & 0x07u : n == 3 ? c & 0x0Fu : c & 0x1Fu;
      bool ok = n != 0 && i + n <= text.size();
      for (std::size_t k = 1; ok && k < n; ++k) {
        const auto b = static_cast<unsigned char>(text[i + k]);
        ok = (b & 0xC0u) == 0x80u;
        cp = (cp << 6) | (b & 0x3Fu);
      }
      ok = ok && !(n == 3 && cp < 0x800) && !(n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) && !(cp >= 0xD800 && cp <= 0xDFFF);
      if (!ok) refuse_here("not UTF-8 text");
      if (in == In::kCode) refuse_here("a character outside ASCII outside a string (TOML's bare keys are ASCII)");
      if (in == In::kLiteral || in == In::kMultiLiteral)
        refuse_here("a character outside ASCII in a literal string ('...'): write it in a basic string (\"...\")");
      char escape[16];
      std::snprintf(escape, sizeof escape, cp > 0xFFFF ? "\\U%08X" : "\\u%04X", static_cast<unsigned>(cp));
      out += escape;
      i += n;
      continue;
    }
    std::size_t take = 1;
    switch (in) {
      case In::kCode:
        if (c == '#') in = In::kComment;
        else if (starts("\"\"\"")) in = In::kMultiBasic, take = 3;
        else if (starts("'''")) in = In::kMultiLiteral, take = 3;
        else if (c == '"') in = In::kBasic;
        else if (c == '\'') in = In::kLiteral;
        break;
      case In::kComment: if (c == '\n') in = In::kCode; break;
      case In::kBasic:
        if (c == '\\') take = i + 1 < text.size() && static_cast<unsigned char>(text[i + 1]) < 0x80 ? 2 : 1;
        else if (c == '"' || c == '\n') in = In::kCode;
        break;
      case In::kLiteral: if (c == '\'' || c == '\n') in = In::kCode; break;
      case In::kMultiBasic:
        if (c == '\\') take = i + 1 < text.size() && static_cast<unsigned char>(text[i + 1]) < 0x80 ? 2 : 1;
        else if (starts("\"\"\"")) in = In::kCode, take = 3;
        break;
      case In::kMultiLiteral: if (starts("'''")) in = In::kCode, take = 3; break;
    }
    for (std::size_t k = 0; k < take; ++k) line += text[i + k] == '\n';
    out.append(text, i, take);
    i += take;
  }
  return out;
}

}  // namespace

ServeConfig parse_config_text(const std::string& text, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(ascii_toml(text, name), name);
  } catch (const toml::parse_error& e) {
    throw cli::Failure(name + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  return parse_root(name, root);
}

ServeConfig parse_config(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw cli::Failure(file + ": cannot open the config");
  std::stringstream text;
  text << in.rdbuf();
  return parse_config_text(text.str(), file);
}

}  // namespace kata::serve
