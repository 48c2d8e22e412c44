// regolith echo TOPIC [--count N]: subscribe from a separate process and print samples as JSON
// lines (one object per sample, ROS field names).
#include <csignal>
#include <iostream>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/topics.hpp"

namespace regolith::cli {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) {
  g_interrupted.store(true);
}

struct EchoArgs {
  std::string topic;
  std::size_t count = 0;
  double timeout_s = 0.0;
  int domain = -1;  // -1: $ROS_DOMAIN_ID (read when the command runs: a bad value is a usage error), else 0
  std::string ns = "rover1";
  bool best_effort = false;
  bool delay = false;
  bool list = false;
};

const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<EchoArgs>();
  CLI::App* cmd = app.add_subcommand("echo", "print a topic's samples as JSON lines (subscribes over DDS)");
  cmd->add_option("topic", a->topic, "topic, e.g. joint_states, /diagnostics, terrain/grid_map");
  cmd->add_option("--count,-n", a->count, "stop after N samples (default: until Ctrl-C)");
  cmd->add_option("--timeout", a->timeout_s, "give up after this many seconds without reaching --count (exit 1)")
      ->check(regolith::cli::non_negative());
  cmd->add_option("--domain", a->domain, "DDS domain id (default: $ROS_DOMAIN_ID, else 0)")->check(CLI::Range(0, 232));
  cmd->add_option("--namespace", a->ns, "robot namespace of relative topic names");
  cmd->add_flag("--best-effort", a->best_effort, "best-effort reader (also matches sensor-data publishers)");
  cmd->add_flag("--list", a->list, "list the known topics and their types");
  cmd->add_flag("--delay", a->delay,
                "add \"received\" (ROS time at receipt) and \"delay_ms\" (received - header.stamp) to each sample");
  cmd->callback([a] {
    dds::Participant participant(dds::ParticipantConfig{dds::resolve_domain_id(a->domain), a->ns});
    if (a->list || a->topic.empty()) {
      std::cout << dds::list_topics(&participant);
      return;
    }
    if (dds::find_topic(a->topic) == nullptr) {
      throw InputError("unknown topic '" + a->topic + "'; known topics:\n" + dds::list_topics(&participant));
    }
    std::signal(SIGINT, on_interrupt);
    std::signal(SIGTERM, on_interrupt);
    dds::EchoOptions opt;
    opt.count = a->count;
    opt.timeout_ns = from_seconds(a->timeout_s);
    opt.best_effort = a->best_effort;
    opt.receipt_time = a->delay;
    opt.keep_going = [] { return !g_interrupted.load(); };
    participant.announce_node(tool_node_name("echo"));  // its subscription is listed once made
    const std::size_t n = dds::echo(participant, a->topic, opt, std::cout);
    if (a->count > 0 && n < a->count && !g_interrupted.load()) throw CLI::RuntimeError(1);
  });
});

}  // namespace
}  // namespace regolith::cli
