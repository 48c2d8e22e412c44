// libFuzzer target: the can-utils `candump -l` log-line parser (hal::parse_candump_line), and
// every frame it accepts through the wheel-angle decoder.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "regolith/hal/can.hpp"

namespace {
regolith::hal::CanDecoder& decoder() {
  static regolith::hal::CanDecoder d({{"left", 0x0CF, false, 0, 4, false, true, 1e-4, 0.0, true},
                                      {"right", 0x0CF, false, 4, 4, true, false, 1e-4, 0.0, true},
                                      {"x", 0x18FF0001, true, 6, 2, false, true, 0.5, 1.0, false}});
  return d;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  regolith::hal::CanFrame frame;
  std::string iface, error;
  double t = 0.0;
  if (regolith::hal::parse_candump_line(line, frame, iface, t, error)) {
    double sum = 0.0;
    decoder().decode(frame, [&](std::size_t, double v) { sum += v; });
    (void)sum;
  }
  return 0;
}
