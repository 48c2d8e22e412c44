#include "regolith/runtime/worker_pool.hpp"

#include <stdexcept>
#include <string>

#include <pthread.h>

#include "regolith/runtime/rate_group.hpp"

namespace regolith::runtime {

WorkerPool::WorkerPool(int threads, const char* name) {
  if (threads < 1 || threads > 64)
    throw std::invalid_argument("worker pool: threads must be in [1, 64] (got " + std::to_string(threads) + ")");
  workers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int i = 1; i < threads; ++i) {
    workers_.emplace_back([this, i] { worker_main(i); });
    const std::string tname = std::string(name).substr(0, 11) + "/w" + std::to_string(i);
    ::pthread_setname_np(workers_.back().native_handle(), tname.substr(0, 15).c_str());
  }
}

WorkerPool::~WorkerPool() {
  {
    const std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  start_cv_.notify_all();
  for (auto& t : workers_) t.join();
}

void WorkerPool::take_jobs(bool worker) {
  std::uint64_t done = 0;
  for (int i = next_.fetch_add(1, std::memory_order_relaxed); i < n_;
       i = next_.fetch_add(1, std::memory_order_relaxed)) {
    fn_(ctx_, i);
    ++done;
  }
  if (worker && done > 0) worker_jobs_.fetch_add(done, std::memory_order_relaxed);
}

void WorkerPool::worker_main(int /*index*/) {
  std::uint64_t seen = 0;
  bool applied = false, have_policy = false;  // the caller's scheduling: taken over / known
  int policy = SCHED_OTHER;
  sched_param sp{};
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(m_);
      start_cv_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
      have_policy = have_policy_;
      policy = policy_;
      sp = sched_;
    }
    if (have_policy && !applied) {
      // The scheduling of the thread that runs the jobs (the rate group's: SCHED_FIFO and its
      // priority when configured), taken over once: a worker must not be preempted by what the
      // group itself outranks. A failure (no permission) was already reported for the group.
      (void)::pthread_setschedparam(::pthread_self(), policy, &sp);
      applied = true;
    }
    const TimeNs c0 = thread_cpu_now();
    {
      const CycleScope scope(caller_in_cycle_, caller_member_);  // the allocation probes see the member
      take_jobs(true);
    }
    worker_cpu_.fetch_add(thread_cpu_now() - c0, std::memory_order_relaxed);
    {
      const std::lock_guard<std::mutex> lock(m_);
      if (--busy_ == 0) done_cv_.notify_one();
    }
  }
}

void WorkerPool::run(int n, void (*fn)(void*, int), void* ctx) {
  if (n <= 0) return;
  const std::lock_guard<std::mutex> one_at_a_time(run_mutex_);
  if (workers_.empty() || n == 1) {
    for (int i = 0; i < n; ++i) fn(ctx, i);
    return;
  }
  if (!have_policy_) {  // only run() writes it, under run_mutex_
    // The first run comes from the thread that will run every job (the rate group's, after its
    // scheduling was applied): its policy and priority are the workers' from now on.
    int policy = SCHED_OTHER;
    sched_param sp{};
    if (::pthread_getschedparam(::pthread_self(), &policy, &sp) == 0) {
      const std::lock_guard<std::mutex> lock(m_);
      policy_ = policy;
      sched_ = sp;
      have_policy_ = true;
    }
  }
  {
    const std::lock_guard<std::mutex> lock(m_);
    fn_ = fn;
    ctx_ = ctx;
    n_ = n;
    caller_in_cycle_ = in_rate_group_cycle();
    caller_member_ = current_cycle_member();
    next_.store(0, std::memory_order_relaxed);
    busy_ = static_cast<int>(workers_.size());
    ++generation_;
  }
  start_cv_.notify_all();
  take_jobs(false);
  std::unique_lock<std::mutex> lock(m_);
  done_cv_.wait(lock, [&] { return busy_ == 0; });
}

std::unique_ptr<WorkerPool> workers_from(Params& p, const std::string& name) {
  const int threads =
      p.get<int>("threads", 1,
                 {.min = 1,
                  .max = 16,
                  .doc = "threads for the data-parallel work of one step, the rate group's own included "
                         "(workers made at configure; their CPU counts in this member's cpu)"});
  if (threads <= 1) return nullptr;
  return std::make_unique<WorkerPool>(threads, name.c_str());
}

}  // namespace regolith::runtime
