#pragma once
// Helpers of the driver tests: bounded waits (never an unbounded hang) and shell commands.
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

#include "regolith/core/time.hpp"

namespace regolith::hwtest {

/// Poll `pred` every 10 ms until it holds or `timeout_s` passes; returns the final value.
template <class Pred>
bool wait_until(Pred&& pred, double timeout_s) {
  const TimeNs end = monotonic_now() + from_seconds(timeout_s);
  while (!pred()) {
    if (monotonic_now() > end) return pred();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

/// Run a shell command; returns its exit status (127 when it could not run).
inline int sh(const std::string& cmd) {
  const int r = std::system((cmd + " >/dev/null 2>&1").c_str());
  return r == -1 ? 127 : WEXITSTATUS(r);
}

}  // namespace regolith::hwtest
