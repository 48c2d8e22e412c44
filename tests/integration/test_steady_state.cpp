// The mocked rover allocates nothing on the heap inside rate-group cycles once warmed up (the
// real-time rule); bench/runtime/steady_state_allocations prints the same figure.
#include <gtest/gtest.h>

#include <execinfo.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "cli.hpp"
#include "regolith/runtime/application.hpp"

namespace {
std::atomic<std::uint64_t> g_in_cycle{0};
// REGOLITH_TRACE_ALLOC=N prints the call stacks of the first N allocations made inside cycles
// after warm-up (debugging aid: `addr2line` or gdb turn the addresses into lines).
std::atomic<bool> g_tracing{false};
std::atomic<int> g_trace_left{0};
}  // namespace

void* operator new(std::size_t n) {
  if (regolith::runtime::in_rate_group_cycle()) {
    g_in_cycle.fetch_add(1, std::memory_order_relaxed);
    if (g_tracing.load(std::memory_order_relaxed) && g_trace_left.fetch_sub(1) > 0) {
      void* frames[24];
      const int depth = backtrace(frames, 24);
      backtrace_symbols_fd(frames, depth, STDERR_FILENO);
      (void)!write(STDERR_FILENO, "----\n", 5);
    }
  }
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace regolith;

TEST(SteadyState, MockRoverAllocatesNothingInCyclesAfterWarmUp) {
  cli::register_everything();
  auto cfg = Params::load_string(cli::embedded_mock_rover(), "<embedded>/config/mock_rover.yaml");
  auto app = runtime::Application::load(cfg, {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(5 * kNsPerSec, stop);
  if (const char* t = std::getenv("REGOLITH_TRACE_ALLOC")) {
    g_trace_left = std::atoi(t);
    g_tracing = true;
  }
  const std::uint64_t before = g_in_cycle.load();
  std::uint64_t cycles_before = 0;
  for (const auto* g : app->view().groups) cycles_before += g->counters().cycles;
  app->run(20 * kNsPerSec, stop);
  std::uint64_t cycles = 0;
  for (const auto* g : app->view().groups) cycles += g->counters().cycles;
  app->stop();
  EXPECT_GT(cycles - cycles_before, 100u);
  EXPECT_EQ(g_in_cycle.load() - before, 0u) << "heap allocations inside rate-group cycles in steady state";
}
