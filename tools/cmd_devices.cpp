// `regolith devices`: what is attached (each hardware backend lists its own devices: V4L2 nodes
// with formats, libcamera cameras, CAN interfaces) and the backends of every device kind.
#include <iostream>

#include "cli.hpp"
#include "regolith/hal/registry.hpp"

namespace regolith::cli {
namespace {

void list_devices(bool with_slow) {
  const auto& reg = hal::BackendRegistry::instance();
  for (const auto& l : reg.listers()) {
    if (l.slow && !with_slow) continue;
    l.list(std::cout);
  }
  for (const auto& kind : reg.kinds()) {
    std::cout << kind << " backends:";
    for (const auto& [name, doc] : reg.backends(kind)) std::cout << " " << name;
    std::cout << "\n";
  }
}

const bool registered = add_command([](CLI::App& app) {
  auto no_libcamera = std::make_shared<bool>(false);
  CLI::App* cmd =
      app.add_subcommand("devices", "list cameras and CAN interfaces, with formats, to help write the YAML");
  cmd->add_flag("--no-libcamera", *no_libcamera, "skip libcamera (its camera manager takes a few seconds to start)");
  cmd->callback([no_libcamera] {
    register_everything();
    list_devices(!*no_libcamera);
  });
});

}  // namespace
}  // namespace regolith::cli
