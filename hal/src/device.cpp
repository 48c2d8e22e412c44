#include "regolith/hal/device.hpp"

#include <cmath>

#include "regolith/hal/imu.hpp"

namespace regolith::hal {

std::string_view to_string(DeviceState s) {
  switch (s) {
    case DeviceState::kStopped: return "stopped";
    case DeviceState::kStreaming: return "streaming";
    case DeviceState::kFaulted: return "faulted";
    case DeviceState::kRecovering: return "recovering";
  }
  return "unknown";
}

Quaternion to_quaternion(const Attitude& a) {
  const auto q = quaternion(a.rotation());
  return {q[0], q[1], q[2], q[3]};
}

void rethrow_located(const Params& p, const DeviceError& e) {
  const std::string key = p.has(e.field()) ? e.field() : std::string{};
  if (dynamic_cast<const DeviceUnavailableError*>(&e) != nullptr) {
    throw DeviceUnavailableError(e.field(), p.where(key) + ": " + p.field_path(key) + ": " + e.what());
  }
  p.fail(key, e.what());
}

}  // namespace regolith::hal
