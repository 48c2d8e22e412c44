// regolith live [ADDR:]PORT: relay the DDS topics of a running rover to Foxglove Studio /
// Lichtblick over the Foxglove WebSocket protocol (runtime/live/README.md), from a separate
// process, until Ctrl-C.
#include <csignal>
#include <iostream>
#include <memory>
#include <thread>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/live/dds_relay.hpp"
#include "regolith/live/web_root.hpp"

namespace regolith::cli {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_live_interrupt(int) {
  g_interrupted.store(true);
}

struct LiveArgs {
  std::string listen = "127.0.0.1:8765";
  int domain = -1;  // -1: $ROS_DOMAIN_ID (read when the command runs: a bad value is a usage error), else 0
  std::string ns = "rover1";
  double duration_s = 0.0;
  std::string token_file;
};

const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<LiveArgs>();
  CLI::App* cmd =
      app.add_subcommand("live", "serve the DDS topics to Foxglove Studio / Lichtblick (Foxglove WebSocket protocol)");
  cmd->add_option("listen", a->listen, "[ADDR:]PORT to listen on (default 127.0.0.1:8765)");
  cmd->add_option("--domain", a->domain, "DDS domain id (default: $ROS_DOMAIN_ID, else 0)")->check(CLI::Range(0, 232));
  cmd->add_option("--namespace", a->ns, "robot namespace of relative topic names");
  cmd->add_option("--token-file", a->token_file,
                  "file (mode 0600) holding the access token clients must present (`?token=`, a bearer header or "
                  "the cookie the page gets); needed to listen on an address other than loopback");
  cmd->add_option("--duration", a->duration_s, "stop after this many seconds (default: until Ctrl-C)")
      ->check(regolith::cli::non_negative());
  cmd->callback([a] {
    live::FoxgloveServerOptions opt;
    try {
      live::parse_listen_address(a->listen, opt);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("live: ") + e.what());
    }
    opt.web_root = live::default_web_root();  // the built-in page on GET /
    dds::Participant participant(dds::ParticipantConfig{dds::resolve_domain_id(a->domain), a->ns});
    participant.announce_node(tool_node_name("live"));  // a node with the relay's subscriptions
    std::unique_ptr<live::DdsRelay> relay_ptr;
    try {
      if (!a->token_file.empty()) opt.token = live::read_token_file(a->token_file);
      relay_ptr =
          std::make_unique<live::DdsRelay>(participant, opt);  // std::runtime_error when the port cannot be bound
    } catch (const std::invalid_argument& e) {                 // a bad token file, or not loopback without one
      throw InputError(std::string("live: ") + e.what());
    }
    live::DdsRelay& relay = *relay_ptr;
    std::signal(SIGINT, on_live_interrupt);
    std::signal(SIGTERM, on_live_interrupt);
    relay.start();
    std::cout << "regolith live: ws://" << opt.address << ":" << relay.server().port() << " ("
              << relay.server().channels().size() << " channels, domain " << participant.domain_id() << ", namespace '"
              << a->ns << "'); page http://" << opt.address << ":" << relay.server().port() << "/"
              << (opt.token.empty() ? "" : "?token=<the token>") << "; Ctrl-C stops" << std::endl;
    const auto start = std::chrono::steady_clock::now();
    while (!g_interrupted.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (a->duration_s > 0 &&
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= a->duration_s) {
        break;
      }
    }
    relay.stop();
    const auto st = relay.server().stats();
    std::cout << "regolith live: " << relay.samples() << " samples taken, " << st.messages_sent << " messages sent, "
              << st.accepted << " clients, " << st.dropped_slow << " dropped (slow), " << st.refused << " refused, "
              << st.bad_requests << " bad requests, " << st.unauthorized << " without the token" << std::endl;
  });
});

}  // namespace
}  // namespace regolith::cli
