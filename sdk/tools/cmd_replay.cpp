// kata replay: forwards to kata-replay, the live path's measurement tool (bench/replay/, kept
// out of the CLI's binary), built and installed beside this binary; a kata without it
// (a partial copy of bin/) says so instead of measuring.
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"

namespace {

void setup(CLI::App& app) {
  auto* cmd = app.add_subcommand("replay", "measure the live runtime against bare ZeroMQ (runs kata-replay, built in bench/)");
  cmd->prefix_command();  // every argument goes to kata-replay as it is
  cmd->set_help_flag();   // --help too: kata-replay's help lists its options (this one had only -h)
  cmd->callback([cmd] {
    const std::filesystem::path tool =
        std::filesystem::read_symlink("/proc/self/exe").parent_path() / "kata-replay";
    std::vector<std::string> rest = cmd->remaining();
    std::vector<char*> argv;
    std::string name = tool.string();
    argv.push_back(name.data());
    for (auto& a : rest) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(name.c_str(), argv.data());
    throw kata::Error(kata::ErrorKind::kNotFound,
                      "replay: cannot run " + name + " (" + std::strerror(errno) +
                          "): kata replay is the separate tool kata-replay (bench/replay), "
                          "built and installed beside kata");
  });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
