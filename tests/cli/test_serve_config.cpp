// The `kata serve` config's integer reader (sdk/tools/serve_config_read.hpp): a value the file
// holds is judged against its range and refused with file, line and key; a missing key gives the
// program's default without judging it (it used to read the missing key's node for a line: a null
// dereference whenever a default lay outside the range it was checked against).
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <string_view>

#include "data_files.hpp"
#include "failure.hpp"
#include "serve_config.hpp"
#include "serve_config_read.hpp"

namespace kata::serve {
namespace {

std::string refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const cli::Failure& e) {  // kata serve's config refusals: the CLI's own error type
    return e.what();
  }
  return "";
}

TEST(serve_config, AMissingKeyGivesItsDefaultWithoutALine) {
  const toml::table table = toml::parse(std::string_view("other = 5\n"), std::string_view("stage.toml"));
  // A default outside the range (a default derived from another setting can be): returned as it is.
  EXPECT_EQ(detail::read_range("stage.toml", table, "workers", 0, 1, 64), 0);
  EXPECT_EQ(detail::read_range("stage.toml", table, "workers", 2, 1, 64), 2);
}

TEST(serve_config, AValueOutOfRangeIsRefusedWithItsFileLineAndKey) {
  const toml::table table = toml::parse(std::string_view("other = 5\nworkers = 99\nname = \"x\"\n"), std::string_view("stage.toml"));
  EXPECT_EQ(refusal([&] { detail::read_range("stage.toml", table, "workers", 2, 1, 64); }),
            "stage.toml:2: 'workers' must be 1..64");
  EXPECT_EQ(refusal([&] { detail::read_range("stage.toml", table, "name", 2, 1, 64); }),
            "stage.toml:3: 'name' must be an integer");
  EXPECT_EQ(detail::read_range("stage.toml", table, "other", 2, 1, 64), 5);
}

TEST(serve_config, AWholeConfigNamesTheLineOfABadValue) {
  const std::string config =
      "[ingest]\nendpoints = [\"bind:tcp://127.0.0.1:5555\"]\nkind = \"pull\"\n"
      "[publish]\nendpoints = [\"tcp://127.0.0.1:5556\"]\n"
      "[runtime]\nworkers = 0\n";
  EXPECT_EQ(refusal([&] { parse_config_text(config, "stage.toml"); }), "stage.toml:7: 'workers' must be 1..64");
  // Without the key, every default holds (none of them is judged against a line it does not have).
  const ServeConfig c = parse_config_text(config.substr(0, config.find("[runtime]")), "stage.toml");
  EXPECT_EQ(c.runtime.workers, 2);
  EXPECT_EQ(c.runtime.max_streams_per_sender, 64u);
}

// [transport] kind = "nats" (docs/deploy.md, "NATS"): the servers and lease settings are read,
// [ingest] keeps only its limits, and what belongs to ZeroMQ is refused with its line.
TEST(serve_config, ANatsTransportReplacesTheZeroMqSockets) {
  const std::string config =
      "[transport]\nkind = \"nats\"\nservers = [\"nats://10.0.0.1:4222\", \"nats://10.0.0.2:4222\"]\n"
      "shard = \"shard-a\"\nlease_ttl_ms = 5000\n[ingest]\nmax_message_bytes = 65536\n[runtime]\nmax_streams = 300\n";
  const ServeConfig c = parse_config_text(config, "shard.toml");
  EXPECT_TRUE(c.nats.enabled);
  EXPECT_EQ(c.nats.servers.size(), 2u);
  EXPECT_EQ(c.nats.shard, "shard-a");
  EXPECT_EQ(c.nats.lease_ttl_ms, 5000);
  EXPECT_EQ(c.nats.partitions, 64u);
  EXPECT_EQ(c.runtime.max_message_bytes, 65536u);
  EXPECT_EQ(c.runtime.max_streams_per_sender, 300u);  // one local sender carries every stream
  EXPECT_TRUE(c.runtime.publish_endpoints.empty());
  EXPECT_EQ(refusal([&] { parse_config_text(config + "[publish]\nendpoints = [\"tcp://127.0.0.1:5556\"]\n", "shard.toml"); }),
            "shard.toml:10: [publish] is for ZeroMQ: with [transport] kind = \"nats\" results go out on NATS and shards "
            "share the partitions by lease (" + kata::cli::doc_file("deploy.md") + ")");
  EXPECT_EQ(refusal([&] { parse_config_text("[transport]\nkind = \"nats\"\n", "shard.toml"); }),
            "shard.toml:1: [transport] kind = \"nats\" needs servers = [\"nats://host:4222\", ...]");
  EXPECT_EQ(refusal([&] { parse_config_text("[transport]\nkind = \"nats\"\nservers = [\"nats://a:1\"]\nshard = \"a.b\"\n", "s.toml"); }),
            "s.toml:4: shard must be 1..64 of [A-Za-z0-9_-] (a NATS subject token)");
  EXPECT_EQ(refusal([&] { parse_config_text("[transport]\nkind = \"mqtt\"\n", "s.toml"); }),
            "s.toml:2: kind must be \"zmq\" or \"nats\"");
  // The server list as the docs write it: one comma-separated string, or such lists in the array.
  const std::vector<std::string> three{"nats://a:1", "nats://b:2", "nats://c:3"};
  EXPECT_EQ(parse_config_text("[transport]\nkind = \"nats\"\nservers = \"nats://a:1, nats://b:2,nats://c:3\"\n", "s.toml").nats.servers,
            three);
  EXPECT_EQ(parse_config_text("[transport]\nkind = \"nats\"\nservers = [\"nats://a:1,nats://b:2\", \"nats://c:3\"]\n", "s.toml").nats.servers,
            three);
  EXPECT_EQ(refusal([&] { parse_config_text("[transport]\nkind = \"nats\"\nservers = [\" , \"]\n", "s.toml"); }),
            "s.toml:3: servers must be NATS URLs (nats://host:port, tls://host:port)");
  // kind = "zmq" takes no NATS key.
  EXPECT_NE(refusal([&] { parse_config_text("[transport]\nservers = [\"nats://a:1\"]\n", "s.toml"); }).find(
                "'servers' is for kind = \"nats\""),
            std::string::npos);
}

// [scoring] tolerance (kata_teacher_desc.tolerance): a level's name or the degrees at which a part
// scores 50 (a TOML number, 5..120), kept as the text the streams' attach reads; anything else is
// refused with its line and key; absent, the default ("": normal).
TEST(serve_config, AToleranceIsALevelOrDegreesAndAnythingElseIsRefusedWithItsLine) {
  const std::string head =
      "[ingest]\nendpoints = [\"bind:tcp://127.0.0.1:5555\"]\n[publish]\nendpoints = [\"tcp://127.0.0.1:5556\"]\n"
      "[scoring]\nmodel = \"" KATA_SOURCE_DIR "/models/default.kata\"\n";
  EXPECT_EQ(parse_config_text(head, "stage.toml").tolerance, "");
  EXPECT_EQ(parse_config_text(head + "tolerance = \"lenient\"\n", "stage.toml").tolerance, "lenient");
  EXPECT_EQ(parse_config_text(head + "tolerance = \"strict\"\n", "stage.toml").tolerance, "strict");
  EXPECT_EQ(parse_config_text(head + "tolerance = 35\n", "stage.toml").tolerance, "35");
  EXPECT_EQ(parse_config_text(head + "tolerance = 37.5\n", "stage.toml").tolerance, "37.5");
  for (const char* bad : {"tolerance = \"loose\"\n", "tolerance = \"35\"\n", "tolerance = true\n"})
    EXPECT_EQ(refusal([&] { parse_config_text(head + bad, "stage.toml"); }),
              "stage.toml:7: 'tolerance' must be \"strict\", \"normal\", \"lenient\" or the angle in degrees (5..120) at "
              "which a part scores 50")
        << bad;
  for (const char* bad : {"tolerance = 4\n", "tolerance = 121.5\n", "tolerance = nan\n"})
    EXPECT_EQ(refusal([&] { parse_config_text(head + bad, "stage.toml"); }),
              "stage.toml:7: 'tolerance' in degrees must be within 5..120 (the angle at which a part scores 50)")
        << bad;
}

// Text outside ASCII: toml++ reaches undefined behaviour on some code points and on malformed
// UTF-8, so the config reader gives it ASCII (serve_config.cpp, ascii_toml): a basic string keeps
// its value, a comment is free, and what cannot be kept is refused with its line.
TEST(serve_config, TextOutsideAsciiKeepsItsValueOrIsRefusedWithItsLine) {
  const std::string config =
      "[security]\ninsecure = true\n# caf\u00e9 \u2ff0 \uff01 \U0001F600 (a comment)\n[ingest]\nendpoints = [\"bind:tcp://127.0.0.1:5555\"]\n"
      "[publish]\nendpoints = [\"tcp://h\u00f4te-\u30e6\u0400:5556\", \"tcp://a\\\\\u00e9\\\"b:1\"]\n";
  const ServeConfig c = parse_config_text("\xEF\xBB\xBF" + config, "stage.toml");
  ASSERT_EQ(c.runtime.publish_endpoints.size(), 2u);
  EXPECT_EQ(c.runtime.publish_endpoints[0], "tcp://h\u00f4te-\u30e6\u0400:5556");
  EXPECT_EQ(c.runtime.publish_endpoints[1], "tcp://a\\\u00e9\"b:1");
  EXPECT_EQ(refusal([&] { parse_config_text(config + "[status]\ninterval_seconds = 1\n'\u00e9' = 2\n", "stage.toml"); }),
            "stage.toml:10: a character outside ASCII in a literal string ('...'): write it in a basic string (\"...\")");
  EXPECT_EQ(refusal([&] { parse_config_text(config + "\n\u00e9 = 2\n", "stage.toml"); }),
            "stage.toml:9: a character outside ASCII outside a string (TOML's bare keys are ASCII)");
  // Malformed UTF-8: a lone continuation byte, a cut sequence, an overlong '/', a surrogate; and
  // the inputs that reached toml++'s unreachable code (a fuzzer's, and upstream's).
  for (const std::string bad : {"\x80", "\xC3", "\xC0\xAF", "\xED\xA0\x80", "\xF5\x80\x80\x80"})
    EXPECT_EQ(refusal([&] { parse_config_text(config + "x = \"" + bad + "\"\n", "stage.toml"); }), "stage.toml:8: not UTF-8 text");
  EXPECT_EQ(refusal([&] { parse_config_text(std::string("\xEF\xBB\x94\x40\x01\x22", 6), "fuzz.toml"); }),
            "fuzz.toml:1: a character outside ASCII outside a string (TOML's bare keys are ASCII)");
  EXPECT_EQ(refusal([&] { parse_config_text("\xCC\xAA", "fuzz.toml"); }),
            "fuzz.toml:1: a character outside ASCII outside a string (TOML's bare keys are ASCII)");
}

}  // namespace
}  // namespace kata::serve
