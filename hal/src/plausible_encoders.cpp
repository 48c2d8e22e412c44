#include "regolith/hal/plausible_encoders.hpp"

#include <cmath>
#include <limits>

#include "regolith/hal/sample_filter.hpp"

namespace regolith::hal {

PlausibleEncoders::PlausibleEncoders(std::unique_ptr<WheelEncoders> inner, std::vector<double> max_rate_rad_s)
    : inner_(std::move(inner)), max_rate_(std::move(max_rate_rad_s)) {
  const std::size_t n = inner_->wheel_count();
  max_rate_.resize(n, kDefaultMaxRateRadS);
  for (double& r : max_rate_)
    if (!(r > 0) || !std::isfinite(r)) r = kDefaultMaxRateRadS;
  ref_ = std::make_unique<Reference[]>(n);
}

double PlausibleEncoders::rate(std::size_t wheel) const {
  return wheel < max_rate_.size() ? max_rate_[wheel] : kDefaultMaxRateRadS;
}

bool PlausibleEncoders::read(const Reference& r, AngleSample& out) const {
  for (int tries = 0; tries < 8; ++tries) {
    const std::uint64_t s0 = r.seq.load(std::memory_order_acquire);
    if (s0 & 1u) continue;  // a writer is in the middle
    out.stamp = r.stamp.load(std::memory_order_relaxed);
    out.angle = r.angle.load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (r.seq.load(std::memory_order_relaxed) == s0) return s0 != 0;  // 0: never written
  }
  return false;
}

void PlausibleEncoders::write(Reference& r, const AngleSample& s) const {
  std::uint64_t s0 = r.seq.load(std::memory_order_relaxed);
  if ((s0 & 1u) || !r.seq.compare_exchange_strong(s0, s0 + 1, std::memory_order_acquire)) return;  // busy: skip
  if (s0 != 0 && s.stamp <= r.stamp.load(std::memory_order_relaxed)) {
    r.seq.store(s0 + 2, std::memory_order_release);  // not newer: keep the reference
    return;
  }
  std::atomic_thread_fence(std::memory_order_release);
  r.stamp.store(s.stamp, std::memory_order_relaxed);
  r.angle.store(s.angle, std::memory_order_relaxed);
  r.seq.store(s0 + 2, std::memory_order_release);
}

bool PlausibleEncoders::agree(std::size_t wheel, const AngleSample& a, const AngleSample& b) const {
  const double dt = to_seconds(a.stamp > b.stamp ? a.stamp - b.stamp : b.stamp - a.stamp);
  return std::isfinite(b.angle) && std::abs(a.angle - b.angle) <= rate(wheel) * dt + kToleranceRad;
}

bool PlausibleEncoders::agrees_with_history(std::size_t wheel, const AngleSample& s) const {
  TimeNs q = s.stamp - 1;
  for (int k = 0; k < kPredecessors; ++k) {
    AngleSample p;
    // No earlier sample at all (the very first, or a device that cannot look back): nothing to
    // disagree with, so it is served (a corrupt very first sample is the one thing not caught).
    if (!inner_->latest(wheel, q, p) || p.stamp >= s.stamp) return k == 0;
    if (agree(wheel, s, p)) return true;
    q = p.stamp - 1;
  }
  return false;
}

bool PlausibleEncoders::check(std::size_t wheel, const AngleSample& s) const {
  if (wheel >= max_rate_.size()) return false;
  Reference& r = ref_[wheel];
  bool ok = std::isfinite(s.angle);
  AngleSample ref;
  if (ok && read(r, ref)) {
    ok = agree(wheel, s, ref);
  } else if (ok) {
    ok = agrees_with_history(wheel, s);  // no reference yet: agree with the device's history
  }
  if (ok) {
    r.streak.store(0, std::memory_order_relaxed);
    write(r, s);
    return true;
  }
  // Counted once per sample, however often it is met.
  TimeNs seen = r.last_rejected.load(std::memory_order_relaxed);
  while (s.stamp > seen) {
    if (r.last_rejected.compare_exchange_weak(seen, s.stamp, std::memory_order_relaxed)) {
      rejected_.fetch_add(1, std::memory_order_relaxed);
      // So many in a row: the wheel really jumped; a finite sample becomes the reference again.
      if (r.streak.fetch_add(1, std::memory_order_relaxed) + 1 >= kReacquire && std::isfinite(s.angle)) {
        r.streak.store(0, std::memory_order_relaxed);
        r.seq.store(0, std::memory_order_relaxed);  // forget; the next check re-references
      }
      break;
    }
  }
  return false;
}

bool PlausibleEncoders::latest(std::size_t wheel, TimeNs now, AngleSample& out) const {
  TimeNs q = now;
  for (int i = 0; i < kMaxWalk; ++i) {
    AngleSample s;
    if (!inner_->latest(wheel, q, s) || s.stamp > q) return false;  // no older sample to fall back on
    if (check(wheel, s)) {
      out = s;
      return true;
    }
    q = s.stamp - 1;
  }
  return false;
}

bool PlausibleEncoders::angle_at(std::size_t wheel, TimeNs t, double& angle) const {
  double v = 0.0;
  if (wheel >= max_rate_.size() || !inner_->angle_at(wheel, t, v) || !std::isfinite(v)) return false;
  // Against the newest plausible sample at or before t (checking it refreshes the reference), else
  // against the reference itself.
  AngleSample a;
  if (!latest(wheel, t, a) && !read(ref_[wheel], a)) return false;  // nothing plausible to check it against yet
  if (agree(wheel, AngleSample{t, v}, a)) {
    angle = v;
    return true;
  }
  // The device extrapolated (or interpolated) from a rejected sample. Past the newest plausible
  // sample, extrapolate from it and the plausible one before it instead (at most kMaxExtrapolation).
  if (t < a.stamp || t - a.stamp > kMaxExtrapolation) return false;
  AngleSample b;
  if (latest(wheel, a.stamp - 1, b) && b.stamp < a.stamp)
    angle = a.angle + (a.angle - b.angle) * static_cast<double>(t - a.stamp) / static_cast<double>(a.stamp - b.stamp);
  else
    angle = a.angle;
  return true;
}

std::size_t PlausibleEncoders::samples_since(std::size_t wheel, TimeNs after, TimeNs now,
                                             std::span<AngleSample> out) const {
  // Read on past rejected samples: a batch that was all garbage is not the end of the history.
  return filter_samples(
      after, out, [&](TimeNs a, std::span<AngleSample> b) { return inner_->samples_since(wheel, a, now, b); },
      [&](const AngleSample& s) { return check(wheel, s); });
}

EncoderStats PlausibleEncoders::stats() const {
  EncoderStats s = inner_->stats();
  s.rejected += rejected_.load(std::memory_order_relaxed);
  return s;
}

}  // namespace regolith::hal
