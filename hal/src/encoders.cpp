#include <algorithm>
#include <cmath>

#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::hal {

bool WheelEncoders::velocity(std::size_t wheel, TimeNs now, double& rad_per_s) const {
  AngleSample a;
  if (!latest(wheel, now, a)) return false;
  constexpr TimeNs kWindow = 20 * kNsPerMs;
  double before = 0.0;
  if (!angle_at(wheel, a.stamp - kWindow, before)) return false;
  rad_per_s = (a.angle - before) / to_seconds(kWindow);
  return true;
}

std::size_t WheelEncoders::samples_since(std::size_t wheel, TimeNs after, TimeNs now,
                                         std::span<AngleSample> out) const {
  AngleSample s;
  if (out.empty() || !latest(wheel, now, s) || s.stamp <= after) return 0;
  out[0] = s;
  return 1;
}

std::size_t WheelEncoders::can_frames(std::uint64_t& /*cursor*/, TimeNs /*now*/, std::span<CanFrame> /*out*/,
                                      std::uint64_t& /*missed*/) const {
  return 0;
}

bool WheelEncoders::stale(std::size_t wheel, TimeNs now, TimeNs timeout) const {
  AngleSample s;
  if (!latest(wheel, now, s)) return true;
  return now - s.stamp > timeout;
}

bool interpolate(const AngleHistory::Snapshot& h, TimeNs t, TimeNs max_extrapolation, double& angle) {
  if (h.count == 0) return false;
  const AngleSample& newest = h.newest();
  if (h.count == 1) {
    if (std::llabs(t - newest.stamp) > max_extrapolation) return false;
    angle = newest.angle;
    return true;
  }
  if (t >= newest.stamp) {
    if (t - newest.stamp > max_extrapolation) return false;
    const AngleSample& prev = h.newest(1);
    const double dt = static_cast<double>(newest.stamp - prev.stamp);
    angle =
        dt > 0 ? newest.angle + (newest.angle - prev.angle) * static_cast<double>(t - newest.stamp) / dt : newest.angle;
    return true;
  }
  // Walk back from the newest sample to the pair bracketing t.
  for (std::size_t back = 1; back < h.count; ++back) {
    const AngleSample& a = h.newest(back);
    const AngleSample& b = h.newest(back - 1);
    if (t >= a.stamp) {
      const double dt = static_cast<double>(b.stamp - a.stamp);
      const double f = dt > 0 ? static_cast<double>(t - a.stamp) / dt : 0.0;
      angle = a.angle + f * (b.angle - a.angle);
      return true;
    }
  }
  return false;  // older than the history
}

bool AngleHistory::push(const AngleSample& s) {
  if (work_.count > 0 && s.stamp < work_.newest().stamp) return false;
  work_.head = work_.count == 0 ? 0 : (work_.head + 1) % kCapacity;
  work_.ring[work_.head] = s;
  if (work_.count < kCapacity) ++work_.count;
  return pool_.publish(work_);
}

bool AngleHistory::latest(AngleSample& out) const {
  auto lease = pool_.acquire();
  if (!lease || lease->count == 0) return false;
  out = lease->newest();
  return true;
}

bool AngleHistory::at(TimeNs t, TimeNs max_extrapolation, double& angle) const {
  auto lease = pool_.acquire();
  if (!lease) return false;
  return interpolate(*lease, t, max_extrapolation, angle);
}

bool AngleHistory::velocity(double& rad_per_s) const {
  auto lease = pool_.acquire();
  if (!lease || lease->count < 2) return false;
  const auto& a = lease->newest(1);
  const auto& b = lease->newest();
  if (b.stamp <= a.stamp) return false;
  rad_per_s = (b.angle - a.angle) / to_seconds(b.stamp - a.stamp);
  return true;
}

std::size_t AngleHistory::since(TimeNs after, std::span<AngleSample> out) const {
  auto lease = pool_.acquire();
  if (!lease) return 0;
  std::size_t n = 0;  // how many of the newest samples are after `after`
  while (n < lease->count && lease->newest(n).stamp > after) ++n;
  const std::size_t m = std::min(n, out.size());
  for (std::size_t i = 0; i < m; ++i) out[i] = lease->newest(n - 1 - i);
  return m;
}

}  // namespace regolith::hal
