// Real-time and simulated-time executors for rate groups.
#include <cerrno>
#include <cstring>
#include <memory>
#include <mutex>
#include <thread>

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <spdlog/spdlog.h>

#include "regolith/runtime/rate_group.hpp"

namespace regolith::runtime {
namespace {

// One clear warning per kind of missing permission, however many threads hit it.
void warn_once(std::once_flag& flag, const std::string& msg) {
  std::call_once(flag, [&] { spdlog::warn("{}", msg); });
}
std::once_flag g_prio_warning, g_affinity_warning, g_mlock_warning;

void apply_thread_settings(const RateGroupConfig& cfg) {
  pthread_setname_np(pthread_self(), ("rg-" + cfg.name).substr(0, 15).c_str());
  if (cfg.priority > 0) {
    sched_param sp{};
    sp.sched_priority = cfg.priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (rc != 0) {
      warn_once(g_prio_warning, std::string("real-time priority (SCHED_FIFO) not permitted: ") + std::strerror(rc) +
                                    "; rate groups run with normal scheduling. Grant it with LimitRTPRIO (systemd), "
                                    "an rtprio entry in /etc/security/limits.conf or CAP_SYS_NICE.");
    }
  }
  if (cfg.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<unsigned>(cfg.cpu), &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    if (rc != 0) {
      warn_once(g_affinity_warning, "CPU affinity for rate group '" + cfg.name + "' (cpu " + std::to_string(cfg.cpu) +
                                        ") failed: " + std::strerror(rc) + "; the thread may run on any CPU.");
    }
  }
}

class RealtimeExecutor final : public Executor {
 public:
  explicit RealtimeExecutor(RealtimeOptions opts) : opts_(opts) {}
  ~RealtimeExecutor() override { stop(); }

  void start(std::vector<RateGroup*> groups) override {
    if (opts_.lock_memory && mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
      warn_once(g_mlock_warning, std::string("mlockall failed: ") + std::strerror(errno) +
                                     "; memory may be paged out. Grant it with LimitMEMLOCK=infinity.");
    }
    stopping_.store(false);
    const TimeNs start = clock_.now();
    for (RateGroup* g : groups) {
      g->reset(start);
      threads_.emplace_back([this, g] { loop(*g); });
    }
  }

  void stop() override {
    stopping_.store(true);
    for (auto& t : threads_) {
      if (t.joinable()) t.join();
    }
    threads_.clear();
  }

  void run_until(TimeNs end, const std::atomic<bool>& stop_flag) override {
    while (!stop_flag.load() && clock_.now() < end) {
      clock_.sleep_until(std::min(end, clock_.now() + 50 * kNsPerMs));
    }
  }

  Clock& clock() override { return clock_; }

 private:
  void loop(RateGroup& g) {
    apply_thread_settings(g.config());
    constexpr TimeNs kStopCheck = 100 * kNsPerMs;  // slow groups still notice stop() promptly
    while (!stopping_.load(std::memory_order_relaxed)) {
      const TimeNs release = g.next_release();
      TimeNs now = clock_.now();
      while (now < release && !stopping_.load(std::memory_order_relaxed)) {
        clock_.sleep_until(std::min(release, now + kStopCheck));
        now = clock_.now();
      }
      if (stopping_.load(std::memory_order_relaxed)) break;
      g.run_cycle(clock_);
    }
  }

  RealtimeOptions opts_;
  SystemClock clock_;
  std::atomic<bool> stopping_{false};
  std::vector<std::thread> threads_;
};

class SimExecutor final : public Executor {
 public:
  explicit SimExecutor(SimClock& clock) : clock_(clock) {}

  void start(std::vector<RateGroup*> groups) override {
    groups_ = std::move(groups);
    for (RateGroup* g : groups_) g->reset(clock_.now());
  }
  void stop() override {}

  void run_until(TimeNs end, const std::atomic<bool>& stop_flag) override {
    while (!stop_flag.load(std::memory_order_relaxed)) {
      // Earliest release first; ties go to the group listed first (deterministic).
      RateGroup* next = nullptr;
      for (RateGroup* g : groups_) {
        if (next == nullptr || g->next_release() < next->next_release()) next = g;
      }
      if (next == nullptr || next->next_release() > end) break;
      if (before_advance_) before_advance_(next->next_release());
      clock_.sleep_until(next->next_release());
      next->run_cycle(clock_);
      if (after_cycle_) after_cycle_();
    }
    clock_.sleep_until(end);
  }

  Clock& clock() override { return clock_; }
  void set_after_cycle(std::function<void()> f) override { after_cycle_ = std::move(f); }
  void set_before_advance(std::function<void(TimeNs)> f) override { before_advance_ = std::move(f); }

 private:
  std::function<void()> after_cycle_;
  std::function<void(TimeNs)> before_advance_;
  SimClock& clock_;
  std::vector<RateGroup*> groups_;
};

}  // namespace

std::unique_ptr<Executor> make_realtime_executor(RealtimeOptions opts) {
  return std::make_unique<RealtimeExecutor>(opts);
}
std::unique_ptr<Executor> make_sim_executor(SimClock& clock) {
  return std::make_unique<SimExecutor>(clock);
}

}  // namespace regolith::runtime
