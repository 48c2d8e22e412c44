#include "regolith/hal/device.hpp"

namespace regolith::hal {

void rethrow_located(const Params& p, const DeviceError& e) {
  const std::string key = p.has(e.field()) ? e.field() : std::string{};
  if (dynamic_cast<const DeviceUnavailableError*>(&e) != nullptr) {
    throw DeviceUnavailableError(e.field(), p.where(key) + ": " + p.field_path(key) + ": " + e.what());
  }
  p.fail(key, e.what());
}

}  // namespace regolith::hal
