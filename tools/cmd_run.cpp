// regolith run: load a deployment, run its rate groups with a live summary until Ctrl-C or
// --duration. regolith config check: validate a deployment and print the resolved configuration.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <iostream>

#include "cli.hpp"
#include "regolith/core/params.hpp"
#include "regolith/runtime/application.hpp"
#include "summary.hpp"

namespace regolith::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

Params load_config(const std::string& path) {
  if (path.empty()) return Params::load_string(embedded_mock_rover(), "<embedded>/config/mock_rover.yaml");
  return Params::load_file(path);
}

struct RunOptions {
  std::string config;
  double duration_s = 0.0;
  bool sim_time = false;
  double summary_interval_s = 1.0;
  bool quiet = false;
};

void run(const RunOptions& o) {
  auto app = runtime::Application::load(load_config(o.config), {.sim_time = o.sim_time});
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  spdlog::info("deployment '{}': {} rate groups, {} components{}", app->name(), app->view().groups.size(),
               app->view().components.size(), o.sim_time ? " (simulated time)" : "");
  app->start();

  Summary summary(*app, isatty(STDOUT_FILENO) != 0 && !o.quiet);
  const TimeNs duration = o.duration_s > 0 ? from_seconds(o.duration_s) : 0;
  const TimeNs t_end = duration > 0 ? app->clock().now() + duration : INT64_MAX;
  const TimeNs wall_interval = from_seconds(o.summary_interval_s);
  TimeNs next_print = monotonic_now() + wall_interval;
  // Run in slices so the summary and the rate-limited warnings are produced on this (non
  // real-time) thread. Under --sim-time a slice is one simulated second.
  while (!g_stop.load() && app->clock().now() < t_end) {
    const TimeNs slice = std::min<TimeNs>(app->sim_time() ? kNsPerSec : 100 * kNsPerMs, t_end - app->clock().now());
    app->run(slice, g_stop);
    summary.warn_rate_limited();
    if (!o.quiet && monotonic_now() >= next_print) {
      summary.print(std::cout);
      next_print = monotonic_now() + wall_interval;
    }
  }
  app->stop();
  if (!o.quiet) summary.print(std::cout, /*final=*/true);
}

const bool registered = add_command([](CLI::App& app) {
  auto opts = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "run a deployment (default: the embedded mocked rover)");
  cmd->add_option("--config,-c", opts->config, "deployment YAML (default: embedded config/mock_rover.yaml)");
  cmd->add_option("--duration,-d", opts->duration_s, "stop after this many seconds (of simulated time with --sim-time)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--sim-time", opts->sim_time, "simulated clock: run in lockstep as fast as the CPU allows");
  cmd->add_option("--summary-interval", opts->summary_interval_s, "seconds between live summaries")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--quiet,-q", opts->quiet, "no live summary");
  cmd->callback([opts] { run(*opts); });

  CLI::App* config = group(app, "config", "deployment configuration tools");
  auto file = std::make_shared<std::string>();
  CLI::App* check = config->add_subcommand("check", "validate a deployment and print the resolved configuration");
  check->add_option("file", *file, "deployment YAML (default: the embedded mocked rover)");
  check->callback([file] {
    auto loaded = runtime::Application::load(load_config(*file), {.sim_time = true, .enable_dds = false, .open_devices = false});
    std::cout << "# " << (file->empty() ? "<embedded>/config/mock_rover.yaml" : *file) << ": OK ("
              << loaded->view().groups.size() << " rate groups, " << loaded->view().components.size() << " components)\n";
    print_resolved(std::cout, loaded->resolved());
  });
});

}  // namespace
}  // namespace regolith::cli
