#pragma once
// StampCheckedCamera: every camera of a deployment is read through this decorator (the
// application wraps each one at configure time, real and mock backends alike, as it wraps
// encoders in PlausibleEncoders), so a frame whose capture stamp cannot be true never reaches a
// component.
//
// Capture stamps are on the process clock (CLOCK_MONOTONIC, or the simulated clock), taken by the
// driver when the frame was captured: a frame is read after it was captured. A frame stamped
// later than the time it is read (the clock's now() at the read, not the `now` the reader passes,
// which is its cycle's start; by more than kFutureToleranceNs) comes from a device whose clock
// stepped or is not the process clock: everything timed against it (the encoder angle at capture,
// the age that makes an input stale, the header stamp of what is published from it) would be
// wrong. Such a frame is withheld and counted once (stats().bad_stamps); readers see the last good
// frame go stale instead. A new frame stamped before the previous one (the device clock stepped
// back) is delivered, since its age is what the staleness checks judge, and the step is counted
// (stats().stamp_steps); the components that publish per frame skip it unless the step is larger
// than their input timeout (regolith::FrameOrder), so their outputs never go back in time.
//
// The V4L2 and libcamera backends already map kernel stamps onto the process clock and clamp them
// to the dequeue time, so this guards what they cannot: other backends (mocks, replays, plugins),
// whose clocks are whatever they were given.
//
// Real-time safe: no allocation, blocking lock or log; latest() may be called from several rate
// groups at once. The per-frame bookkeeping (once per sequence number, newest first) is done by
// whichever reader gets a try-lock; a reader that does not get it skips the bookkeeping (the
// holder is counting a frame at least as new; a later read counts what is left).
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>

#include "regolith/hal/camera.hpp"

namespace regolith::hal {

class StampCheckedCamera final : public Camera {
 public:
  static constexpr TimeNs kFutureToleranceNs = 100 * kNsPerMs;  ///< clock conversion jitter allowed

  /// `clock`: the process clock the deployment runs on (outlives this object).
  StampCheckedCamera(std::unique_ptr<Camera> inner, const Clock& clock) : inner_(std::move(inner)), clock_(clock) {}

  const std::string& id() const override { return inner_->id(); }
  void start() override { inner_->start(); }
  void stop() override { inner_->stop(); }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }
  CameraFormat format() const override { return inner_->format(); }
  bool latest(TimeNs now, FrameLease& out) override;
  /// The inner camera's, with `frames` less the withheld ones and bad_stamps / stamp_steps.
  CameraStats stats() const override;

  const Camera& inner() const { return *inner_; }

 private:
  static constexpr std::uint64_t kNone = std::numeric_limits<std::uint64_t>::max();
  /// Counts frame `seq` (stamp `stamp`, withheld or not) once, if it is newer than the last one counted.
  void account(std::uint64_t seq, TimeNs stamp, bool withheld);

  std::unique_ptr<Camera> inner_;
  const Clock& clock_;
  std::atomic_flag busy_ = ATOMIC_FLAG_INIT;                // try-lock of the fields below
  std::uint64_t last_seq_ = kNone;                          // the last frame counted ...
  TimeNs last_stamp_ = std::numeric_limits<TimeNs>::min();  // ... and the last delivered one's stamp
  std::atomic<std::uint64_t> bad_stamps_{0}, stamp_steps_{0};
};

}  // namespace regolith::hal
