#pragma once
// A rate group: a period, an ordered list of member components, optional real-time priority and
// CPU affinity, and exact accounting of missed periods. The same RateGroup runs under the
// real-time executor (one thread each, absolute-deadline sleeps on CLOCK_MONOTONIC) and under the
// simulated-time executor (all groups in lockstep on one thread, as fast as the CPU allows).
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/time.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/stats.hpp"

namespace regolith::runtime {

/// True on a thread while it executes a rate-group cycle: lets allocation probes (tests, the
/// steady_state_allocations benchmark) count only what happens inside cycles.
bool in_rate_group_cycle();
/// The member whose step() the calling thread is executing inside a cycle, else nullptr: lets
/// the probes say which component allocated.
const Component* current_cycle_member();

/// Makes the calling thread count as working inside a cycle for `member` (the two above) until
/// destroyed: a worker pool's threads run their jobs under the caller's scope, so what a job
/// does is attributed to the member that handed it out. Restores the previous state.
class CycleScope {
 public:
  CycleScope(bool in_cycle, const Component* member);
  ~CycleScope();
  CycleScope(const CycleScope&) = delete;
  CycleScope& operator=(const CycleScope&) = delete;

 private:
  bool prev_in_cycle_;
  const Component* prev_member_;
};

enum class OverrunPolicy : std::uint8_t {
  kSkip,     ///< after an overrun, wait for the next release in the future (missed ones are dropped)
  kCatchUp,  ///< run the missed releases back to back until on schedule again
};

struct RateGroupConfig {
  std::string name;
  TimeNs period = 0;  ///< ns, > 0
  TimeNs offset = 0;  ///< phase of the first release after start, ns
  int priority = 0;   ///< SCHED_FIFO priority 1..99; 0 = normal scheduling
  int cpu = -1;       ///< CPU to pin the thread to; -1 = any
  OverrunPolicy overrun = OverrunPolicy::kSkip;
  std::vector<std::string> members;
};

struct RateGroupCounters {
  std::uint64_t cycles = 0;  ///< cycles executed
  std::uint64_t slips = 0;   ///< releases missed (deadline passed before the cycle ended)
  /// Of `slips`, those missed only because the cycle started late for reasons outside the group
  /// (another thread or rate group had the CPU, the host descheduled the process): had the cycle
  /// started when the group itself let it (its release, or its previous cycle's end), it would
  /// have ended in time. No member of the group is to blame for these.
  std::uint64_t late_start_slips = 0;
  /// Of `slips`, those missed only because the group's thread was runnable but off the CPU inside
  /// a cycle (preempted, or the host descheduled the virtual CPU: wall time that is not the
  /// thread's CPU time while no step blocked), in this cycle or in the previous one it ran into.
  /// Real clock only. No member of the group is to blame for these either; a step that blocks
  /// (I/O, a lock) is, and gets no such credit.
  std::uint64_t stall_slips = 0;
  std::uint64_t skipped = 0;  ///< releases not executed (skip policy)
  TimeNs last_release = 0;
};

class RateGroup {
 public:
  RateGroup(RateGroupConfig cfg, std::vector<Component*> members);

  const RateGroupConfig& config() const { return cfg_; }
  const std::vector<Component*>& members() const { return members_; }

  /// Start the schedule: the first release is `start + offset`.
  void reset(TimeNs start);
  /// The next release time to wait for.
  TimeNs next_release() const { return next_release_; }
  /// Run one cycle for release `next_release()` using `clock` for timing, then account for slips
  /// and compute the next release according to the overrun policy. Never allocates.
  void run_cycle(Clock& clock);

  RateGroupCounters counters() const;
  const ExecHistogram& cycle_exec() const { return cycle_exec_; }
  /// Wake-up latency: clock reading at cycle start minus release (real-time executor).
  const ExecHistogram& wakeup_latency() const { return wakeup_; }

 private:
  RateGroupConfig cfg_;
  std::vector<Component*> members_;
  TimeNs next_release_ = 0;
  TimeNs slip_horizon_ = 0;  // latest release already accounted as missed
  // When the previous cycle would have ended had no cycle started late from outside (sched_end_),
  // and had none been stalled either (own_end_): the schedules the slips are split by.
  TimeNs sched_end_ = 0;
  TimeNs own_end_ = 0;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> own_slips_{0};         // slips the cycle would have made starting on time
  std::atomic<std::uint64_t> stall_slips_{0};       // those only a stall made (off the CPU mid-cycle)
  std::atomic<std::uint64_t> late_start_slips_{0};  // the rest (counters().slips is the sum of the three)
  std::atomic<std::uint64_t> skipped_{0};
  std::atomic<TimeNs> last_release_{0};
  ExecHistogram cycle_exec_;
  ExecHistogram wakeup_;
};

/// Simulated clock: time advances only when the simulated executor (or a test) says so.
class SimClock final : public Clock {
 public:
  explicit SimClock(TimeNs start = kNsPerSec) : now_(start) {}
  TimeNs now() const override { return now_.load(std::memory_order_acquire); }
  /// Jump forward to `t` (never backwards).
  void sleep_until(TimeNs t) override {
    if (t > now()) now_.store(t, std::memory_order_release);
  }
  /// Let simulated time pass, e.g. to model a member's execution cost in a test.
  void advance(TimeNs dt) { now_.fetch_add(dt, std::memory_order_acq_rel); }
  bool simulated() const override { return true; }

 private:
  std::atomic<TimeNs> now_;
};

/// Runs rate groups. `run_until` returns when `stop` becomes true or the clock passes `end`.
class Executor {
 public:
  virtual ~Executor() = default;
  virtual void start(std::vector<RateGroup*> groups) = 0;
  virtual void stop() = 0;
  /// Block the caller until `end` (absolute, executor clock) or until `stop_flag` is set.
  virtual void run_until(TimeNs end, const std::atomic<bool>& stop_flag) = 0;
  virtual Clock& clock() = 0;
  /// Called on the executing thread after every cycle (simulated-time executor only): lets the
  /// application synchronise off-loop work, e.g. DDS delivery, with simulated time.
  virtual void set_after_cycle(std::function<void()> f) { (void)f; }
  /// Called on the executing thread before the clock advances to the next release `t`
  /// (simulated-time executor only): lets the application wait until the devices have produced
  /// what they deliver by `t` (hal::Device::ready_for).
  virtual void set_before_advance(std::function<void(TimeNs)> f) { (void)f; }
};

struct RealtimeOptions {
  bool lock_memory = false;  ///< mlockall(MCL_CURRENT | MCL_FUTURE)
};

/// One thread per rate group, clock_nanosleep(TIMER_ABSTIME) on CLOCK_MONOTONIC. Priorities,
/// affinity and memory locking fall back with one warning each when not permitted.
std::unique_ptr<Executor> make_realtime_executor(RealtimeOptions opts = {});
/// All rate groups on the calling thread in release order; `clock` is advanced to each release.
std::unique_ptr<Executor> make_sim_executor(SimClock& clock);

}  // namespace regolith::runtime
