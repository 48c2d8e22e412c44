// Registers every component type and HAL backend compiled into this build: the built-in
// components, then every part declared with regolith_register_part() in its folder (the calls are
// generated into register_parts.cpp by tools/CMakeLists.txt).
#include "cli.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/runtime/application.hpp"

namespace regolith::cli {

void register_parts(hal::BackendRegistry& backends);  // generated

void register_everything() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  register_parts(hal::BackendRegistry::instance());
}

}  // namespace regolith::cli
