#pragma once
// A pool of worker threads a component makes at configure time (never in step) for data-parallel
// work inside its step (pyramid levels, channels, tiles): regolith::ParallelFor, so the algorithm
// libraries take it without depending on the runtime. A job is handed over under one mutex and
// condition variable; nothing is allocated per job. The workers' CPU time is counted and the rate
// group adds it to the member's CPU, so the summary shows what a member costs across its workers.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <pthread.h>
#include <sched.h>

#include "regolith/core/parallel.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"

namespace regolith::runtime {

class Component;

class WorkerPool final : public ParallelFor {
 public:
  /// `threads` >= 1 threads run jobs: the caller of run() and threads - 1 workers started here.
  /// The workers take the scheduling policy and priority of the thread of the first run() (the
  /// rate group's: SCHED_FIFO with its priority when the group has one); CPU affinity is not
  /// copied (a group pinned to one CPU would put its workers on that CPU too).
  /// `name` (<= 15 characters are kept) names the workers for top / ps ("sams/w1", ...).
  /// Throws std::invalid_argument for threads < 1 or > 64.
  explicit WorkerPool(int threads, const char* name = "worker");
  ~WorkerPool() override;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(int n, void (*fn)(void*, int), void* ctx) override;
  int threads() const override { return static_cast<int>(workers_.size()) + 1; }

  /// CPU time the workers spent in jobs so far (CLOCK_THREAD_CPUTIME_ID), ns.
  TimeNs worker_cpu_ns() const { return worker_cpu_.load(std::memory_order_relaxed); }
  /// Jobs (calls of fn) run by the workers so far (the caller's are not counted).
  std::uint64_t worker_jobs() const { return worker_jobs_.load(std::memory_order_relaxed); }

 private:
  void worker_main(int index);
  void take_jobs(bool worker);

  std::vector<std::thread> workers_;
  std::mutex run_mutex_;  // one run() at a time
  std::mutex m_;
  std::condition_variable start_cv_, done_cv_;
  std::uint64_t generation_ = 0;  // guarded by m_
  int busy_ = 0;                  // workers still in the current job (guarded by m_)
  bool stop_ = false;             // guarded by m_
  void (*fn_)(void*, int) = nullptr;
  void* ctx_ = nullptr;
  int n_ = 0;
  bool caller_in_cycle_ = false;  // the caller's cycle scope, taken over by the workers
  // Scheduling of the first run()'s caller (the rate group's thread), taken over by the workers
  // before their first job (guarded by m_; read by a worker after it wakes under m_).
  int policy_ = 0;
  sched_param sched_{};
  bool have_policy_ = false;
  const Component* caller_member_ = nullptr;
  std::atomic<int> next_{0};
  std::atomic<TimeNs> worker_cpu_{0};
  std::atomic<std::uint64_t> worker_jobs_{0};
};

/// Reads a component's `threads` key (default 1 = only the rate group's thread; at most 16): the
/// threads its step may use for data-parallel work, its own included. Returns the pool (made
/// now, at configure time) when threads > 1, else nullptr. `name` names the workers.
std::unique_ptr<WorkerPool> workers_from(Params& p, const std::string& name);

}  // namespace regolith::runtime
