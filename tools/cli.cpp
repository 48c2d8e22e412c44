// The sub-command registry and the helpers every tools/cmd_*.cpp shares (part of regolith_cli, so
// that test binaries link the same code as the `regolith` executable).
#include "cli.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <unistd.h>

#include "regolith/core/params.hpp"

namespace regolith::cli {

namespace {
std::vector<Setup>& setups() {
  static std::vector<Setup> s;
  return s;
}
}  // namespace

const std::vector<Setup>& commands() {
  return setups();
}

bool add_command(Setup setup) {
  setups().push_back(std::move(setup));
  return true;
}

CLI::App* group(CLI::App& app, const std::string& name, const std::string& description) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    if (sub->get_name() == name) return sub;
  }
  CLI::App* g = app.add_subcommand(name, description);
  g->require_subcommand(1);
  return g;
}

namespace {
enum class Bound { kFinite, kNonNegative, kPositive };

CLI::Validator number_check(Bound bound) {
  static constexpr const char* kNames[] = {"NUMBER", "NUMBER >= 0", "NUMBER > 0"};
  return CLI::Validator(
      [bound](std::string& s) -> std::string {
        double v = 0.0;
        std::size_t used = 0;
        try {
          v = std::stod(s, &used);
        } catch (const std::exception&) {
          return "not a number: '" + s + "'";
        }
        if (used != s.size()) return "not a number: '" + s + "'";
        if (!std::isfinite(v)) return "must be a finite number (got " + s + ")";
        if (bound == Bound::kNonNegative && !(v >= 0.0)) return "must be >= 0 (got " + s + ")";
        if (bound == Bound::kPositive && !(v > 0.0)) return "must be > 0 (got " + s + ")";
        return {};
      },
      kNames[static_cast<int>(bound)]);
}
}  // namespace

CLI::Validator finite() {
  return number_check(Bound::kFinite);
}
CLI::Validator non_negative() {
  return number_check(Bound::kNonNegative);
}
CLI::Validator positive() {
  return number_check(Bound::kPositive);
}

std::string tool_node_name(const std::string& command) {
  return "regolith_" + command + "_" + std::to_string(::getpid());
}

int usage_error(CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
  if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
  // A command's own exit status (echo: fewer samples than asked; replay --compare: a difference):
  // the command has said why.
  if (dynamic_cast<const CLI::RuntimeError*>(&e) != nullptr) return e.get_exit_code();
  // Walk the words: the first one that is neither an option (nor an option's value) nor a
  // command of the level it appears at, where a command is required, is the offending word.
  CLI::App* level = &app;
  for (int i = 1; i < argc; ++i) {
    const std::string w = argv[i];
    if (w.rfind("-", 0) == 0) {
      if (w.find('=') == std::string::npos && i + 1 < argc && level->get_option_no_throw(w) != nullptr &&
          level->get_option_no_throw(w)->get_expected_min() > 0)
        ++i;  // its value
      continue;
    }
    std::vector<std::string> names;
    CLI::App* next = nullptr;
    for (CLI::App* sub : level->get_subcommands([](CLI::App*) { return true; })) {
      names.push_back(sub->get_name());
      if (sub->get_name() == w) next = sub;
    }
    if (next != nullptr) {
      level = next;
      continue;
    }
    if (!names.empty() && level->get_require_subcommand_min() > 0) {
      std::string msg = "unknown command '" + w + "'";
      const std::string guess = regolith::did_you_mean(w, names);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      std::fprintf(stderr, "%s: %s; commands: %s\n", level == &app ? "regolith" : level->get_name().c_str(),
                   msg.c_str(), list.c_str());
      return kExitConfig;
    }
    break;
  }
  std::fprintf(stderr, "%s: %s\nRun with --help for more information.\n",
               level == &app ? "regolith" : level->get_name().c_str(), e.what());
  return kExitConfig;
}

}  // namespace regolith::cli
