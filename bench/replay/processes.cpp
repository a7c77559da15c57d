// kata-replay: the child processes it spawns (the subscriber, the sender, kata serve and proxy) and
// the run's CURVE keys, which they inherit through the environment.
#include "replay.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "common/error.hpp"

extern char** environ;

namespace kata::replay {

// --curve: the run's keys, made once per run and handed to the sender and subscriber processes in
// the environment (they inherit it): the server's pair (the runtime's ingest and publisher, the bare
// publisher) and one client pair (the sender, the subscribers), the client on the allow-list.
constexpr const char* kCurveServerEnv = "KATA_REPLAY_CURVE_SERVER";  // the server's public key
constexpr const char* kCurvePublicEnv = "KATA_REPLAY_CURVE_PUBLIC";  // the client's pair
constexpr const char* kCurveSecretEnv = "KATA_REPLAY_CURVE_SECRET";
const CurveKeys& curve_keys() {
  static const CurveKeys keys = [] {
    CurveKeys k{kata::transport::generate_key_pair(), kata::transport::generate_key_pair()};
    setenv(kCurveServerEnv, k.server.public_key.c_str(), 1);
    setenv(kCurvePublicEnv, k.client.public_key.c_str(), 1);
    setenv(kCurveSecretEnv, k.client.secret_key.c_str(), 1);
    return k;
  }();
  return keys;
}
kata::transport::CurveOptions curve_server() {
  kata::transport::CurveOptions c;
  c.own = curve_keys().server;
  c.allowed_clients = {curve_keys().client.public_key};
  return c;
}
// A sender's or subscriber's socket, before it connects: a CURVE client when the parent set keys.
void curve_client(void* socket) {
  const char* server = std::getenv(kCurveServerEnv);
  if (!server) return;
  kata::transport::CurveOptions c;
  c.remote_server = server;
  c.own.public_key = std::getenv(kCurvePublicEnv) ? std::getenv(kCurvePublicEnv) : "";
  c.own.secret_key = std::getenv(kCurveSecretEnv) ? std::getenv(kCurveSecretEnv) : "";
  kata::transport::apply_curve(socket, c);
}


Child spawn_subscriber(const std::string& endpoint, const std::string& mode, double deadline, int64_t expect_results,
                       double window, int expect_definitions, bool capture_is_send,
                       double inject_growth_us_per_s, int nats_shards) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw Error(ErrorKind::kIo, "replay: pipe failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], 1);
  posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
  const std::string deadline_text = std::to_string(deadline);
  std::vector<std::string> args = {"kata", "replay", "--subscriber", endpoint, "--mode", mode, "--deadline", deadline_text,
                                   "--window", std::to_string(window), "--expect-definitions",
                                   std::to_string(expect_definitions), "--expect-results", std::to_string(expect_results),
                                   "--inject-growth-us-per-s", std::to_string(inject_growth_us_per_s)};
  if (capture_is_send) args.push_back("--capture-is-send");
  // NATS: a stream counts as announced once its definition came from the shard of these that keeps it.
  if (nats_shards > 0) args.insert(args.end(), {"--shards", std::to_string(nats_shards)});
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  Child c;
  if (posix_spawn(&c.pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ) != 0)
    throw Error(ErrorKind::kIo, "replay: cannot start the subscriber process");
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  c.out = fdopen(pipe_fds[0], "r");
  return c;
}

std::string read_line(FILE* f) {
  std::string line;
  for (int ch; (ch = std::fgetc(f)) != EOF && ch != '\n';) line.push_back(static_cast<char>(ch));
  return line;
}

json finish_child(Child& c) {
  const std::string line = read_line(c.out);
  std::fclose(c.out);
  int status = 0;
  waitpid(c.pid, &status, 0);
  if (line.empty()) throw Error(ErrorKind::kIo, "replay: the subscriber process reported nothing");
  return json::parse(line);
}

std::string endpoint_for(const Options& o, const char* tag) {
  if (o.transport == "ipc")
    return "ipc:///tmp/kata_replay_" + std::to_string(getpid()) + "_" + tag;
  return "tcp://127.0.0.1:*";
}

SenderChild spawn_sender(const Options& o, const std::string& endpoint, int streams) {
  int to_child[2], from_child[2];
  if (pipe(to_child) != 0 || pipe(from_child) != 0) throw Error(ErrorKind::kIo, "replay: pipe failed");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, to_child[0], 0);
  posix_spawn_file_actions_adddup2(&actions, from_child[1], 1);
  posix_spawn_file_actions_addclose(&actions, to_child[1]);
  posix_spawn_file_actions_addclose(&actions, from_child[0]);
  std::vector<std::string> args = {"kata", "replay", "--sender", endpoint, "--streams", std::to_string(streams),
                                   "--seconds", std::to_string(o.seconds), "--rate", std::to_string(o.rate),
                                   "--data", o.data_dir};
  if (o.batch) args.push_back("--batch");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  SenderChild c;
  if (posix_spawn(&c.pid, "/proc/self/exe", &actions, nullptr, argv.data(), environ) != 0)
    throw Error(ErrorKind::kIo, "replay: cannot start the sender process");
  posix_spawn_file_actions_destroy(&actions);
  close(to_child[0]);
  close(from_child[1]);
  c.in = fdopen(to_child[1], "w");
  c.out = fdopen(from_child[0], "r");
  return c;
}


pid_t spawn_logged(const std::vector<std::string>& args, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<std::string> copy = args;
  std::vector<char*> argv;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  // kata proxy / kata serve: the CLI beside this tool (build/bin/kata).
  const std::string kata = (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "kata").string();
  if (posix_spawn(&pid, kata.c_str(), &actions, nullptr, argv.data(), environ) != 0)
    throw Error(ErrorKind::kIo, "replay: cannot start " + kata + " " + args[1]);
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

std::string absolute(const std::string& p) { return std::filesystem::absolute(p).string(); }

}  // namespace kata::replay
