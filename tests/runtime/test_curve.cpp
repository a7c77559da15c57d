// CURVE on the runtime's sockets: a server key pair, an allow-list read from a key
// directory; a sender with a known key gets its stream in and a subscriber with a known key reads
// its results; an unknown key gets nothing in and nothing out; a subscriber without a key reads
// nothing; keys round-trip through their files. Loopback TCP, every wait bounded.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <zmq.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "runtime/runtime.hpp"
#include "support/live_clip.hpp"
#include "support/temp_paths.hpp"
#include "transport/curve.hpp"
#include "transport/wire.hpp"

namespace kata::runtime {
namespace {

using Clock = std::chrono::steady_clock;
using transport::KeyPair;

struct Keys {
  test::TempDir dir;
  KeyPair server = transport::generate_key_pair();
  KeyPair client = transport::generate_key_pair();
  KeyPair stranger = transport::generate_key_pair();
  std::string clients_dir = (dir.path() / "clients").string();
  Keys() {
    std::filesystem::create_directories(clients_dir);
    transport::write_key_files((dir.path() / "server").string(), server);
    transport::write_key_files(clients_dir + "/client", client);
    transport::write_key_files((dir.path() / "stranger").string(), stranger);  // not in the directory
    std::ofstream(clients_dir + "/README") << "not a key: ignored\n";
  }
};

void curve_client(void* socket, const KeyPair& own, const std::string& server_public) {
  transport::CurveOptions c;
  c.own = own;
  c.remote_server = server_public;
  transport::apply_curve(socket, c);
}

void* socket_of(void* context, int type) {
  void* s = zmq_socket(context, type);
  int linger = 0;
  zmq_setsockopt(s, ZMQ_LINGER, &linger, sizeof linger);
  return s;
}

// Results of `id` read from a SUB socket within the time.
int count_results(void* sub, uint64_t id, int want, int milliseconds) {
  transport::Decoder decoder;
  std::vector<uint8_t> buffer(1 << 20);
  int results = 0;
  const auto end = Clock::now() + std::chrono::milliseconds(milliseconds);
  while (results < want && Clock::now() < end) {
    zmq_pollitem_t item{sub, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&item, 1, 50) <= 0) continue;
    const int n = zmq_recv(sub, buffer.data(), buffer.size(), 0);
    if (n > 0 && decoder.decode(buffer.data(), static_cast<size_t>(n)) == transport::MessageKind::kResult &&
        decoder.result().stream_id == id)
      ++results;
  }
  return results;
}

// Waits until `sub` receives any message (the runtime publishes the skeleton definitions when a
// subscriber joins, and definitions and stats every second): then its CURVE handshake is done and
// its subscription reached the publisher. A fixed sleep is not enough on a loaded machine (a
// 500 ms one lost the first 9 results at load 12).
bool joined(void* sub, int milliseconds) {
  std::vector<uint8_t> buffer(1 << 20);
  const auto end = Clock::now() + std::chrono::milliseconds(milliseconds);
  while (Clock::now() < end) {
    zmq_pollitem_t item{sub, 0, ZMQ_POLLIN, 0};
    if (zmq_poll(&item, 1, 50) > 0 && zmq_recv(sub, buffer.data(), buffer.size(), 0) > 0) return true;
  }
  return false;
}

TEST(runtime_curve, KeysRoundTripThroughTheirFiles) {
  Keys keys;
  const KeyPair back = transport::read_key_file((keys.dir.path() / "server.secret").string());
  EXPECT_EQ(back.public_key, keys.server.public_key);
  EXPECT_EQ(back.secret_key, keys.server.secret_key);
  const KeyPair pub = transport::read_key_file((keys.dir.path() / "server.pub").string());
  EXPECT_EQ(pub.public_key, keys.server.public_key);
  EXPECT_TRUE(pub.secret_key.empty());
  struct stat st {};
  ASSERT_EQ(stat((keys.dir.path() / "server.secret").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u) << "the secret is private";
  EXPECT_EQ(transport::read_key_directory(keys.clients_dir), std::vector<std::string>{keys.client.public_key});
  // A damaged key names its file and line.
  const std::string bad = (keys.dir.path() / "bad.pub").string();
  std::ofstream(bad) << "# comment\npublic = \"not a key\"\n";
  try {
    transport::read_key_file(bad);
    FAIL() << "a bad key was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad + ":2:"), std::string::npos) << e.what();
  }
  // A secret that does not belong to its public key is refused.
  const std::string mixed = (keys.dir.path() / "mixed.secret").string();
  std::ofstream(mixed) << "public = \"" << keys.client.public_key << "\"\nsecret = \"" << keys.server.secret_key << "\"\n";
  EXPECT_THROW(transport::read_key_file(mixed), Error);
}

TEST(runtime_curve, OnlyKnownKeysGetInAndOut) {
  Keys keys;
  const test::LiveClip clip("07_01", 0);
  RuntimeConfig config;
  config.workers = 2;
  config.publish.endpoints = {"tcp://127.0.0.1:*"};
  config.ingest.kind = transport::IngestKind::kPull;
  config.ingest.endpoints = {"bind:tcp://127.0.0.1:*"};
  const std::vector<std::string> allowed = transport::read_key_directory(keys.clients_dir);
  for (auto* curve : {&config.ingest.security.curve, &config.publish.security.curve}) {
    curve->own = transport::read_key_file((keys.dir.path() / "server.secret").string());
    curve->allowed_clients = allowed;
  }
  Runtime runtime(config);
  void* context = zmq_ctx_new();
  {
    void* known_sub = socket_of(context, ZMQ_SUB);
    void* plain_sub = socket_of(context, ZMQ_SUB);
    void* stranger_sub = socket_of(context, ZMQ_SUB);
    curve_client(known_sub, keys.client, keys.server.public_key);
    curve_client(stranger_sub, keys.stranger, keys.server.public_key);
    for (void* s : {known_sub, plain_sub, stranger_sub}) {
      zmq_setsockopt(s, ZMQ_SUBSCRIBE, "", 0);
      zmq_connect(s, runtime.publish_endpoint().c_str());
    }
    void* known = socket_of(context, ZMQ_PUSH);
    void* stranger = socket_of(context, ZMQ_PUSH);
    void* plain = socket_of(context, ZMQ_PUSH);
    curve_client(known, keys.client, keys.server.public_key);
    curve_client(stranger, keys.stranger, keys.server.public_key);
    for (void* s : {known, stranger, plain}) zmq_connect(s, runtime.ingest_endpoint().c_str());
    transport::Encoder encoder;
    auto send = [&](void* s, transport::Bytes m) { zmq_send(s, m.data, m.size, ZMQ_DONTWAIT); };
    // The stranger and the keyless sender try first, with streams of their own.
    send(stranger, encoder.skeleton(clip.definition(8)));
    send(plain, encoder.skeleton(clip.definition(9)));
    send(known, encoder.skeleton(clip.definition(7)));
    ASSERT_TRUE(joined(known_sub, 20000)) << "the known subscriber never got a message";
    const int frames = 60;
    for (int i = 0; i < frames; ++i) {
      for (auto [s, id] : {std::pair{known, 7}, std::pair{stranger, 8}, std::pair{plain, 9}})
        send(s, encoder.frame(static_cast<uint64_t>(id), static_cast<uint64_t>(i), i * 8'333'333LL,
                              clip.frame(1 + i),
                              clip.joints()));
      std::this_thread::sleep_for(std::chrono::milliseconds(8));
    }
    EXPECT_EQ(count_results(known_sub, 7, frames, 10000), frames) << "a known key reads every result";
    EXPECT_EQ(count_results(plain_sub, 7, 1, 300), 0) << "a subscriber without a key reads nothing";
    EXPECT_EQ(count_results(stranger_sub, 7, 1, 300), 0) << "an unknown key reads nothing";
    const RuntimeCounters c = runtime.counters();
    EXPECT_EQ(c.streams, 1u) << "only the known sender's stream exists";
    EXPECT_EQ(c.ingest.received, static_cast<uint64_t>(frames + 1)) << "nothing of the others came in";
    for (void* s : {known_sub, plain_sub, stranger_sub, known, stranger, plain}) zmq_close(s);
  }
  zmq_ctx_term(context);
}

}  // namespace
}  // namespace kata::runtime
