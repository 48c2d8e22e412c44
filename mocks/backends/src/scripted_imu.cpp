// IMU "scripted": a body attitude from a script (constant roll / pitch / heading plus an optional
// sinusoidal sway and a constant turn rate), sampled on the grid of a real IMU stream. With the
// script at its defaults the rover is level; the synthetic scenes' attitude is scripted the same
// way. Angular velocity = the script's Euler-angle rates (exact for the small sways it models);
// linear acceleration = gravity seen in the body frame (specific force of a rover at rest).
#include <algorithm>
#include <cmath>

#include "backends_internal.hpp"
#include "common.hpp"

namespace regolith::mocks {
namespace {

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;

struct AttitudeScript {
  Attitude base;                ///< at start [rad]
  double sway_roll_rad = 0.0;   ///< amplitude of the roll sway
  double sway_pitch_rad = 0.0;  ///< amplitude of the pitch sway
  double sway_period_s = 4.0;
  double yaw_rate_rad_s = 0.0;
  double gravity_mps2 = 1.62;

  Attitude at(double t) const {
    const double s = std::sin(kTwoPi * t / sway_period_s);
    return {base.roll_rad + sway_roll_rad * s, base.pitch_rad + sway_pitch_rad * s, base.yaw_rad + yaw_rate_rad_s * t};
  }
  Vec3 rates(double t) const {
    const double c = kTwoPi / sway_period_s * std::cos(kTwoPi * t / sway_period_s);
    return {sway_roll_rad * c, sway_pitch_rad * c, yaw_rate_rad_s};
  }
};

class ScriptedImu final : public detail::GridImu {
 public:
  ScriptedImu(const hal::DeviceContext& ctx, AttitudeScript script, double rate_hz)
      : GridImu(ctx, rate_hz), script_(script) {}

 private:
  Attitude attitude(double t) const override { return script_.at(t); }
  void motion(double t, hal::ImuSample& out) const override {
    out.angular_velocity = script_.rates(t);
    // Specific force at rest: the reaction to gravity, (0, 0, g) in the local level, in the body.
    out.linear_acceleration = out.attitude.rotation().transposed() * Vec3{0.0, 0.0, script_.gravity_mps2};
  }

  AttitudeScript script_;
};

}  // namespace

std::unique_ptr<hal::Imu> make_scripted_imu(Params& p, const hal::DeviceContext& ctx) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  AttitudeScript s;
  const double rate = p.get<double>(
      "rate_hz", 100.0, {.unit = "Hz", .min = 0.0, .max = 10000.0, .min_exclusive = true, .doc = "sample rate"});
  s.base.roll_rad =
      kDeg * p.get<double>("roll_deg", 0.0,
                           {.unit = "deg", .min = -90.0, .max = 90.0, .doc = "body roll at start (left side up +)"});
  s.base.pitch_rad =
      kDeg * p.get<double>("pitch_deg", 0.0,
                           {.unit = "deg", .min = -90.0, .max = 90.0, .doc = "body pitch at start (nose down +)"});
  s.base.yaw_rad = kDeg * p.get<double>("yaw_deg", 0.0,
                                        {.unit = "deg",
                                         .min = -360.0,
                                         .max = 360.0,
                                         .doc = "heading at start, counter-clockwise from the local-level x"});
  s.sway_roll_rad = kDeg * p.get<double>("sway_roll_deg", 0.0,
                                         {.unit = "deg", .min = 0.0, .max = 45.0, .doc = "roll sway amplitude"});
  s.sway_pitch_rad = kDeg * p.get<double>("sway_pitch_deg", 0.0,
                                          {.unit = "deg", .min = 0.0, .max = 45.0, .doc = "pitch sway amplitude"});
  s.sway_period_s =
      p.get<double>("sway_period_s", 4.0, {.unit = "s", .min = 0.01, .max = 3600.0, .doc = "sway period"});
  s.yaw_rate_rad_s =
      kDeg * p.get<double>("yaw_rate_deg_s", 0.0, {.unit = "deg/s", .min = -360.0, .max = 360.0, .doc = "turn rate"});
  s.gravity_mps2 = p.get<double>(
      "gravity_mps2", ctx.rover != nullptr && ctx.rover->gravity_mps2 > 0.0 ? ctx.rover->gravity_mps2 : 1.62,
      {.unit = "m/s^2", .min = 0.0, .max = 100.0, .doc = "surface gravity (default rover.gravity_mps2)"});
  return std::make_unique<ScriptedImu>(ctx, s, rate);
}

}  // namespace regolith::mocks
