#pragma once
// PlausibleImu: every IMU device of a deployment is read through this decorator (the application
// wraps each one at configure time, real and mock backends alike, as it wraps encoders in
// PlausibleEncoders), so a damaged sample never reaches a component, `imu` or the odometry.
//
// A sample is plausible when hal::plausible(sample) holds: finite values, roll within +-pi, pitch
// within +-pi/2, rates within kImuMaxRateRadS and specific force within kImuMaxAccelerationMps2.
//   latest()        the newest plausible sample (walking back over damaged ones through the
//                   device's history, at most kMaxWalk samples);
//   attitude_at()   the device's interpolation when it is a plausible attitude; when it was
//                   interpolated through a damaged sample, the interpolation between the plausible
//                   samples around t (found through the device's history up to the clock's now);
//                   past the newest plausible sample its attitude held for at most kMaxHold;
//   samples_since() the plausible ones only (recorders).
// Each damaged sample is counted once (counters().rejected: the health diagnostics and the run
// summary). Real-time safe: no allocation, lock or log.
#include <atomic>
#include <limits>
#include <memory>

#include "regolith/hal/imu.hpp"

namespace regolith::hal {

class PlausibleImu final : public Imu {
 public:
  static constexpr int kMaxWalk = 16;
  static constexpr TimeNs kMaxHold = 100 * kNsPerMs;  ///< past the newest plausible sample

  /// `clock`: the process clock the device's stamps are on (bounds the history searched forward).
  PlausibleImu(std::unique_ptr<Imu> inner, const Clock& clock) : inner_(std::move(inner)), clock_(&clock) {}

  const std::string& id() const override { return inner_->id(); }
  void start() override { inner_->start(); }
  void stop() override { inner_->stop(); }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }
  bool latest(TimeNs now, ImuSample& out) const override;
  bool attitude_at(TimeNs t, Attitude& out) const override;
  std::size_t samples_since(TimeNs after, TimeNs now, std::span<ImuSample> out) const override;
  DeviceCounters counters() const override;

  const Imu& inner() const { return *inner_; }

 private:
  void reject(const ImuSample& s) const;

  std::unique_ptr<Imu> inner_;
  const Clock* clock_;
  mutable std::atomic<TimeNs> newest_rejected_{std::numeric_limits<TimeNs>::min()};
  mutable std::atomic<std::uint64_t> rejected_{0};
};

}  // namespace regolith::hal
