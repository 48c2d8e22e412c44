#include "regolith/runtime/rate_group.hpp"

#include <algorithm>
#include <ctime>
#include <stdexcept>

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
  prev_end_ = 0;
}

void RateGroup::run_cycle(Clock& clock) {
  const CycleFlag flag;
  const TimeNs release = next_release_;
  const TimeNs period = cfg_.period;
  const bool sim = clock.simulated();
  const TimeNs start = clock.now();
  wakeup_.record(start - release);
  last_release_.store(release, std::memory_order_relaxed);

  CycleInfo info{release, start, period, cycles_.load(std::memory_order_relaxed)};
  for (Component* m : members_) {
    const TimeNs t0 = clock.now();
    const TimeNs w0 = sim ? monotonic_now() : t0;
    const TimeNs c0 = thread_cpu_now() + m->worker_cpu_ns();
    info.now = t0;
    t_member = m;
    m->step(info);
    t_member = nullptr;
    const TimeNs t1 = clock.now();
    m->cpu_.record(thread_cpu_now() + m->worker_cpu_ns() - c0);
    m->exec_.record(t1 - t0);
    m->wall_.record(sim ? monotonic_now() - w0 : t1 - t0);
    m->heartbeat_.fetch_add(1, std::memory_order_relaxed);
  }
  const TimeNs end = clock.now();
  cycle_exec_.record(end - start);
  cycles_.fetch_add(1, std::memory_order_relaxed);

  // Missed releases: release + j*period (j >= 1) that came and went before this cycle ended and
  // were not already counted by an earlier (late) cycle. Those that would not have been missed had
  // the cycle started as soon as the group let it (its release, or its previous cycle's end) are
  // late-start slips: the delay came from outside the group.
  const TimeNs lo = std::max(release, slip_horizon_);
  const auto missed_by = [&](TimeNs until) -> TimeNs {
    if (until <= release + period) return 0;
    return std::max<TimeNs>(0, (until - 1 - release) / period - ((lo - release) / period + 1) + 1);
  };
  const TimeNs missed = missed_by(end);
  if (missed > 0) {
    const TimeNs own_start = std::max(release, prev_end_);
    const TimeNs own = std::min(missed, missed_by(own_start + (end - start)));
    // Kept as two disjoint counts, so that a reader on another thread always sees late <= slips.
    own_slips_.fetch_add(static_cast<std::uint64_t>(own), std::memory_order_relaxed);
    late_start_slips_.fetch_add(static_cast<std::uint64_t>(missed - own), std::memory_order_relaxed);
    slip_horizon_ = release + ((end - 1 - release) / period) * period;
  }
  prev_end_ = end;

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
  c.slips = own_slips_.load(std::memory_order_relaxed) + c.late_start_slips;
  c.skipped = skipped_.load(std::memory_order_relaxed);
  c.last_release = last_release_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace regolith::runtime
