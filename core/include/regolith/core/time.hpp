#pragma once
// Time in regolith: signed 64-bit nanoseconds on CLOCK_MONOTONIC (or on the simulated clock when
// the process runs with --sim-time). Every HAL sample carries its capture time in this base.
#include <atomic>
#include <cstdint>
#include <ctime>

namespace regolith {

using TimeNs = std::int64_t;

inline constexpr TimeNs kNsPerUs = 1'000;
inline constexpr TimeNs kNsPerMs = 1'000'000;
inline constexpr TimeNs kNsPerSec = 1'000'000'000;

constexpr double to_seconds(TimeNs t) {
  return static_cast<double>(t) * 1e-9;
}
constexpr TimeNs from_seconds(double s) {
  return static_cast<TimeNs>(s * 1e9);
}

inline TimeNs monotonic_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSec + ts.tv_nsec;
}

/// CLOCK_REALTIME in ns since 1970 (wall-clock stamps of recordings and kernel CAN frames; the
/// process clock stays monotonic_now()).
inline TimeNs realtime_now() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSec + ts.tv_nsec;
}

/// CPU time consumed by the calling thread (CLOCK_THREAD_CPUTIME_ID), ns: what a step or a job
/// cost without preemption or sleeps. Allocation-free.
inline TimeNs thread_cpu_now() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * kNsPerSec + ts.tv_nsec;
}

inline timespec to_timespec(TimeNs t) {
  return timespec{static_cast<time_t>(t / kNsPerSec), static_cast<long>(t % kNsPerSec)};
}

/// ROS time (what ROS 2 tools compare stamps with) of a process-clock time: on the system clock
/// CLOCK_REALTIME = process time + the measured offset realtime - monotonic (refreshed by the
/// application while it runs, so NTP steps and slews follow); under --sim-time the simulated time
/// itself (offset 0: ROS's use_sim_time, the same value the application publishes on /clock).
/// Internally everything stays on the process clock; only message stamps are converted.
std::atomic<TimeNs>& ros_time_offset() noexcept;
inline TimeNs to_ros_time(TimeNs process_ns) noexcept {
  return process_ns + ros_time_offset().load(std::memory_order_relaxed);
}
/// CLOCK_REALTIME - CLOCK_MONOTONIC now, read as the midpoint of two monotonic reads around one
/// realtime read (the tightest of three tries).
TimeNs measure_realtime_offset() noexcept;

/// The clock every rate group, HAL backend and component reads. `SystemClock` is CLOCK_MONOTONIC;
/// the runtime's `SimClock` is advanced by the simulated-time executor.
class Clock {
 public:
  virtual ~Clock() = default;
  virtual TimeNs now() const = 0;
  /// Sleep until absolute time `t`. On the simulated clock this never blocks on wall time.
  virtual void sleep_until(TimeNs t) = 0;
  virtual bool simulated() const = 0;
};

class SystemClock final : public Clock {
 public:
  TimeNs now() const override { return monotonic_now(); }
  void sleep_until(TimeNs t) override;
  bool simulated() const override { return false; }
};

}  // namespace regolith
