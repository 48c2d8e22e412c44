#include <cerrno>

#include "regolith/core/time.hpp"

namespace regolith {

void SystemClock::sleep_until(TimeNs t) {
  const timespec ts = to_timespec(t);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace regolith

namespace regolith {

std::atomic<TimeNs>& ros_time_offset() noexcept {
  static std::atomic<TimeNs> offset{0};
  return offset;
}

TimeNs measure_realtime_offset() noexcept {
  TimeNs best_span = INT64_MAX, offset = 0;
  for (int i = 0; i < 3; ++i) {
    timespec a{}, r{}, b{};
    clock_gettime(CLOCK_MONOTONIC, &a);
    clock_gettime(CLOCK_REALTIME, &r);
    clock_gettime(CLOCK_MONOTONIC, &b);
    const TimeNs ta = static_cast<TimeNs>(a.tv_sec) * kNsPerSec + a.tv_nsec;
    const TimeNs tb = static_cast<TimeNs>(b.tv_sec) * kNsPerSec + b.tv_nsec;
    const TimeNs tr = static_cast<TimeNs>(r.tv_sec) * kNsPerSec + r.tv_nsec;
    if (tb - ta < best_span) {
      best_span = tb - ta;
      offset = tr - (ta + (tb - ta) / 2);
    }
  }
  return offset;
}

}  // namespace regolith
