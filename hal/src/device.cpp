#include "regolith/hal/device.hpp"

#include <cmath>

#include "regolith/core/error.hpp"
#include "regolith/core/image_limits.hpp"
#include "regolith/hal/camera.hpp"
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

bool plausible(const Attitude& a) {
  constexpr double kPi = 3.14159265358979323846;
  return std::isfinite(a.yaw_rad) && std::abs(a.roll_rad) <= kPi && std::abs(a.pitch_rad) <= 0.5 * kPi;
}

bool plausible(const ImuSample& s) {
  const auto within = [](const Vec3& v, double limit) {
    return std::abs(v.x) <= limit && std::abs(v.y) <= limit && std::abs(v.z) <= limit;  // false for NaN
  };
  return plausible(s.attitude) && within(s.angular_velocity, kImuMaxRateRadS) &&
         within(s.linear_acceleration, kImuMaxAccelerationMps2);
}

Quaternion to_quaternion(const Attitude& a) {
  const auto q = quaternion(a.rotation());
  return {q[0], q[1], q[2], q[3]};
}

void validate_backoff(double retry_min_s, double retry_max_s) {
  if (!(retry_min_s > 0.0) || !std::isfinite(retry_min_s))
    throw FieldError("", "retry_min", "must be > 0 s and finite");
  if (!(retry_max_s >= retry_min_s) || !std::isfinite(retry_max_s)) {
    throw FieldError("", "retry_max", "must be finite and >= retry_min (" + number_text(retry_min_s) + " s)");
  }
}

void validate_capture(int width, int height, double frame_timeout_s) {
  const auto side = [](int v, const char* field) {
    if (v < 1 || v > kMaxImageSidePx) {
      throw FieldError("", field,
                       "must be in [1, " + std::to_string(kMaxImageSidePx) + "] px (got " + std::to_string(v) + ")");
    }
  };
  side(width, "width");
  side(height, "height");
  if (!(frame_timeout_s > 0.0) || !std::isfinite(frame_timeout_s))
    throw FieldError("", "frame_timeout", "must be > 0 s and finite");
}

void rethrow_located(const Params& p, const DeviceError& e) {
  const std::string key = p.has(e.field()) ? e.field() : std::string{};
  if (dynamic_cast<const DeviceUnavailableError*>(&e) != nullptr) {
    throw DeviceUnavailableError(e.field(), p.where(key) + ": " + p.field_path(key) + ": " + e.what());
  }
  p.fail(key, e.what());
}

}  // namespace regolith::hal
