// WorkerPool: every job runs exactly once across the caller and the workers, run() returns only
// when all are done, the workers' CPU is counted and reaches the member's cpu() through the rate
// group, and the pool shuts down cleanly. Labelled `concurrency` (TSan runs it).
#include <atomic>
#include <chrono>
#include <ctime>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include <pthread.h>
#include <sched.h>

#include <gtest/gtest.h>

#include "regolith/core/parallel.hpp"
#include "regolith/runtime/rate_group.hpp"
#include "regolith/runtime/worker_pool.hpp"

using namespace regolith;
using namespace regolith::runtime;

namespace {

void spin_cpu(TimeNs ns) {
  const TimeNs end = thread_cpu_now() + ns;
  while (thread_cpu_now() < end) {
  }
}

}  // namespace

TEST(WorkerPool, EveryJobRunsOnceAndRunReturnsWhenAllAreDone) {
  WorkerPool pool(4, "test");
  EXPECT_EQ(pool.threads(), 4);
  for (int n : {0, 1, 3, 4, 7, 100, 1000}) {
    std::vector<std::atomic<int>> hits(static_cast<std::size_t>(n));
    for (int round = 0; round < 20; ++round) {
      parallel_for(&pool, n, [&](int i) { hits[static_cast<std::size_t>(i)].fetch_add(1); });
    }
    for (int i = 0; i < n; ++i) EXPECT_EQ(hits[static_cast<std::size_t>(i)].load(), 20) << "n " << n << " job " << i;
  }
  // results written by the workers are visible to the caller after run()
  std::vector<int> out(64, 0);
  parallel_for(&pool, 64, [&](int i) { out[static_cast<std::size_t>(i)] = i * i; });
  for (int i = 0; i < 64; ++i) EXPECT_EQ(out[static_cast<std::size_t>(i)], i * i);
}

TEST(WorkerPool, JobsRunOnSeveralThreadsAndTheWorkersCpuIsCounted) {
  WorkerPool pool(3, "test");
  // Two jobs that wait for each other: they can only both finish if two threads run them at
  // once (bounded wait: a scheduler that never wakes a worker fails the test, not hangs it).
  std::atomic<int> started{0};
  std::mutex m;
  std::set<std::thread::id> ids;
  bool met = true;
  parallel_for(&pool, 2, [&](int) {
    started.fetch_add(1);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (started.load() < 2 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
    spin_cpu(2 * kNsPerMs);
    const std::lock_guard<std::mutex> lock(m);
    met = met && started.load() == 2;
    ids.insert(std::this_thread::get_id());
  });
  EXPECT_TRUE(met);
  EXPECT_EQ(ids.size(), 2u);
  EXPECT_GE(pool.worker_jobs(), 1u);
  EXPECT_GE(pool.worker_cpu_ns(), 2 * kNsPerMs);  // the worker's job: at least its 2 ms spin
  EXPECT_THROW(WorkerPool(0), std::invalid_argument);
  EXPECT_THROW(WorkerPool(65), std::invalid_argument);
}

TEST(WorkerPool, OneThreadAndNoPoolRunSeriallyInOrder) {
  WorkerPool one(1);
  std::vector<int> order;
  parallel_for(&one, 5, [&](int i) { order.push_back(i); });
  parallel_for(nullptr, 5, [&](int i) { order.push_back(10 + i); });
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4, 10, 11, 12, 13, 14}));
  EXPECT_EQ(one.worker_jobs(), 0u);
}

namespace {

// A member whose step spreads CPU work over its pool.
class ParallelMember final : public Component {
 public:
  explicit ParallelMember(int threads) : pool_(threads, "member") { use_workers(&pool_); }
  void configure(Params&, Context&) override {}
  void step(const CycleInfo&) override {
    parallel_for(&pool_, 6, [this](int) {
      // every job, on whichever thread, runs in this member's cycle scope (allocation probes)
      if (!in_rate_group_cycle() || current_cycle_member() != this) scope_lost_.store(true);
      spin_cpu(1 * kNsPerMs);
    });
  }
  WorkerPool pool_;
  std::atomic<bool> scope_lost_{false};
};

}  // namespace

TEST(WorkerPool, TheRateGroupCountsTheWorkersCpuInTheMembersCpu) {
  SimClock clock(kNsPerSec);
  ParallelMember member(3);
  RateGroupConfig c;
  c.name = "g";
  c.period = 100 * kNsPerMs;
  RateGroup g(c, {&member});
  auto exec = make_sim_executor(clock);
  std::atomic<bool> stop{false};
  exec->start({&g});
  exec->run_until(clock.now() + 900 * kNsPerMs, stop);  // 10 cycles
  const auto s = member.cpu().summary();
  ASSERT_EQ(s.count, 10u);
  // 6 jobs x 1 ms CPU per step, whichever thread ran them (the caller's share alone is less
  // whenever a worker took a job)
  EXPECT_GE(s.mean, 6 * kNsPerMs - kNsPerMs / 10) << "mean CPU per step " << s.mean << " ns";
  EXPECT_GT(member.worker_cpu_ns(), 0);
  EXPECT_FALSE(member.scope_lost_.load());
}

TEST(WorkerPool, WorkersTakeTheSchedulingOfTheThreadThatRunsTheJobs) {
  // The rate group's thread runs with SCHED_FIFO and a priority on a rover; its workers must too.
  // SCHED_BATCH stands in for it here (no privilege needed): the caller switches to it before the
  // first run, and every job - the caller's and the workers' - sees it.
  WorkerPool pool(3, "sched");
  std::vector<int> policies;
  std::set<std::thread::id> ids;
  std::thread group([&] {
    sched_param sp{};
    ASSERT_EQ(pthread_setschedparam(pthread_self(), SCHED_BATCH, &sp), 0);
    for (int round = 0; round < 3; ++round) {
      std::atomic<int> started{0};
      std::mutex m;
      parallel_for(&pool, 3, [&](int) {
        started.fetch_add(1);
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (started.load() < 3 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
        const std::lock_guard<std::mutex> lock(m);
        policies.push_back(sched_getscheduler(0));
        ids.insert(std::this_thread::get_id());
      });
    }
  });
  group.join();
  EXPECT_EQ(ids.size(), 3u);  // the caller and both workers ran jobs
  ASSERT_EQ(policies.size(), 9u);
  for (int p : policies) EXPECT_EQ(p, SCHED_BATCH);
}
