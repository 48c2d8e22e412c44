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

class ScriptedImu final : public hal::Imu {
 public:
  ScriptedImu(const hal::DeviceContext& ctx, AttitudeScript script, double rate_hz)
      : id_(ctx.id), clock_(detail::clock_of(ctx)), script_(script), grid_(rate_hz) {}

  const std::string& id() const override { return id_; }
  void start() override {
    run_.begin(clock_->now());
  }
  void stop() override { run_.end(clock_->now()); }

  bool latest(TimeNs now, hal::ImuSample& out) const override {
    if (!run_.running()) return false;
    const std::int64_t k = grid_.index(now - run_.start());
    if (k < 0) return false;
    sample(k, out);
    return true;
  }
  /// Sample k of the run (stamp: the start + k periods).
  void sample(std::int64_t k, hal::ImuSample& out) const {
    const TimeNs t0 = run_.start();
    const TimeNs rel = grid_.offset(k);
    const double t = to_seconds(rel);
    out.stamp = t0 + rel;
    out.sequence = static_cast<std::uint64_t>(k);
    out.attitude = script_.at(t);
    out.angular_velocity = script_.rates(t);
    // Specific force at rest: the reaction to gravity, (0, 0, g) in the local level, in the body.
    out.linear_acceleration = out.attitude.rotation().transposed() * Vec3{0.0, 0.0, script_.gravity_mps2};
  }

  std::size_t samples_since(TimeNs after, TimeNs now, std::span<hal::ImuSample> out) const override {
    return grid_samples_since(run_, grid_, after, now, out, [this](std::int64_t k, hal::ImuSample& s) { sample(k, s); });
  }
  bool attitude_at(TimeNs t, Attitude& out) const override {
    if (!run_.running()) return false;
    const TimeNs t0 = run_.start();
    if (t < t0) return false;
    out = script_.at(to_seconds(t - t0));
    return true;
  }

  hal::DeviceCounters counters() const override {
    hal::DeviceCounters c;
    TimeNs rel = 0;
    if (!run_.counted(clock_->now(), rel)) return c;
    c.state = run_.state();
    const std::int64_t k = grid_.index(rel);
    c.delivered = k < 0 ? 0 : static_cast<std::uint64_t>(k + 1);
    return c;
  }

 private:
  std::string id_;
  Clock* clock_;
  AttitudeScript script_;
  detail::TimeGrid grid_;
  detail::RunSpan run_;
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
