#pragma once
// PlausibleEncoders: every encoder device of a deployment is read through this decorator (the
// application wraps each one at configure time, real and mock backends alike), so a corrupt
// sample never reaches a component, `joint_states` or the odometry.
//
// Per wheel it keeps a reference: the newest sample it accepted. A sample is plausible when its
// angle is finite and it agrees with the reference: |angle - ref| <= max_rate x |dt| +
// kToleranceRad, max_rate being the wheel's `rover.wheels[].max_rate_rad_s` (default
// kDefaultMaxRateRadS). Without a reference (at the start, or after re-acquiring), a sample must
// agree with one of the kPredecessors samples before it in the device's history to become the
// reference; the very first sample (or any, from a device that cannot look back) has nothing to
// disagree with and is taken as it is: a corrupt very first sample is not caught. A bit flip or a garbage
// frame (1,895 rad after 3.2 rad, 10 ms later) is rejected; after kReacquire rejected samples in a
// row the wheel is taken to have really jumped (an encoder re-zeroed) and the next sample is the
// new reference, so one bad first sample cannot shut a wheel out for good.
//   latest()        the newest plausible sample (walking back over rejected ones through the
//                   device's history, at most kMaxWalk samples);
//   angle_at()      the device's interpolation when it agrees with the newest plausible sample at
//                   or before t; past that sample, when the device extrapolated from a rejected one,
//                   an extrapolation from the last two plausible samples (at most
//                   kMaxExtrapolation); else refused (interpolated through garbage);
//   samples_since() the plausible ones only (recorders).
// Each rejected sample is counted once (stats().rejected, so DeviceCounters::rejected, the health
// diagnostics and the run summary). Real-time safe: no allocation, lock or log (the reference is a
// per-wheel seqlock whose writers only ever try).
#include <atomic>
#include <limits>
#include <memory>
#include <vector>

#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::hal {

class PlausibleEncoders final : public WheelEncoders {
 public:
  static constexpr double kDefaultMaxRateRadS = 50.0;  ///< rad/s (about 480 rpm)
  static constexpr double kToleranceRad = 0.05;        ///< rad, quantisation and timestamp jitter
  static constexpr int kReacquire = 5;  ///< rejected samples in a row after which the wheel re-references
  static constexpr int kMaxWalk = 16;
  static constexpr int kPredecessors = 4;                      ///< samples a new reference is compared with
  static constexpr TimeNs kMaxExtrapolation = 100 * kNsPerMs;  ///< past the newest plausible sample

  /// `max_rate_rad_s[i]` for wheel i of `inner` (missing or non-positive: the default).
  PlausibleEncoders(std::unique_ptr<WheelEncoders> inner, std::vector<double> max_rate_rad_s);

  const std::string& id() const override { return inner_->id(); }
  const std::vector<std::string>& wheel_names() const override { return inner_->wheel_names(); }
  void start() override { inner_->start(); }
  void stop() override { inner_->stop(); }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }
  bool latest(std::size_t wheel, TimeNs now, AngleSample& out) const override;
  bool angle_at(std::size_t wheel, TimeNs t, double& angle) const override;
  std::size_t samples_since(std::size_t wheel, TimeNs after, TimeNs now, std::span<AngleSample> out) const override;
  EncoderStats stats() const override;
  /// The raw frames as the inner backend received them (plausibility applies to decoded angles).
  bool reads_can() const override { return inner_->reads_can(); }
  std::size_t can_frames(std::uint64_t& cursor, TimeNs now, std::span<CanFrame> out,
                         std::uint64_t& missed) const override {
    return inner_->can_frames(cursor, now, out, missed);
  }

  const WheelEncoders& inner() const { return *inner_; }

 private:
  struct Reference {  // one wheel's newest accepted sample (seqlock) and rejection bookkeeping
    std::atomic<std::uint64_t> seq{0};
    std::atomic<TimeNs> stamp{0};
    std::atomic<double> angle{0.0};
    std::atomic<TimeNs> last_rejected{std::numeric_limits<TimeNs>::min()};
    std::atomic<int> streak{0};
  };
  /// Accepts (and takes as the reference when newer) or rejects (and counts) one sample.
  bool check(std::size_t wheel, const AngleSample& s) const;
  bool agree(std::size_t wheel, const AngleSample& a, const AngleSample& b) const;
  /// Without a reference: one of the kPredecessors samples before `s` agrees with it.
  bool agrees_with_history(std::size_t wheel, const AngleSample& s) const;
  bool read(const Reference& r, AngleSample& out) const;
  void write(Reference& r, const AngleSample& s) const;
  double rate(std::size_t wheel) const;
  std::unique_ptr<WheelEncoders> inner_;
  std::vector<double> max_rate_;
  std::unique_ptr<Reference[]> ref_;
  mutable std::atomic<std::uint64_t> rejected_{0};
};

}  // namespace regolith::hal
