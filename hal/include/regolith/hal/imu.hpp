#pragma once
// The IMU device kind: body attitude, angular velocity and specific force, with capture stamps.
// Frames: the IMU is mounted aligned with the body frame (REP-103: x forward, y left, z up);
// orientation = the body in the local-level frame (z up, x = the heading at start). Real backends
// (Linux IIO) rotate their sensor frame into the body frame; the mock scripts it.
#include <cstddef>
#include <cstdint>
#include <span>

#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/device.hpp"

namespace regolith::hal {

struct ImuSample {
  TimeNs stamp = 0;  ///< capture time (ns, process clock)
  std::uint64_t sequence = 0;
  Attitude attitude;         ///< roll, pitch, yaw of the body in the local-level frame [rad]
  Vec3 angular_velocity;     ///< body frame [rad/s]
  Vec3 linear_acceleration;  ///< specific force, body frame [m/s^2] (level at rest: +g on z)
};

/// Unit quaternion (x, y, z, w) of an attitude (R = Rz(yaw) Ry(pitch) Rx(roll)), as
/// geometry_msgs/Quaternion carries it.
struct Quaternion {
  double x = 0.0, y = 0.0, z = 0.0, w = 1.0;
};
Quaternion to_quaternion(const Attitude& a);

/// Physical limits of what an IMU can report; beyond them a sample is damaged (a corrupt packet,
/// a sensor fault), not a motion, and consumers skip it.
inline constexpr double kImuMaxRateRadS = 35.0;           ///< ~2000 deg/s, the largest common gyro range
inline constexpr double kImuMaxAccelerationMps2 = 160.0;  ///< 16 g
/// Finite angles, roll within +-pi, pitch within +-pi/2 (yaw is continuous, any finite value).
bool plausible(const Attitude& a);
/// A plausible attitude, and every rate / acceleration component finite and within the limits.
bool plausible(const ImuSample& s);

/// An inertial measurement unit. Query functions are real-time safe (no lock, no allocation, no
/// exception).
class Imu : public Device {
 public:
  static constexpr const char* kKind = "imu";
  const char* kind() const final { return kKind; }
  /// Newest sample available at `now`; false when there is none (not started, faulted).
  virtual bool latest(TimeNs now, ImuSample& out) const = 0;
  /// The attitude at time `t` (e.g. a camera frame's capture time), interpolated between the
  /// samples around it; false outside the history.
  virtual bool attitude_at(TimeNs t, Attitude& out) const = 0;
  /// The samples with `after` < stamp <= `now`, oldest first, at most out.size() (call again from
  /// the last one's stamp for the rest); returns how many. For recorders, outside the rate groups.
  /// The default gives the newest only.
  virtual std::size_t samples_since(TimeNs after, TimeNs now, std::span<ImuSample> out) const {
    ImuSample s;
    if (out.empty() || !latest(now, s) || s.stamp <= after) return 0;
    out[0] = s;
    return 1;
  }
};

}  // namespace regolith::hal
