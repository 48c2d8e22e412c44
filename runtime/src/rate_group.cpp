#include "regolith/runtime/rate_group.hpp"

#include <algorithm>
#include <ctime>
#include <stdexcept>

#include <sys/resource.h>

namespace regolith::runtime {

namespace {
thread_local bool t_in_cycle = false;
thread_local const Component* t_member = nullptr;
struct CycleFlag {
  CycleFlag() { t_in_cycle = true; }
  ~CycleFlag() {
    t_in_cycle = false;
    t_member = nullptr;
  }
};

// Voluntary context switches of the calling thread so far: the times it blocked (I/O, a lock, a
// condition variable, a sleep). Allocation-free (one getrusage system call).
std::uint64_t voluntary_switches() {
  rusage u{};
  getrusage(RUSAGE_THREAD, &u);
  return static_cast<std::uint64_t>(u.ru_nvcsw);
}
}  // namespace

bool in_rate_group_cycle() {
  return t_in_cycle;
}
const Component* current_cycle_member() {
  return t_member;
}

CycleScope::CycleScope(bool in_cycle, const Component* member) : prev_in_cycle_(t_in_cycle), prev_member_(t_member) {
  t_in_cycle = in_cycle;
  t_member = member;
}

CycleScope::~CycleScope() {
  t_in_cycle = prev_in_cycle_;
  t_member = prev_member_;
}

RateGroup::RateGroup(RateGroupConfig cfg, std::vector<Component*> members)
    : cfg_(std::move(cfg)), members_(std::move(members)) {
  if (cfg_.period <= 0) throw std::invalid_argument("rate group '" + cfg_.name + "': period must be > 0");
}

void RateGroup::reset(TimeNs start) {
  next_release_ = start + cfg_.offset;
  slip_horizon_ = next_release_;
  sched_end_ = 0;
  own_end_ = 0;
}

void RateGroup::run_cycle(Clock& clock) {
  const CycleFlag flag;
  const TimeNs release = next_release_;
  const TimeNs period = cfg_.period;
  const bool sim = clock.simulated();
  const TimeNs start = clock.now();
  wakeup_.record(start - release);
  last_release_.store(release, std::memory_order_relaxed);

  // On a real clock, for stalls: the thread's blocking waits over the cycle, and the CPU time its
  // steps took on this thread (read where each member's CPU is read anyway).
  const std::uint64_t waits0 = sim ? 0 : voluntary_switches();
  TimeNs step_cpu = 0;

  CycleInfo info{release, start, period, cycles_.load(std::memory_order_relaxed)};
  for (Component* m : members_) {
    const TimeNs t0 = clock.now();
    const TimeNs w0 = sim ? monotonic_now() : t0;
    const TimeNs c0 = thread_cpu_now(), k0 = m->worker_cpu_ns();
    info.now = t0;
    t_member = m;
    m->step(info);
    t_member = nullptr;
    const TimeNs t1 = clock.now();
    const TimeNs c1 = thread_cpu_now();
    step_cpu += c1 - c0;
    m->cpu_.record(c1 - c0 + m->worker_cpu_ns() - k0);
    m->exec_.record(t1 - t0);
    m->wall_.record(sim ? monotonic_now() - w0 : t1 - t0);
    m->heartbeat_.fetch_add(1, std::memory_order_relaxed);
  }
  const TimeNs end = clock.now();
  const TimeNs duration = end - start;
  cycle_exec_.record(duration);
  cycles_.fetch_add(1, std::memory_order_relaxed);
  // Stall: wall time of the cycle beyond the thread's CPU time while no step blocked, i.e. the
  // thread was runnable but off the CPU (preempted by another thread, or the host descheduled the
  // virtual CPU: neither moves the thread's CPU clock). A step that blocked (a voluntary context
  // switch: I/O, a lock, waiting on a worker pool) gets no such credit: waiting inside a cycle is
  // the member's own doing. Under the simulated clock time passes only as the members model it.
  TimeNs stall = 0;
  if (!sim && voluntary_switches() == waits0) stall = std::clamp<TimeNs>(duration - step_cpu, 0, duration);

  // Missed releases: release + j*period (j >= 1) that came and went before this cycle ended and
  // were not already counted by an earlier (late) cycle. Split three ways, each part disjoint:
  // - late-start slips: those the cycle would not have missed had every cycle started as soon as
  //   the group let it (its release, or that schedule's previous end): the delay came from
  //   outside the group;
  // - stall slips: of the rest, those it would not have missed had no cycle been stalled either
  //   (above): the CPU was taken from inside a cycle, this one or one it ran into;
  // - own slips: the rest, the members' doing.
  const TimeNs lo = std::max(release, slip_horizon_);
  const auto missed_by = [&](TimeNs until) -> TimeNs {
    if (until <= release + period) return 0;
    return std::max<TimeNs>(0, (until - 1 - release) / period - ((lo - release) / period + 1) + 1);
  };
  sched_end_ = std::max(release, sched_end_) + duration;
  own_end_ = std::max(release, own_end_) + duration - stall;
  const TimeNs missed = missed_by(end);
  if (missed > 0) {
    const TimeNs on_time = std::min(missed, missed_by(sched_end_));
    const TimeNs own = std::min(on_time, missed_by(own_end_));
    // Kept as disjoint counts, so that a reader on another thread always sees each part <= slips.
    own_slips_.fetch_add(static_cast<std::uint64_t>(own), std::memory_order_relaxed);
    stall_slips_.fetch_add(static_cast<std::uint64_t>(on_time - own), std::memory_order_relaxed);
    late_start_slips_.fetch_add(static_cast<std::uint64_t>(missed - on_time), std::memory_order_relaxed);
    slip_horizon_ = release + ((end - 1 - release) / period) * period;
  }

  if (cfg_.overrun == OverrunPolicy::kSkip) {
    const TimeNs elapsed = end - release;
    const TimeNs steps = std::max<TimeNs>(1, (elapsed + period - 1) / period);
    if (steps > 1) skipped_.fetch_add(static_cast<std::uint64_t>(steps - 1), std::memory_order_relaxed);
    next_release_ = release + steps * period;
  } else {
    next_release_ = release + period;
  }
}

RateGroupCounters RateGroup::counters() const {
  RateGroupCounters c;
  c.cycles = cycles_.load(std::memory_order_relaxed);
  c.late_start_slips = late_start_slips_.load(std::memory_order_relaxed);
  c.stall_slips = stall_slips_.load(std::memory_order_relaxed);
  c.slips = own_slips_.load(std::memory_order_relaxed) + c.late_start_slips + c.stall_slips;
  c.skipped = skipped_.load(std::memory_order_relaxed);
  c.last_release = last_release_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace regolith::runtime
