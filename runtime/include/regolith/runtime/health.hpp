#pragma once
// Health monitoring. The `health` component (its own low-rate group) fills a fixed-size snapshot
// every cycle from the counters the rate groups and components keep: heartbeat progress, execution
// statistics, slips, stale inputs, device faults. The snapshot is published on channel
// "health/snapshot"; the DDS layer turns it into diagnostic_msgs/DiagnosticArray off the real-time
// path, and the watchdog (systemd) is fed only while every critical component is healthy.
#include <array>
#include <cstdint>

#include "regolith/core/time.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/stats.hpp"

namespace regolith::runtime {

inline constexpr std::size_t kMaxHealthEntries = 32;
inline constexpr std::size_t kNameLen = 40;

struct HealthEntry {
  enum class Kind : std::uint8_t { kComponent, kRateGroup, kCamera, kEncoders, kImu };
  Kind kind = Kind::kComponent;
  std::array<char, kNameLen> name{};   ///< component / group / device name
  std::array<char, kNameLen> group{};  ///< rate group of a component
  Level level = Level::kOk;
  const char* message = "ok";  ///< static string
  std::uint64_t heartbeat = 0;
  std::uint64_t cycles = 0;
  std::uint64_t slips = 0;
  std::uint64_t late_start_slips = 0;  ///< rate groups: of `slips`, missed only by a late start (RateGroupCounters)
  std::uint64_t stall_slips = 0;   ///< rate groups: of `slips`, missed only by a stall mid-cycle (RateGroupCounters)
  std::uint64_t errors = 0;        ///< component errors / device faults
  std::uint64_t stale_inputs = 0;  ///< inputs stale right now
  std::uint64_t frames = 0;        ///< devices: frames or samples delivered
  std::uint64_t dropped = 0;       ///< devices: dropped frames / rejected samples
  std::uint64_t lost = 0;          ///< encoders: frames lost before they were read (bus receive queue)
  std::uint64_t bad_stamps = 0;    ///< cameras: frames withheld, stamped after they were read (device clock)
  TimeNs period = 0;
  StatsSummary exec{};  ///< execution time on the schedule clock
  StatsSummary wall{};  ///< execution time on CLOCK_MONOTONIC
  bool critical = false;
};

/// Whether `e` stops the systemd watchdog: a critical component that is stuck (no heartbeat) or
/// in error. A warning (stale input, overruns) does not: restarting would not cure it.
inline bool gates_watchdog(const HealthEntry& e) {
  return e.critical && (e.level == Level::kError || e.level == Level::kStale);
}

struct HealthSnapshot {
  TimeNs stamp = 0;
  std::uint32_t count = 0;
  std::array<HealthEntry, kMaxHealthEntries> entries{};
  bool all_critical_ok = true;  ///< no entry gates_watchdog(): the systemd watchdog is fed
};

}  // namespace regolith::runtime
