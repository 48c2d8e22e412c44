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
  const double cr = std::cos(0.5 * a.roll_rad), sr = std::sin(0.5 * a.roll_rad);
  const double cp = std::cos(0.5 * a.pitch_rad), sp = std::sin(0.5 * a.pitch_rad);
  const double cy = std::cos(0.5 * a.yaw_rad), sy = std::sin(0.5 * a.yaw_rad);
  return {sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy};
}


void rethrow_located(const Params& p, const DeviceError& e) {
  const std::string key = p.has(e.field()) ? e.field() : std::string{};
  if (dynamic_cast<const DeviceUnavailableError*>(&e) != nullptr) {
    throw DeviceUnavailableError(e.field(), p.where(key) + ": " + p.field_path(key) + ": " + e.what());
  }
  p.fail(key, e.what());
}

}  // namespace regolith::hal
