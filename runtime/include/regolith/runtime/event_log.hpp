#pragma once
// The event log (what F Prime calls events): device faults and recoveries, components that stall
// or lose an input, rate-group slips, as one line each, derived off the real-time path from the
// health monitor's snapshots and written through spdlog (console) and, when the deployment
// publishes on DDS, to /rosout as rcl_interfaces/Log (RosoutSink, rate-limited).
//
// Nothing here runs in a rate-group cycle: HealthEvents compares two snapshots (allocates,
// formats); the application calls it from a non-real-time thread (or after each simulated cycle
// under --sim-time).
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <spdlog/details/null_mutex.h>
#include <spdlog/sinks/base_sink.h>

#include "regolith/core/time.hpp"
#include "regolith/runtime/health.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

struct Event {
  enum class Severity : std::uint8_t { kInfo, kWarn, kError };
  Severity severity = Severity::kInfo;
  std::string text;
};

/// Turns successive health snapshots into events. The first snapshot reports errors at once and
/// warnings (e.g. an input not delivered yet at start-up) only if the next snapshot still has
/// them; afterwards an entry whose level worsens (ok -> warn / stale / error, or warn -> error)
/// is a warning or an error naming it and the monitor's message ("camera front: faulted"), one
/// that returns to ok is "... recovered", and a rate group whose slip counter grew reports how
/// many cycles slipped since (rate groups are matched by name, so reordering is harmless).
class HealthEvents {
 public:
  std::vector<Event> update(const HealthSnapshot& snapshot);

 private:
  struct Seen {
    std::string key;
    Level level = Level::kOk;
    std::uint64_t slips = 0, errors = 0, late_start_slips = 0, stall_slips = 0;
  };
  std::vector<Seen> seen_;
  bool first_ = true;
};

/// spdlog sink publishing every record (info and above) on /rosout as rcl_interfaces/Log:
/// level DEBUG 10 .. FATAL 50, name = `node` (the deployment), msg = the formatted text (cut to
/// 255 characters), stamp = ROS time of `now()` (process clock: monotonic, or the simulated
/// clock). At most `per_second` records per second of `now()` with bursts of `burst`; the rest are counted
/// and, when the budget allows again, announced as "N log messages suppressed". Never blocks on
/// DDS: the outbox's publisher thread writes.
class RosoutSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  RosoutSink(dds::Participant& participant, std::string node, std::function<TimeNs()> now, double per_second = 10.0,
             double burst = 20.0);
  ~RosoutSink() override;
  std::uint64_t published() const { return published_; }
  std::uint64_t suppressed_total() const { return suppressed_total_; }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override;
  void flush_() override {}

 private:
  bool publish(std::uint8_t level, std::string_view text, const spdlog::source_loc& where);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string node_;
  std::function<TimeNs()> now_;
  double per_second_, burst_, tokens_;
  TimeNs refill_ = 0;
  std::uint64_t suppressed_ = 0, suppressed_total_ = 0, published_ = 0;
};

}  // namespace regolith::runtime
