#pragma once
// Sub-commands of the `regolith` tool. Each tools/cmd_<name>.cpp registers itself:
//   static const bool registered = regolith::cli::add_command([](CLI::App& app) { ... });
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli_support.hpp"

namespace regolith::cli {

using Setup = std::function<void(CLI::App& app)>;
bool add_command(Setup setup);
// Every registered command, in registration order.
const std::vector<Setup>& commands();

/// The sub-command group `name` (e.g. "config", "calibrate", "eval"), created on first use.
CLI::App* group(CLI::App& app, const std::string& name, const std::string& description);

/// Option checks with short messages ("must be >= 0 (got -1)"), where CLI11's own print the
/// limits of a double: a finite number; finite and >= 0; finite and > 0 (NaN and inf refused).
CLI::Validator finite();
CLI::Validator non_negative();
CLI::Validator positive();

/// Exit code and message for a command-line usage error: 2, one line naming the offending word
/// (an unknown command gets a suggestion and the list of commands). Help and --version: 0.
int usage_error(CLI::App& app, const CLI::ParseError& e, int argc, char** argv);

}  // namespace regolith::cli
