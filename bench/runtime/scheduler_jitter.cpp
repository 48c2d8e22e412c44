// Wake-up latency of a 1 kHz rate group against a bare clock_nanosleep(TIMER_ABSTIME) loop, idle
// and with the other core loaded. On a shared host the background changes from one second to the
// next, so the two loops are measured in alternating windows (bare, rate group, bare, ...) and
// each is pooled over all its windows: both see the same host. Prints p50 / p99 / max of each
// and the rate group's p50 and p99 as ratios of the bare loop's (goal: p99 ratio <= 1.2), plus
// the median over windows of the per-window p99 ratio (robust to a burst in one window).
//
//   scheduler_jitter [--cycles N (per loop and load, default 100000)] [--window N (default 1000)]
//                    [--idle-only]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "regolith/runtime/rate_group.hpp"

using namespace regolith;
using namespace regolith::runtime;

namespace {

constexpr TimeNs kPeriod = kNsPerMs;  // 1 kHz

double quantile_us(std::vector<TimeNs> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return static_cast<double>(v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))]) / 1e3;
}

// Keeps the other core busy for the duration of a measurement.
class Load {
 public:
  explicit Load(bool on) {
    if (on)
      thread_ = std::thread([this] {
        volatile std::uint64_t x = 0;
        while (!stop_.load(std::memory_order_relaxed)) x = x + 1;
      });
  }
  ~Load() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  Load(const Load&) = delete;
  Load& operator=(const Load&) = delete;

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

void bare_loop(int cycles, std::vector<TimeNs>& out) {
  TimeNs next = monotonic_now() + kPeriod;
  SystemClock clock;
  for (int i = 0; i < cycles; ++i) {
    clock.sleep_until(next);
    out.push_back(monotonic_now() - next);
    next += kPeriod;
  }
}

class Probe final : public Component {
 public:
  explicit Probe(int cycles) : lat_(static_cast<std::size_t>(cycles)) {}
  void configure(Params&, Context&) override {}
  void step(const CycleInfo& c) override {
    const std::size_t i = n_.load(std::memory_order_relaxed);
    if (i < lat_.size()) {
      lat_[i] = monotonic_now() - c.release;
      n_.store(i + 1, std::memory_order_release);
    }
  }
  std::vector<TimeNs> lat_;
  std::atomic<std::size_t> n_{0};
};

void rate_group_loop(int cycles, std::vector<TimeNs>& out) {
  Probe probe(cycles);
  RateGroupConfig cfg;
  cfg.name = "jitter";
  cfg.period = kPeriod;
  RateGroup g(cfg, {&probe});
  auto exec = make_realtime_executor();
  exec->start({&g});
  while (probe.n_.load(std::memory_order_acquire) < probe.lat_.size())
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  exec->stop();
  out.insert(out.end(), probe.lat_.begin(), probe.lat_.end());
}

struct Result {
  std::vector<TimeNs> bare, rate_group;
  std::vector<double> window_p99_ratio;
};

Result alternate(bool loaded, long cycles, int window) {
  const Load load(loaded);
  Result r;
  r.bare.reserve(static_cast<std::size_t>(cycles));
  r.rate_group.reserve(static_cast<std::size_t>(cycles));
  std::vector<TimeNs> wb, wr;
  for (long done = 0; done < cycles; done += window) {
    const int n = static_cast<int>(std::min<long>(window, cycles - done));
    wb.clear();
    wr.clear();
    bare_loop(n, wb);
    rate_group_loop(n, wr);
    r.bare.insert(r.bare.end(), wb.begin(), wb.end());
    r.rate_group.insert(r.rate_group.end(), wr.begin(), wr.end());
    const double b99 = quantile_us(wb, 0.99);
    if (b99 > 0) r.window_p99_ratio.push_back(quantile_us(wr, 0.99) / b99);
  }
  return r;
}

int usage(const char* why) {
  std::fprintf(stderr, "scheduler_jitter: %s\nusage: scheduler_jitter [--cycles N] [--window N] [--idle-only]\n", why);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  long cycles = 100000;
  int window = 1000;
  bool idle_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--cycles" && i + 1 < argc)
      cycles = std::atol(argv[++i]);
    else if (a == "--window" && i + 1 < argc)
      window = std::atoi(argv[++i]);
    else if (a == "--idle-only")
      idle_only = true;
    else
      return usage(("unknown or incomplete argument '" + a + "'").c_str());
  }
  if (cycles < 100 || window < 100 || window > cycles) return usage("need 100 <= --window <= --cycles");
  std::printf("wake-up latency at 1 kHz: %ld cycles per loop and load, in alternating windows of %d (us)\n", cycles,
              window);
  std::printf("%-8s %-11s %9s %9s %9s\n", "load", "loop", "p50", "p99", "max");
  for (const bool loaded : {false, true}) {
    if (loaded && idle_only) break;
    const Result r = alternate(loaded, cycles, window);
    const char* load = loaded ? "loaded" : "idle";
    const double b50 = quantile_us(r.bare, 0.5), b99 = quantile_us(r.bare, 0.99);
    const double g50 = quantile_us(r.rate_group, 0.5), g99 = quantile_us(r.rate_group, 0.99);
    std::printf("%-8s %-11s %9.1f %9.1f %9.1f\n", load, "bare", b50, b99, quantile_us(r.bare, 1.0));
    std::printf("%-8s %-11s %9.1f %9.1f %9.1f\n", load, "rate_group", g50, g99, quantile_us(r.rate_group, 1.0));
    std::vector<double> w = r.window_p99_ratio;
    std::sort(w.begin(), w.end());
    const double wmed = w.empty() ? 0.0 : w[w.size() / 2];
    std::printf("%-8s ratio rate_group/bare: p50 %.2f, p99 %.2f (goal <= 1.2); median of %zu window p99 ratios %.2f\n",
                load, b50 > 0 ? g50 / b50 : 0.0, b99 > 0 ? g99 / b99 : 0.0, w.size(), wmed);
    std::fflush(stdout);
  }
  return 0;
}
