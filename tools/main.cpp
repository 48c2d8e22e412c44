// regolith: the command-line tool. Sub-commands live in tools/cmd_*.cpp and register themselves.
#include <cstdlib>
#include <string>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/hal/device.hpp"

int main(int argc, char** argv) {
  // libcamera logs its version and pipeline set-up at INFO, in colour, to stderr, from whichever
  // command opens its camera manager (`devices`, `run`): keep its warnings and errors only, unless
  // the user asked otherwise. Set here, before any thread exists: libcamera reads the variable
  // when its first log category is made.
  setenv("LIBCAMERA_LOG_LEVELS", "*:WARN", /*overwrite=*/0);
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
  for (auto& s : regolith::cli::commands()) s(app);

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
