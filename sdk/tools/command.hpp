// The CLI's subcommand registry: each subcommand lives in its own file and registers itself,
// so `kata` grows by adding a file. Subcommands are thin: parse flags, call the library, report.
#pragma once

#include <functional>
#include <vector>

#include <CLI/CLI.hpp>

#include "failure.hpp"

namespace kata::cli {

// Adds one subcommand (with its flags and callback) to the app. A callback signals failure by
// throwing Failure (failure.hpp) or, in the commands on the private core, kata::Error (printed as "kata: message", exit 1) or CLI::RuntimeError(code).
using CommandSetup = void (*)(CLI::App& app);

std::vector<CommandSetup>& command_registry();

struct RegisterCommand {
  explicit RegisterCommand(CommandSetup setup) { command_registry().push_back(setup); }
};

}  // namespace kata::cli
