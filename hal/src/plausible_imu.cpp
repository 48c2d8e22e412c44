#include "regolith/hal/plausible_imu.hpp"

#include <array>
#include <cmath>

#include "regolith/hal/sample_filter.hpp"

namespace regolith::hal {

void PlausibleImu::reject(const ImuSample& s) const {
  // Counted once: samples are met newest first by latest() and oldest first by samples_since(),
  // always at stamps past those already counted or at the same stamp again.
  TimeNs seen = newest_rejected_.load(std::memory_order_relaxed);
  while (s.stamp > seen)
    if (newest_rejected_.compare_exchange_weak(seen, s.stamp, std::memory_order_relaxed)) {
      rejected_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
}

bool PlausibleImu::latest(TimeNs now, ImuSample& out) const {
  TimeNs q = now;
  for (int i = 0; i < kMaxWalk; ++i) {
    if (!inner_->latest(q, out)) return false;
    if (plausible(out)) return true;
    reject(out);
    q = out.stamp - 1;
  }
  return false;
}

bool PlausibleImu::attitude_at(TimeNs t, Attitude& out) const {
  if (inner_->attitude_at(t, out) && plausible(out)) return true;
  ImuSample a;
  if (!latest(t, a)) return false;  // the newest plausible sample at or before t
  ImuSample b;
  bool after = false;
  std::array<ImuSample, 16> batch{};
  TimeNs from = a.stamp;
  const TimeNs now = clock_->now();
  for (int round = 0; round < kMaxWalk && !after; ++round) {
    const std::size_t got = inner_->samples_since(from, now, batch);
    for (std::size_t i = 0; i < got && !after; ++i) {
      if (!plausible(batch[i])) continue;
      b = batch[i];
      after = b.stamp > t;
    }
    if (got < batch.size()) break;
    from = batch[got - 1].stamp;
  }
  if (!after) {
    if (t - a.stamp > kMaxHold) return false;
    out = a.attitude;
    return true;
  }
  constexpr double kPi = 3.14159265358979323846;
  const double f = static_cast<double>(t - a.stamp) / static_cast<double>(b.stamp - a.stamp);
  double dyaw = b.attitude.yaw_rad - a.attitude.yaw_rad;
  dyaw -= 2.0 * kPi * std::round(dyaw / (2.0 * kPi));
  out.roll_rad = a.attitude.roll_rad + f * (b.attitude.roll_rad - a.attitude.roll_rad);
  out.pitch_rad = a.attitude.pitch_rad + f * (b.attitude.pitch_rad - a.attitude.pitch_rad);
  out.yaw_rad = a.attitude.yaw_rad + f * dyaw;
  return true;
}

std::size_t PlausibleImu::samples_since(TimeNs after, TimeNs now, std::span<ImuSample> out) const {
  return filter_samples(
      after, out, [&](TimeNs a, std::span<ImuSample> b) { return inner_->samples_since(a, now, b); },
      [&](const ImuSample& s) {
        if (plausible(s)) return true;
        reject(s);
        return false;
      });
}

DeviceCounters PlausibleImu::counters() const {
  DeviceCounters c = inner_->counters();
  c.rejected += rejected_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace regolith::hal
