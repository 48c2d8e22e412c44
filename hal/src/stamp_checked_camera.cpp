#include "regolith/hal/stamp_checked_camera.hpp"

namespace regolith::hal {

void StampCheckedCamera::account(std::uint64_t seq, TimeNs stamp, bool withheld) {
  if (busy_.test_and_set(std::memory_order_acquire)) return;  // another reader is counting
  if (last_seq_ == kNone || seq > last_seq_) {
    last_seq_ = seq;
    if (withheld) {
      bad_stamps_.fetch_add(1, std::memory_order_relaxed);
    } else {
      if (stamp < last_stamp_) stamp_steps_.fetch_add(1, std::memory_order_relaxed);
      last_stamp_ = stamp;
    }
  }
  busy_.clear(std::memory_order_release);
}

bool StampCheckedCamera::latest(TimeNs now, FrameLease& out) {
  if (!inner_->latest(now, out)) return false;
  // Against the time of this read, not the reader's `now` (its cycle's start): a frame captured
  // since the cycle began is not from the future.
  const bool future = out->capture_time > clock_.now() + kFutureToleranceNs;
  account(out->sequence, out->capture_time, future);
  if (future) {
    out.reset();
    return false;
  }
  return true;
}

CameraStats StampCheckedCamera::stats() const {
  CameraStats s = inner_->stats();
  s.bad_stamps = bad_stamps_.load(std::memory_order_relaxed);
  s.stamp_steps = stamp_steps_.load(std::memory_order_relaxed);
  s.frames = s.frames >= s.bad_stamps ? s.frames - s.bad_stamps : 0;
  return s;
}

}  // namespace regolith::hal
