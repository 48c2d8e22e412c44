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
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/watchdog.hpp"
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
  std::vector<std::string> wait_for;
  double wait_timeout_s = 30.0;
};

void run(const RunOptions& o) {
  auto app = runtime::Application::load(load_config(o.config),
                                        {.sim_time = o.sim_time, .wait_for = o.wait_for,
                                         .wait_timeout = from_seconds(o.wait_timeout_s)});
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  spdlog::info("deployment '{}': {} rate groups, {} components{}", app->name(), app->view().groups.size(),
               app->view().components.size(), o.sim_time ? " (simulated time)" : "");
  // Under systemd (Type=notify): READY=1 once every rate group has cycled, WATCHDOG=1 only while
  // every critical component is healthy (see runtime/watchdog.hpp). Outside systemd: no-ops.
  runtime::SystemdNotifier notifier;
  auto& health = app->context().channel<runtime::HealthSnapshot>("health/snapshot");
  app->start();

  Summary summary(*app, isatty(STDOUT_FILENO) != 0 && !o.quiet);
  const TimeNs duration = o.duration_s > 0 ? from_seconds(o.duration_s) : 0;
  const TimeNs t_end = duration > 0 ? app->clock().now() + duration : INT64_MAX;
  const TimeNs wall_interval = from_seconds(o.summary_interval_s);
  TimeNs next_print = monotonic_now() + wall_interval;
  // Run in slices so the summary is produced on this (non real-time) thread. Under --sim-time a
  // slice is one simulated second.
  while (!g_stop.load() && app->clock().now() < t_end) {
    const TimeNs slice = std::min<TimeNs>(app->sim_time() ? kNsPerSec : 100 * kNsPerMs, t_end - app->clock().now());
    app->run(slice, g_stop);
    {
      const auto snapshot = health.acquire();
      notifier.update(app->view(), snapshot ? &*snapshot : nullptr, app->clock().now());
    }
    if (!o.quiet && monotonic_now() >= next_print) {
      summary.print(std::cout);
      next_print = monotonic_now() + wall_interval;
    }
  }
  notifier.stopping();
  app->stop();
  if (!o.quiet) summary.print(std::cout, /*final=*/true);
}

const bool registered = add_command([](CLI::App& app) {
  auto opts = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "run a deployment (default: the embedded mocked rover)");
  cmd->add_option("--config,-c", opts->config, "deployment YAML (default: embedded config/mock_rover.yaml)");
  cmd->add_option("--duration,-d", opts->duration_s, "stop after this many seconds (of simulated time with --sim-time)")
      ->check(regolith::cli::positive());
  cmd->add_flag("--sim-time", opts->sim_time, "simulated clock: run in lockstep as fast as the CPU allows");
  cmd->add_option("--summary-interval", opts->summary_interval_s, "seconds between live summaries")
      ->check(regolith::cli::positive());
  cmd->add_flag("--quiet,-q", opts->quiet, "no live summary");
  cmd->add_option("--wait-for", opts->wait_for, "before starting, wait for a subscriber on this DDS topic (repeatable)");
  cmd->add_option("--wait-timeout", opts->wait_timeout_s, "seconds to wait for --wait-for subscribers")
      ->check(regolith::cli::non_negative());
  cmd->callback([opts] { run(*opts); });

  CLI::App* config = group(app, "config", "deployment configuration tools");
  auto file = std::make_shared<std::string>();
  auto dot = std::make_shared<bool>(false);
  CLI::App* check = config->add_subcommand(
      "check", "validate a deployment and print the resolved configuration and the data-flow graph");
  check->add_option("file", *file, "deployment YAML (default: the embedded mocked rover)");
  check->add_flag("--dot", *dot, "print only the data-flow graph, in Graphviz dot (| dot -Tsvg > flow.svg)");
  check->callback([file, dot] {
    auto loaded = runtime::Application::load(load_config(*file), {.sim_time = true, .enable_dds = false, .open_devices = false});
    if (*dot) {
      loaded->dataflow().print_dot(std::cout);
      return;
    }
    std::cout << "# " << (file->empty() ? "<embedded>/config/mock_rover.yaml" : *file) << ": OK ("
              << loaded->view().groups.size() << " rate groups, " << loaded->view().components.size() << " components)\n";
    print_resolved(std::cout, loaded->resolved());
    loaded->dataflow().print(std::cout);
  });
});

}  // namespace
}  // namespace regolith::cli
