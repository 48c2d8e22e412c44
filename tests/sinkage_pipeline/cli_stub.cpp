// Stand-ins for the registration helpers of tools/main.cpp so that this test binary can link
// tools/cmd_sinkage.cpp on its own (same behaviour: group() creates the group on first use).
#include <vector>

#include "cli.hpp"

namespace regolith::cli {

bool add_command(Setup) { return true; }

CLI::App* group(CLI::App& app, const std::string& name, const std::string& description) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    if (sub->get_name() == name) return sub;
  }
  CLI::App* g = app.add_subcommand(name, description);
  g->require_subcommand(1);
  return g;
}

}  // namespace regolith::cli
