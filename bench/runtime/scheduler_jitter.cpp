// Wake-up latency of a 1 kHz rate group against a bare clock_nanosleep(TIMER_ABSTIME) loop in the
// same run, idle and with the other core loaded. Prints p50 / p99 / max and the ratio of the rate
// group's p99 to the bare loop's (goal: <= 1.2).
#include <benchmark/benchmark.h>
#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <map>
#include <thread>
#include <vector>

#include "regolith/runtime/rate_group.hpp"

using namespace regolith;
using namespace regolith::runtime;

namespace {

constexpr TimeNs kPeriod = kNsPerMs;  // 1 kHz
constexpr int kCycles = 2000;          // 2 s per measurement

struct Percentiles {
  double p50_us = 0, p99_us = 0, max_us = 0;
};
std::map<std::string, Percentiles> g_results;

Percentiles percentiles(std::vector<TimeNs> v) {
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return static_cast<double>(v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))]) / 1e3; };
  return {at(0.5), at(0.99), static_cast<double>(v.back()) / 1e3};
}

// Keeps the other core busy for the duration of a measurement.
class Load {
 public:
  explicit Load(bool on) {
    if (on) thread_ = std::thread([this] {
        volatile std::uint64_t x = 0;
        while (!stop_.load(std::memory_order_relaxed)) x = x + 1;
      });
  }
  ~Load() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

std::vector<TimeNs> bare_loop() {
  std::vector<TimeNs> lat;
  lat.reserve(kCycles);
  TimeNs next = monotonic_now() + kPeriod;
  SystemClock clock;
  for (int i = 0; i < kCycles; ++i) {
    clock.sleep_until(next);
    lat.push_back(monotonic_now() - next);
    next += kPeriod;
  }
  return lat;
}

class Probe final : public Component {
 public:
  void configure(Params&, Context&) override {}
  void step(const CycleInfo& c) override {
    if (n_ < lat_.size()) lat_[n_++] = monotonic_now() - c.release;
  }
  std::vector<TimeNs> lat_ = std::vector<TimeNs>(kCycles);
  std::size_t n_ = 0;
};

std::vector<TimeNs> rate_group_loop() {
  Probe probe;
  RateGroupConfig cfg;
  cfg.name = "jitter";
  cfg.period = kPeriod;
  RateGroup g(cfg, {&probe});
  auto exec = make_realtime_executor();
  std::atomic<bool> stop{false};
  exec->start({&g});
  while (probe.n_ < probe.lat_.size()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  exec->stop();
  return probe.lat_;
}

void record(benchmark::State& state, const std::string& name, const std::vector<TimeNs>& lat) {
  const Percentiles p = percentiles(lat);
  g_results[name] = p;
  state.counters["p50_us"] = p.p50_us;
  state.counters["p99_us"] = p.p99_us;
  state.counters["max_us"] = p.max_us;
}

void BM_BareNanosleep(benchmark::State& state) {
  Load load(state.range(0) != 0);
  for (auto _ : state) record(state, std::string("bare/") + (state.range(0) ? "loaded" : "idle"), bare_loop());
}
void BM_RateGroup(benchmark::State& state) {
  Load load(state.range(0) != 0);
  for (auto _ : state) record(state, std::string("rate_group/") + (state.range(0) ? "loaded" : "idle"), rate_group_loop());
}
BENCHMARK(BM_BareNanosleep)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RateGroup)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  std::printf("\nwake-up latency at 1 kHz, %d cycles each (us):\n", kCycles);
  std::printf("%-10s %-8s %9s %9s %9s\n", "loop", "load", "p50", "p99", "max");
  for (const char* load : {"idle", "loaded"}) {
    for (const char* loop : {"bare", "rate_group"}) {
      const auto it = g_results.find(std::string(loop) + "/" + load);
      if (it == g_results.end()) continue;
      std::printf("%-10s %-8s %9.1f %9.1f %9.1f\n", loop, load, it->second.p50_us, it->second.p99_us, it->second.max_us);
    }
    const auto b = g_results.find(std::string("bare/") + load);
    const auto r = g_results.find(std::string("rate_group/") + load);
    if (b != g_results.end() && r != g_results.end() && b->second.p99_us > 0) {
      std::printf("ratio rate_group/bare p99 (%s): %.2f  (goal <= 1.2)\n", load, r->second.p99_us / b->second.p99_us);
    }
  }
  benchmark::Shutdown();
  return 0;
}
