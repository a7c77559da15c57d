// kata-replay: the live path's measurement tool (docs/runtime.md, "kata replay"), moved out of the
// CLI's binary: `kata replay ARGS` runs `kata-replay ARGS` from beside it. The tool is
// replay.cpp's one subcommand; "replay" is put first when the caller left it out, so both
// `kata-replay --streams 64` and the children it spawns (`kata-replay replay --subscriber ...`) parse.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/error.hpp"

namespace kata::cli {
std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> commands;
  return commands;
}
}  // namespace kata::cli

int main(int argc, char** argv) {
  CLI::App app{"kata-replay: the live runtime against bare ZeroMQ, side by side"};
  app.require_subcommand(1);
  for (auto setup : kata::cli::command_registry()) setup(app);
  std::vector<char*> args(argv, argv + argc);
  static char replay[] = "replay";
  if (argc < 2 || std::strcmp(argv[1], "replay") != 0) args.insert(args.begin() + 1, replay);
  try {
    app.parse(static_cast<int>(args.size()), args.data());
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const kata::Error& e) {
    std::fprintf(stderr, "kata-replay: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kata-replay: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
