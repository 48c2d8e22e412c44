// regolith: the command-line tool. Sub-commands live in tools/cmd_*.cpp and register themselves.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/params.hpp"
#include "regolith/hal/device.hpp"

namespace regolith::cli {

namespace {
std::vector<Setup>& setups() {
  static std::vector<Setup> s;
  return s;
}
}  // namespace

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
CLI::Validator number_check(bool strict) {
  return CLI::Validator(
      [strict](std::string& s) -> std::string {
        double v = 0.0;
        std::size_t used = 0;
        try {
          v = std::stod(s, &used);
        } catch (const std::exception&) {
          return "not a number: '" + s + "'";
        }
        if (used != s.size()) return "not a number: '" + s + "'";
        if (strict ? !(v > 0.0) : !(v >= 0.0)) return std::string(strict ? "must be > 0" : "must be >= 0") + " (got " + s + ")";
        return {};
      },
      strict ? "NUMBER > 0" : "NUMBER >= 0");
}
}  // namespace

CLI::Validator non_negative() { return number_check(false); }
CLI::Validator positive() { return number_check(true); }

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

int main(int argc, char** argv) {
  // Logs and errors go to stderr; stdout carries the summary, JSON lines and tables.
  spdlog::set_default_logger(spdlog::stderr_color_mt("regolith"));
  CLI::App app{"regolith: real-time terrain assessment for planetary micro-rovers"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("regolith ") + REGOLITH_VERSION);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.parse_complete_callback([&] { spdlog::set_level(spdlog::level::from_str(log_level)); });

  regolith::cli::register_everything();
  for (auto& s : regolith::cli::setups()) s(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return regolith::cli::usage_error(app, e, argc, argv);
  } catch (const regolith::ConfigError& e) {
    spdlog::error("{}", e.what());
    return regolith::cli::kExitConfig;
  } catch (const regolith::InputError& e) {
    spdlog::error("{}", e.what());
    return regolith::cli::kExitConfig;
  } catch (const regolith::hal::DeviceUnavailableError& e) {
    // The message names the deployment file, the field and the device; one line for the journal.
    spdlog::error(
        "{}; device unavailable at start-up, will be retried by systemd (exit status {}: regolith.service "
        "restarts on it)",
        e.what(), regolith::cli::kExitDeviceUnavailable);
    return regolith::cli::kExitDeviceUnavailable;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
