// Heap allocations per rate-group cycle of the mocked rover after warm-up (goal and expectation:
// 0). Every operator new is counted; those made on a thread inside a rate-group cycle are counted
// separately. The peer in the same run is the configure + warm-up phase of the same deployment.
#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "cli.hpp"
#include "regolith/runtime/application.hpp"

namespace {
std::atomic<std::uint64_t> g_all{0};
std::atomic<std::uint64_t> g_in_cycle{0};
}  // namespace

void* operator new(std::size_t n) {
  g_all.fetch_add(1, std::memory_order_relaxed);
  if (regolith::runtime::in_rate_group_cycle()) g_in_cycle.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace regolith;

namespace {

std::uint64_t total_cycles(const runtime::Application& app) {
  std::uint64_t n = 0;
  for (const auto* g : app.view().groups) n += g->counters().cycles;
  return n;
}

void BM_MockRoverSteadyState(benchmark::State& state) {
  cli::register_everything();
  for (auto _ : state) {
    const std::uint64_t before_load = g_in_cycle.load();
    auto app = runtime::Application::load(
        Params::load_string(cli::embedded_mock_rover(), "<embedded>/config/mock_rover.yaml"),
        {.sim_time = true, .enable_dds = true});
    std::atomic<bool> stop{false};
    app->start();
    app->run(5 * kNsPerSec, stop);  // warm-up: first frames size every buffer
    const std::uint64_t warm_cycles = total_cycles(*app);
    const std::uint64_t warm_allocs = g_in_cycle.load() - before_load;
    const std::uint64_t a0 = g_in_cycle.load();
    app->run(30 * kNsPerSec, stop);
    const std::uint64_t steady_allocs = g_in_cycle.load() - a0;
    const std::uint64_t steady_cycles = total_cycles(*app) - warm_cycles;
    app->stop();
    state.counters["warmup_allocs_per_cycle"] =
        warm_cycles ? static_cast<double>(warm_allocs) / static_cast<double>(warm_cycles) : 0.0;
    state.counters["steady_allocs_per_cycle"] =
        steady_cycles ? static_cast<double>(steady_allocs) / static_cast<double>(steady_cycles) : 0.0;
    std::printf("\nmocked rover, simulated time: warm-up %llu allocations in %llu cycles; "
                "steady state %llu allocations in %llu cycles (%.4f per cycle, goal 0)\n",
                static_cast<unsigned long long>(warm_allocs), static_cast<unsigned long long>(warm_cycles),
                static_cast<unsigned long long>(steady_allocs), static_cast<unsigned long long>(steady_cycles),
                steady_cycles ? static_cast<double>(steady_allocs) / static_cast<double>(steady_cycles) : 0.0);
  }
}
BENCHMARK(BM_MockRoverSteadyState)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
