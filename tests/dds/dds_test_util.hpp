#pragma once
// Shared helpers of the DDS tests: an isolated domain / namespace per process
// (no cross-talk with other test processes on the same host), the loopback
// Cyclone configuration, and views that point C sequences at std::vector
// storage (for building samples on the stack in tests).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "test_domain.hpp"

namespace regolith::dds::testing {

/// Pins Cyclone to the loopback interface (unless the caller already set
/// CYCLONEDDS_URI).
inline void use_loopback_config() {
  setenv("CYCLONEDDS_URI", "file://" REGOLITH_DDS_LOOPBACK_XML, 0);
}

/// This process's DDS domain, held by no other running test process
/// (tests/common/test_domain.hpp).
inline std::uint32_t test_domain() {
  return regolith::testing::test_domain();
}

/// A namespace unique to this process and call ("t<pid>_<n>").
inline std::string unique_ns() {
  static std::atomic<int> n{0};
  return "t" + std::to_string(getpid()) + "_" + std::to_string(n++);
}

/// Points a C sequence at `v` (not owned: _release = false).
template <class Seq, class T>
void view(Seq& seq, std::vector<T>& v) {
  seq._buffer = v.data();
  seq._length = static_cast<std::uint32_t>(v.size());
  seq._maximum = static_cast<std::uint32_t>(v.size());
  seq._release = false;
}

/// Polls `pred` every millisecond up to `timeout` (condition waits on DDS
/// events that are not driven by our clock: matching, deadline timers).
template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return pred();
}

inline char* cstr(const char* s) {
  return const_cast<char*>(s);
}

}  // namespace regolith::dds::testing
