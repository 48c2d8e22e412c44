// Stand-ins for the registration helpers defined in tools/main.cpp, so that the
// test binary can link tools/cmd_rocks.cpp on its own (same behaviour: group()
// creates the group on first use).
#include <vector>

#include "cli.hpp"

namespace regolith::cli {

std::vector<Setup> &test_setups() {
  static std::vector<Setup> s;
  return s;
}

bool add_command(Setup setup) {
  test_setups().push_back(std::move(setup));
  return true;
}

CLI::App *group(CLI::App &app, const std::string &name,
                const std::string &description) {
  for (CLI::App *sub : app.get_subcommands([](CLI::App *) { return true; })) {
    if (sub->get_name() == name)
      return sub;
  }
  CLI::App *g = app.add_subcommand(name, description);
  g->require_subcommand(1);
  return g;
}

} // namespace regolith::cli
