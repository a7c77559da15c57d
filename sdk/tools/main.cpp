// kata: the command-line tool. Every subcommand is a thin layer over the library.
#include <cstdio>
#include <exception>

#include "command.hpp"
#include "common/error.hpp"

namespace kata::cli {
std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> commands;
  return commands;
}
}  // namespace kata::cli

int main(int argc, char** argv) {
  CLI::App app{"kata: real-time 3D pose features, scoring and retargeting"};
  app.require_subcommand(1);
  app.set_version_flag("--version", KATA_VERSION_STRING);
  for (auto setup : kata::cli::command_registry()) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const kata::Error& e) {
    std::fprintf(stderr, "kata: %s\n", e.what());
    return 1;
  } catch (const kata::cli::Failure& e) {
    std::fprintf(stderr, "kata: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kata: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
