#include <cerrno>

#include "regolith/core/time.hpp"

namespace regolith {

void SystemClock::sleep_until(TimeNs t) {
  const timespec ts = to_timespec(t);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace regolith
