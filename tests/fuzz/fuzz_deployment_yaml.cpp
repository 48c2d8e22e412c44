// libFuzzer target: the YAML deployment reader (Params: anchors, merge keys, types, ranges) and
// the rover description (cameras with calibration and mounts, wheels, sun). Any input either
// loads or throws a located error; nothing else may happen.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    regolith::Params root = regolith::Params::load_string(text, "fuzz.yaml");
    const regolith::RoverDescription rover = regolith::read_rover_description(root, "/nonexistent");
    (void)rover;
  } catch (const std::exception&) {
    // a located configuration error: the expected outcome for most inputs
  }
  return 0;
}
