// CURVE key files and endpoints in the C ABI (kata_key_file_read, kata_key_directory_check,
// kata_endpoint_reachable_beyond_host; kata/runtime.h): files written here in the documented
// format from key pairs libzmq makes (not kata's own writer), read back; broken ones refused with
// the reason naming file and line.
#include <gtest/gtest.h>
#include <zmq.h>

#include <cstdint>
#include <string>

#include "kata/kata.h"
#include "support/temp_paths.hpp"

namespace {

using kata::test::TempDir;

struct Pair {
  char public_key[41];
  char secret_key[41];
};

Pair make_pair() {
  Pair p{};
  EXPECT_EQ(zmq_curve_keypair(p.public_key, p.secret_key), 0) << "libzmq without CURVE";
  return p;
}

TEST(keys_capi, ASecretFileReadsBackBothKeys) {
  TempDir dir;
  const Pair p = make_pair();
  const std::string path = dir.write("stage.secret", std::string("# a comment\n\npublic = \"") + p.public_key +
                                                         "\"\n  secret = \"" + p.secret_key + "\"\n");
  char public_key[KATA_KEY_TEXT_SIZE], secret_key[KATA_KEY_TEXT_SIZE];
  ASSERT_EQ(kata_key_file_read(nullptr, path.c_str(), public_key, secret_key), KATA_OK);
  EXPECT_STREQ(public_key, p.public_key);
  EXPECT_STREQ(secret_key, p.secret_key);
}

TEST(keys_capi, APublicFileHasNoSecretAndTheSecretMayBeLeftOut) {
  TempDir dir;
  const Pair p = make_pair();
  const std::string path = dir.write("sender.pub", std::string("public = \"") + p.public_key + "\"\n");
  char public_key[KATA_KEY_TEXT_SIZE], secret_key[KATA_KEY_TEXT_SIZE] = "x";
  ASSERT_EQ(kata_key_file_read(nullptr, path.c_str(), public_key, secret_key), KATA_OK);
  EXPECT_STREQ(public_key, p.public_key);
  EXPECT_STREQ(secret_key, "");
  char again[KATA_KEY_TEXT_SIZE];
  ASSERT_EQ(kata_key_file_read(nullptr, path.c_str(), again, nullptr), KATA_OK);
  EXPECT_STREQ(again, p.public_key);
}

TEST(keys_capi, BrokenFilesAreRefusedWithFileLineAndReason) {
  TempDir dir;
  kata_context context = nullptr;
  ASSERT_EQ(kata_context_create(&context), KATA_OK);
  const Pair p = make_pair(), other = make_pair();
  char public_key[KATA_KEY_TEXT_SIZE] = "x", secret_key[KATA_KEY_TEXT_SIZE] = "x";
  const std::string short_key = std::string(p.public_key).substr(0, 39);
  const std::string a = dir.write("short.pub", std::string("# kata\npublic = \"") + short_key + "\"\n");
  EXPECT_EQ(kata_key_file_read(context, a.c_str(), public_key, secret_key), KATA_E_PARSE);
  EXPECT_EQ(std::string(kata_context_last_error(context)), a + ":2: 'public' is not a CURVE key (40 Z85 characters)");
  EXPECT_STREQ(public_key, "");  // nothing of a refused file is handed out
  EXPECT_STREQ(secret_key, "");
  // A secret key that is not the public key's: someone else's secret beside this public key.
  const std::string b = dir.write("mixed.secret", std::string("public = \"") + p.public_key + "\"\nsecret = \"" +
                                                      other.secret_key + "\"\n");
  EXPECT_EQ(kata_key_file_read(context, b.c_str(), public_key, secret_key), KATA_E_PARSE);
  EXPECT_EQ(std::string(kata_context_last_error(context)), b + ":1: the secret key does not match the public key");
  const std::string c = dir.write("typo.pub", std::string("\npublik = \"") + p.public_key + "\"\n");
  EXPECT_EQ(kata_key_file_read(context, c.c_str(), public_key, nullptr), KATA_E_PARSE);
  EXPECT_EQ(std::string(kata_context_last_error(context)), c + ":2: unknown key 'publik'");
  const std::string d = dir.write("empty.pub", "# nothing\n");
  EXPECT_EQ(kata_key_file_read(context, d.c_str(), public_key, nullptr), KATA_E_PARSE);
  EXPECT_EQ(std::string(kata_context_last_error(context)), d + ":1: no public key");
  const std::string missing = dir.file("missing.pub");
  EXPECT_EQ(kata_key_file_read(context, missing.c_str(), public_key, nullptr), KATA_E_IO);
  EXPECT_EQ(std::string(kata_context_last_error(context)), missing + ": cannot open the key file");
  EXPECT_EQ(kata_key_file_read(context, nullptr, public_key, nullptr), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_key_file_read(context, d.c_str(), nullptr, nullptr), KATA_E_NULL_POINTER);
  kata_context_destroy(context);
}

TEST(keys_capi, ADirectoryCountsItsPublicKeysAndNamesABadOne) {
  TempDir dir;
  const Pair p = make_pair(), q = make_pair();
  dir.write("a.pub", std::string("public = \"") + p.public_key + "\"\n");
  dir.write("b.pub", std::string("public = \"") + q.public_key + "\"\n");
  dir.write("notes.txt", "not a key: ignored\n");
  uint32_t count = 99;
  ASSERT_EQ(kata_key_directory_check(nullptr, dir.path().c_str(), &count), KATA_OK);
  EXPECT_EQ(count, 2u);
  const std::string bad = dir.write("c.pub", "public = \"not a key\"\n");
  EXPECT_EQ(kata_key_directory_check(nullptr, dir.path().c_str(), &count), KATA_E_PARSE);
  EXPECT_EQ(count, 0u);
  EXPECT_EQ(std::string(kata_context_last_error(nullptr)), bad + ":1: 'public' is not a CURVE key (40 Z85 characters)");
  const std::string missing = dir.file("nowhere");
  EXPECT_EQ(kata_key_directory_check(nullptr, missing.c_str(), &count), KATA_E_IO);
  EXPECT_EQ(std::string(kata_context_last_error(nullptr)), missing + ": not a key directory");
  EXPECT_EQ(kata_key_directory_check(nullptr, missing.c_str(), nullptr), KATA_E_NULL_POINTER);
}

TEST(keys_capi, OnlyTcpOffThisHostIsReachableBeyondIt) {
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://*:5555"), 1);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://0.0.0.0:5555"), 1);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://10.1.2.3:5555"), 1);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://eth0:5555"), 1);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://127.0.0.1:5555"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://127.4.5.6:5555"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://localhost:5555"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://[::1]:5555"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://lo:5555"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://10.0.0.1;127.0.0.1:5555"), 0);  // judged by the host after ';'
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("tcp://127.0.0.1;10.0.0.1:5555"), 1);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("ipc:///tmp/kata.sock"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host("inproc://kata"), 0);
  EXPECT_EQ(kata_endpoint_reachable_beyond_host(nullptr), 0);
}

}  // namespace
