// Private stand-in for the `regolith` executable (tools/main.cpp), exposing
// only the rock commands, so that they can be run before / without the lead's
// tool.
#include <CLI/CLI.hpp>

#include <iostream>

#include "regolith/core/error.hpp"

namespace regolith::cli {
void add_rocks_commands(CLI::App &app);
}

int main(int argc, char **argv) {
  CLI::App app{"regolith (rock commands only; test build)"};
  app.require_subcommand(1);
  regolith::cli::add_rocks_commands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError &e) {
    return app.exit(e);
  } catch (const regolith::ConfigError &e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  } catch (const regolith::InputError &e) {
    std::cerr << "error: " << e.what() << '\n';
    return 2;
  } catch (const std::exception &e) {
    std::cerr << "error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}
