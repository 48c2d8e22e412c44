// libFuzzer target: a whole deployment as `regolith config check` takes it: the YAML reader, the
// rover description, every component's parameter validation and configure, every HAL backend's
// parameter validation (devices not opened), the rate groups and the data-flow graph check. Any
// input either configures or throws a located error; nothing else may happen: no crash, no
// sanitizer report, and no configuration that makes configure allocate without bound.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "cli_support.hpp"
#include "regolith/core/params.hpp"
#include "regolith/runtime/application.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  regolith::cli::register_everything();
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    auto app = regolith::runtime::Application::load(regolith::Params::load_string(text, "fuzz.yaml"),
                                                    {.sim_time = true, .enable_dds = false, .open_devices = false});
    (void)app;
  } catch (const std::exception&) {
    // a located configuration error: the expected outcome for most inputs
  }
  return 0;
}
