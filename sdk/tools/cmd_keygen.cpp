// kata keygen --out BASE: a CURVE key pair for ZeroMQ (docs/deploy.md): BASE.pub (the public key,
// to give to the other side: a server's client key directory, or a client's server key) and
// BASE.secret (the pair, mode 0600, for this side's config or --key). Refuses to overwrite.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "command.hpp"
#include "common/error.hpp"
#include "transport/curve.hpp"

namespace {

void run_keygen(const std::string& base, bool force) {
  for (const char* ext : {".pub", ".secret"})
    if (!force && std::filesystem::exists(base + ext))
      throw kata::Error(kata::ErrorKind::kInvalidArgument, base + ext + ": exists (--force replaces it)");
  if (const auto dir = std::filesystem::path(base).parent_path(); !dir.empty())
    std::filesystem::create_directories(dir);
  const kata::transport::KeyPair keys = kata::transport::generate_key_pair();
  kata::transport::write_key_files(base, keys);
  // The round trip: what was written reads back as the same pair.
  const kata::transport::KeyPair back = kata::transport::read_key_file(base + ".secret");
  if (back.public_key != keys.public_key || back.secret_key != keys.secret_key)
    throw kata::Error(kata::ErrorKind::kIo, base + ".secret: does not read back");
  std::printf("%s.pub\n%s.secret\npublic key %s\n", base.c_str(), base.c_str(), keys.public_key.c_str());
}

void setup(CLI::App& app) {
  auto base = std::make_shared<std::string>();
  auto force = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("keygen", "make a CURVE key pair (BASE.pub, BASE.secret) for kata serve, send, proxy");
  cmd->add_option("--out", *base, "BASE path of the two files (keys/stage writes keys/stage.pub and keys/stage.secret)")
      ->required();
  cmd->add_flag("--force", *force, "replace existing files");
  cmd->callback([base, force] { run_keygen(*base, *force); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
