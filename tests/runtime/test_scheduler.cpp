// Rate groups under the simulated clock: periods, member order, exact slip counts, skip vs
// catch-up, statistics. Members model their execution time by advancing the simulated clock.
#include <algorithm>
#include <atomic>
#include <vector>

#include <time.h>

#include <gtest/gtest.h>

#include "regolith/runtime/rate_group.hpp"

using namespace regolith;
using namespace regolith::runtime;

namespace {

struct Trace {
  std::vector<std::pair<std::string, TimeNs>> steps;  // (member, release)
};

class CostMember final : public Component {
 public:
  CostMember(std::string n, SimClock& clock, Trace& trace) : label_(std::move(n)), clock_(clock), trace_(trace) {}
  void configure(Params&, Context&) override {}
  void step(const CycleInfo& c) override {
    seen_self_ = seen_self_ && in_rate_group_cycle() && current_cycle_member() == this;
    trace_.steps.emplace_back(label_, c.release);
    TimeNs cost = cost_;
    if (!costs_.empty()) cost = costs_[std::min(calls_, costs_.size() - 1)];
    ++calls_;
    clock_.advance(cost);
  }
  TimeNs cost_ = 0;
  std::vector<TimeNs> costs_;  // per call; last one repeats
  std::size_t calls_ = 0;
  bool seen_self_ = true;  // every step saw itself as the current member, inside a cycle

 private:
  std::string label_;
  SimClock& clock_;
  Trace& trace_;
};

constexpr TimeNs kMs = kNsPerMs;

struct Rig {
  SimClock clock{1000 * kMs};
  Trace trace;
  std::vector<std::unique_ptr<CostMember>> members;
  std::vector<std::unique_ptr<RateGroup>> groups;
  std::unique_ptr<Executor> exec = make_sim_executor(clock);
  std::atomic<bool> stop{false};

  CostMember& member(const std::string& n) {
    members.push_back(std::make_unique<CostMember>(n, clock, trace));
    return *members.back();
  }
  RateGroup& group(const std::string& n, TimeNs period, std::vector<Component*> m,
                   OverrunPolicy p = OverrunPolicy::kSkip) {
    RateGroupConfig c;
    c.name = n;
    c.period = period;
    c.overrun = p;
    groups.push_back(std::make_unique<RateGroup>(c, std::move(m)));
    return *groups.back();
  }
  void run_for(TimeNs d) {
    std::vector<RateGroup*> g;
    for (auto& x : groups) g.push_back(x.get());
    exec->start(g);
    exec->run_until(clock.now() + d, stop);
  }
};

}  // namespace

TEST(Scheduler, RunsEachGroupAtItsPeriodAndMembersInOrder) {
  Rig r;
  auto& a = r.member("a");
  auto& b = r.member("b");
  auto& slow = r.member("slow");
  r.group("fast", 10 * kMs, {&a, &b});
  r.group("slow", 50 * kMs, {&slow});
  r.run_for(100 * kMs);  // releases at 0,10,...,100 (inclusive end) and 0,50,100

  int n_a = 0, n_slow = 0;
  for (std::size_t i = 0; i < r.trace.steps.size(); ++i) {
    if (r.trace.steps[i].first == "a") {
      ++n_a;
      ASSERT_LT(i + 1, r.trace.steps.size());
      EXPECT_EQ(r.trace.steps[i + 1].first, "b") << "members run in configured order";
      EXPECT_EQ(r.trace.steps[i + 1].second, r.trace.steps[i].second);
    }
    if (r.trace.steps[i].first == "slow") ++n_slow;
  }
  EXPECT_EQ(n_a, 11);
  EXPECT_EQ(n_slow, 3);
  // Releases are exact multiples of the period from the start.
  TimeNs expect = 1000 * kMs;
  for (const auto& [m, rel] : r.trace.steps) {
    if (m != "a") continue;
    EXPECT_EQ(rel, expect);
    expect += 10 * kMs;
  }
  EXPECT_EQ(r.groups[0]->counters().slips, 0u);
  EXPECT_EQ(r.groups[0]->counters().cycles, 11u);
  // What the allocation probes read: inside each step the member itself, outside nothing.
  for (const auto& m : r.members) EXPECT_TRUE(m->seen_self_);
  EXPECT_FALSE(in_rate_group_cycle());
  EXPECT_EQ(current_cycle_member(), nullptr);
}

class SlipTest : public ::testing::TestWithParam<int> {};

TEST_P(SlipTest, OverrunByKPeriodsIsExactlyKSlips) {
  const int k = GetParam();
  for (OverrunPolicy policy : {OverrunPolicy::kSkip, OverrunPolicy::kCatchUp}) {
    Rig r;
    auto& m = r.member("m");
    // The third cycle lasts k.5 periods: k further releases pass before it ends.
    // Later cycles are short enough that a catch-up burst ends before the next release.
    m.costs_ = {1 * kMs, 1 * kMs, k * 10 * kMs + 5 * kMs, 100 * kNsPerUs};
    r.group("g", 10 * kMs, {&m}, policy);
    r.run_for(300 * kMs);
    EXPECT_EQ(r.groups[0]->counters().slips, static_cast<std::uint64_t>(k))
        << "k=" << k << " policy=" << (policy == OverrunPolicy::kSkip ? "skip" : "catch_up");
  }
}
INSTANTIATE_TEST_SUITE_P(K, SlipTest, ::testing::Values(0, 1, 2, 3, 7));

TEST(Scheduler, SlipsFromALateStartAreToldApartFromOverruns) {
  // Under the simulated executor every group shares one thread: the hog's 35 ms cycle (in its own
  // 50 ms period, never late itself) delays the 10 ms group, whose 1 ms cycles would all fit had
  // they started at their release. Those slips are the fast group's, but none is its own doing.
  Rig r;
  auto& hog = r.member("hog");
  auto& quick = r.member("quick");
  hog.cost_ = 35 * kMs;
  quick.cost_ = 1 * kMs;
  r.group("hog", 50 * kMs, {&hog});
  r.group("fast", 10 * kMs, {&quick});
  r.run_for(500 * kMs);
  const auto h = r.groups[0]->counters(), f = r.groups[1]->counters();
  EXPECT_EQ(h.slips, 0u);
  EXPECT_EQ(h.late_start_slips, 0u);
  EXPECT_GE(f.slips, 20u) << "three releases pass under each of the hog's 11 cycles";
  EXPECT_EQ(f.late_start_slips, f.slips) << "every one from a late start";
}

TEST(Scheduler, AnOverrunThatAlsoStartedLateCountsOnlyTheDelayAsLate) {
  // The fast member costs 8 ms of its 10 ms period: on time it fits; started 5 ms late behind the
  // hog it ends 3 ms past the next release: one slip, a late-start one. Costing 28 ms it misses
  // two releases by itself, whenever it starts: those are overruns, not late starts.
  for (const TimeNs cost : {8 * kMs, 28 * kMs}) {
    Rig r;
    auto& hog = r.member("hog");
    auto& slow = r.member("slow");
    hog.costs_ = {5 * kMs, 0};
    slow.costs_ = {cost, 1 * kMs};
    r.group("hog", 1000 * kMs, {&hog});
    r.group("fast", 10 * kMs, {&slow});
    r.run_for(100 * kMs);
    const auto f = r.groups[1]->counters();
    if (cost == 8 * kMs) {
      EXPECT_EQ(f.slips, 1u);
      EXPECT_EQ(f.late_start_slips, 1u);
    } else {
      EXPECT_EQ(f.slips, 3u) << "started at 5 ms, ended at 33 ms: releases 10, 20 and 30 ms passed";
      EXPECT_EQ(f.late_start_slips, 1u) << "on time it would have ended at 28 ms: two slips; the third is the delay's";
    }
  }
}

TEST(Scheduler, ACatchUpBurstAfterAnOverrunIsTheGroupsOwnDoing) {
  // Catch-up runs the missed releases back to back: those cycles start late because the group's
  // own previous cycle overran, which is no outside delay.
  Rig r;
  auto& m = r.member("m");
  m.costs_ = {25 * kMs, 9 * kMs};  // the burst of 9 ms cycles falls behind before it catches up
  r.group("g", 10 * kMs, {&m}, OverrunPolicy::kCatchUp);
  r.run_for(200 * kMs);
  const auto c = r.groups[0]->counters();
  EXPECT_GE(c.slips, 2u);
  EXPECT_EQ(c.late_start_slips, 0u);
}

namespace {

// A real (not simulated) clock the test moves by hand, so that a cycle's wall time and its
// thread's CPU time can be set apart: a member "stalled" by the host advances it without using
// the CPU, a busy one by the CPU it burned, a blocking one while it sleeps.
class HandClock final : public Clock {
 public:
  TimeNs now() const override { return now_; }
  void sleep_until(TimeNs t) override { now_ = std::max(now_, t); }
  bool simulated() const override { return false; }
  void advance(TimeNs dt) { now_ += dt; }

 private:
  TimeNs now_ = 1000 * kMs;
};

enum class Kind { kStalled, kBusy, kBlocking };

class HandMember final : public Component {
 public:
  HandMember(HandClock& clock, std::vector<std::pair<Kind, TimeNs>> cycles)
      : clock_(clock), cycles_(std::move(cycles)) {}
  void configure(Params&, Context&) override {}
  void step(const CycleInfo&) override {
    const auto [kind, cost] = cycles_[std::min(calls_++, cycles_.size() - 1)];
    switch (kind) {
      case Kind::kStalled:  // off the CPU without waiting for anything: the host took it
        clock_.advance(cost);
        break;
      case Kind::kBusy: {  // computing: the wall time is the CPU time
        // Burns at least `cost` of CPU and moves the wall clock by `cost`: on a loaded virtual
        // machine a CPU-time reading can jump (time the hypervisor took charged to the thread; a
        // fresh-clone CI under ASan once read 135 ms for this 35 ms loop), which must not move
        // the test's wall clock. CPU >= wall keeps the cycle the member's own doing.
        const TimeNs c0 = thread_cpu_now();
        while (thread_cpu_now() - c0 < cost) {
        }
        clock_.advance(cost);
        break;
      }
      case Kind::kBlocking: {  // waiting on I/O (a voluntary context switch) while time passes
        const timespec nap{0, 200000};
        nanosleep(&nap, nullptr);
        clock_.advance(cost);
        break;
      }
    }
  }

 private:
  HandClock& clock_;
  std::vector<std::pair<Kind, TimeNs>> cycles_;
  std::size_t calls_ = 0;
};

// Runs `n` cycles of `cycles` after a first one that takes no time: the first cycle of a process
// can spend milliseconds of CPU on one-time work (a sanitizer runtime's first interception of the
// CPU clock and getrusage: 10-20 ms once under TSan on a loaded machine), which would read as CPU
// the member used rather than a stall. There it cannot slip.
RateGroupCounters run_by_hand(std::vector<std::pair<Kind, TimeNs>> cycles, int n,
                              OverrunPolicy policy = OverrunPolicy::kSkip) {
  HandClock clock;
  cycles.insert(cycles.begin(), {Kind::kStalled, 0});
  ++n;
  HandMember m(clock, std::move(cycles));
  RateGroupConfig c;
  c.name = "g";
  c.period = 10 * kMs;
  c.overrun = policy;
  RateGroup g(c, {&m});
  g.reset(clock.now());
  for (int i = 0; i < n; ++i) {
    clock.sleep_until(g.next_release());
    g.run_cycle(clock);
  }
  return g.counters();
}

}  // namespace

TEST(Scheduler, AStallMidCycleIsToldApartFromAnOverrunAndFromBlocking) {
  // 35 ms in a 10 ms period: three releases pass, whatever the cause. Off the CPU without waiting
  // (the host descheduled the thread) is no member's doing; computing for 35 ms, or blocking on
  // I/O inside the cycle, is.
  const auto stalled = run_by_hand({{Kind::kStalled, 35 * kMs}, {Kind::kStalled, 0}}, 6);
  EXPECT_EQ(stalled.slips, 3u);
  EXPECT_EQ(stalled.stall_slips, 3u);
  EXPECT_EQ(stalled.late_start_slips, 0u);

  const auto busy = run_by_hand({{Kind::kBusy, 35 * kMs}, {Kind::kStalled, 0}}, 6);
  EXPECT_EQ(busy.slips, 3u);
  EXPECT_EQ(busy.stall_slips, 0u) << "the wall time was the thread's own CPU time";
  EXPECT_EQ(busy.late_start_slips, 0u);

  const auto blocking = run_by_hand({{Kind::kBlocking, 35 * kMs}, {Kind::kStalled, 0}}, 6);
  EXPECT_EQ(blocking.slips, 3u);
  EXPECT_EQ(blocking.stall_slips, 0u) << "a step that blocks inside its cycle gets no credit";
}

TEST(Scheduler, ACatchUpBurstAfterAStallIsTheStallsDoing) {
  // Catch-up after a 25 ms stall: the missed releases run back to back, 8 ms of CPU each. Started
  // on time each would fit; they slip only because the stall pushed them: stall slips, not the
  // member's, however long the burst runs. With the same 25 ms spent computing, the burst is
  // the group's own doing.
  const auto after_stall =
      run_by_hand({{Kind::kStalled, 25 * kMs}, {Kind::kBusy, 8 * kMs}}, 8, OverrunPolicy::kCatchUp);
  EXPECT_GE(after_stall.slips, 3u) << "two releases under the stall, then the burst falls behind";
  EXPECT_EQ(after_stall.stall_slips, after_stall.slips);
  const auto after_overrun = run_by_hand({{Kind::kBusy, 25 * kMs}, {Kind::kBusy, 8 * kMs}}, 8, OverrunPolicy::kCatchUp);
  EXPECT_EQ(after_overrun.slips, after_stall.slips);
  EXPECT_EQ(after_overrun.stall_slips, 0u);
}

TEST(Scheduler, ExactlyOnePeriodIsNotASlip) {
  Rig r;
  auto& m = r.member("m");
  m.cost_ = 10 * kMs;  // ends exactly at the next release
  r.group("g", 10 * kMs, {&m});
  r.run_for(100 * kMs);
  EXPECT_EQ(r.groups[0]->counters().slips, 0u);
  EXPECT_EQ(r.groups[0]->counters().cycles, 11u);
}

TEST(Scheduler, SkipDropsMissedReleasesCatchUpRunsThem) {
  for (OverrunPolicy policy : {OverrunPolicy::kSkip, OverrunPolicy::kCatchUp}) {
    Rig r;
    auto& m = r.member("m");
    m.costs_ = {1 * kMs, 35 * kMs, 1 * kMs};  // second cycle overruns by 3 releases (20, 30, 40 ms)
    r.group("g", 10 * kMs, {&m}, policy);
    r.run_for(100 * kMs);
    const auto c = r.groups[0]->counters();
    EXPECT_EQ(c.slips, 3u);
    std::vector<TimeNs> releases;
    for (const auto& s : r.trace.steps) releases.push_back(s.second - 1000 * kMs);
    if (policy == OverrunPolicy::kSkip) {
      // 0, 10 (ends at 46), next release 50: 20, 30, 40 skipped.
      EXPECT_EQ(c.skipped, 3u);
      EXPECT_EQ(releases,
                (std::vector<TimeNs>{0, 10 * kMs, 50 * kMs, 60 * kMs, 70 * kMs, 80 * kMs, 90 * kMs, 100 * kMs}));
    } else {
      // Every release runs: 20, 30, 40 back to back right after the overrun.
      EXPECT_EQ(c.skipped, 0u);
      EXPECT_EQ(c.cycles, 11u);
      EXPECT_EQ(releases.size(), 11u);
      EXPECT_EQ(releases[2], 20 * kMs);
    }
  }
}

TEST(Scheduler, CatchUpDoesNotCountTheSameReleaseTwice) {
  Rig r;
  auto& m = r.member("m");
  // A long overrun followed by late cycles that each end after the next release would be
  // double-counted by naive accounting.
  m.costs_ = {25 * kMs, 9 * kMs, 9 * kMs, 9 * kMs, 1 * kMs};
  r.group("g", 10 * kMs, {&m}, OverrunPolicy::kCatchUp);
  r.run_for(200 * kMs);
  // Timeline: c0 0..25 (misses 10, 20); c1 starts 25 ends 34 (misses 30); c2 34..43 (40);
  // c3 43..52 (50); c4 (rel 40) 52..53; c5 (rel 50) 53..54; c6 rel 60 on time.
  EXPECT_EQ(r.groups[0]->counters().slips, 5u);
}

TEST(Scheduler, ExecutionStatisticsFromTheHistogram) {
  Rig r;
  auto& m = r.member("m");
  m.costs_.clear();
  for (int i = 1; i <= 100; ++i) m.costs_.push_back(i * kNsPerUs * 10);  // 10 us .. 1 ms
  r.group("g", 10 * kMs, {&m});
  r.run_for(990 * kMs);  // exactly 100 cycles
  const auto s = m.exec().summary();
  EXPECT_EQ(s.count, 100u);
  EXPECT_EQ(s.min, 10 * kNsPerUs);
  EXPECT_EQ(s.max, 1000 * kNsPerUs);
  EXPECT_EQ(s.mean, 505 * kNsPerUs);
  // Histogram resolution is 12.5 %: p50 ~ 500 us, p99 ~ 990 us.
  EXPECT_NEAR(static_cast<double>(s.p50), 500e3, 500e3 * 0.125);
  EXPECT_NEAR(static_cast<double>(s.p99), 990e3, 990e3 * 0.125);
  EXPECT_GE(s.p99, s.p50);
  EXPECT_EQ(m.heartbeat(), 100u);
}

TEST(Scheduler, HistogramBucketsAreMonotonicAndTight) {
  TimeNs prev = -1;
  for (int b = 0; b < 400; ++b) {
    const TimeNs up = ExecHistogram::bucket_upper(b);
    EXPECT_GT(up, prev) << b;
    EXPECT_EQ(ExecHistogram::bucket_of(up), b) << b;
    prev = up;
  }
  for (TimeNs v : {1L, 7L, 8L, 9L, 1000L, 123456789L, 4'000'000'000L}) {
    const int b = ExecHistogram::bucket_of(v);
    EXPECT_LE(v, ExecHistogram::bucket_upper(b));
    EXPECT_LE(static_cast<double>(ExecHistogram::bucket_upper(b) - v), 0.125 * static_cast<double>(v) + 1);
  }
}

TEST(Scheduler, SimulatedRunIsDeterministic) {
  auto run_once = [] {
    Rig r;
    auto& a = r.member("a");
    auto& b = r.member("b");
    a.costs_ = {3 * kMs, 12 * kMs, 1 * kMs};
    b.cost_ = 2 * kMs;
    r.group("x", 10 * kMs, {&a});
    r.group("y", 7 * kMs, {&b}, OverrunPolicy::kCatchUp);
    r.run_for(500 * kMs);
    return r.trace.steps;
  };
  EXPECT_EQ(run_once(), run_once());
}

TEST(Scheduler, RealtimeExecutorRunsAndStops) {
  // Smoke test on the real clock: counts only, no timing assertions.
  Trace trace;
  SimClock unused;
  CostMember m("m", unused, trace);
  RateGroupConfig c;
  c.name = "rt";
  c.period = 1 * kMs;
  RateGroup g(c, {&m});
  auto exec = make_realtime_executor();
  std::atomic<bool> stop{false};
  exec->start({&g});
  exec->run_until(exec->clock().now() + 30 * kMs, stop);
  exec->stop();
  EXPECT_GT(g.counters().cycles, 0u);
  EXPECT_EQ(g.counters().cycles, m.heartbeat());
}

TEST(Scheduler, SimulatedTimeAsksBeforeEveryAdvance) {
  // The application's gate (wait for devices that lag the lockstep clock) is called with every
  // release before the clock reaches it, in order, and never for a time already passed.
  Rig r;
  auto& a = r.member("a");
  auto& s = r.member("s");
  r.group("fast", 10 * kMs, {&a});
  r.group("slow", 25 * kMs, {&s});
  std::vector<TimeNs> asked;
  bool in_order = true;
  r.exec->set_before_advance([&](TimeNs t) {
    in_order = in_order && r.clock.now() <= t && (asked.empty() || asked.back() <= t);
    asked.push_back(t);
  });
  r.run_for(50 * kMs);
  EXPECT_TRUE(in_order);
  ASSERT_EQ(asked.size(), r.trace.steps.size()) << "one question per cycle";
  for (std::size_t i = 0; i < asked.size(); ++i) EXPECT_EQ(asked[i], r.trace.steps[i].second) << i;
}
