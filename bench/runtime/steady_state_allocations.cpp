// The allocation probe: heap allocations per rate-group cycle of a deployment under the
// simulated clock, after warm-up (goal and expectation: 0), named by the component whose step()
// made them. The peer in the same run is the warm-up phase of the same deployment (first frames
// size every buffer there).
//
//   steady_state_allocations [--config FILE] [--warmup S] [--steady S] [--trace N]
//
// Default: the embedded mocked rover. Exit status 0 when the steady state allocated nothing, 1
// when it did (CTest runs it on every shipped deployment whose devices are all mocks), 2 on a
// usage or deployment error. --trace N prints the call stacks of the first N steady-state
// allocations (addr2line or gdb turn the addresses into lines).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <string>

#include "cli_support.hpp"
#include "regolith/runtime/application.hpp"

// The counting operator new shared with the allocation tests, with the count inside rate-group
// cycles and its attribution to the member that allocated.
#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new

using namespace regolith;

namespace {

std::uint64_t total_cycles(const runtime::Application& app) {
  std::uint64_t n = 0;
  for (const auto* g : app.view().groups) n += g->counters().cycles;
  return n;
}

int usage(const char* why) {
  std::fprintf(stderr,
               "steady_state_allocations: %s\n"
               "usage: steady_state_allocations [--config FILE] [--warmup S] [--steady S] [--trace N]\n",
               why);
  return 2;
}

bool parse_seconds(const char* text, double& out) {
  char* end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0' && out > 0.0 && out <= 86400.0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string config;  // empty: the embedded mocked rover
  double warmup_s = 5.0, steady_s = 30.0;
  int trace = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--config" && has_value) {
      config = argv[++i];
    } else if (a == "--warmup" && has_value) {
      if (!parse_seconds(argv[++i], warmup_s)) return usage("--warmup: seconds in (0, 86400]");
    } else if (a == "--steady" && has_value) {
      if (!parse_seconds(argv[++i], steady_s)) return usage("--steady: seconds in (0, 86400]");
    } else if (a == "--trace" && has_value) {
      trace = std::atoi(argv[++i]);
    } else if (a == "-h" || a == "--help") {
      usage("allocation probe");
      return 0;
    } else {
      return usage(("unknown or incomplete argument '" + a + "'").c_str());
    }
  }

  cli::register_everything();
  std::unique_ptr<runtime::Application> app;
  const std::string name = config.empty() ? "<embedded>/config/mock_rover.yaml" : config;
  try {
    const Params p = config.empty() ? Params::load_string(cli::embedded_mock_rover(), name) : Params::load_file(config);
    app = runtime::Application::load(p, {.sim_time = true, .enable_dds = true});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "steady_state_allocations: %s\n", e.what());
    return 2;
  }
  namespace counter = regolith::testing;
  const std::uint64_t before_load = counter::cycle_allocations();
  std::atomic<bool> stop{false};
  app->start();
  app->run(static_cast<TimeNs>(warmup_s * static_cast<double>(kNsPerSec)), stop);
  const std::uint64_t warm_cycles = total_cycles(*app);
  const std::uint64_t warm_allocs = counter::cycle_allocations() - before_load;

  counter::trace_cycle_allocations(trace);
  counter::attribute_cycle_allocations(true);
  const std::uint64_t a0 = counter::cycle_allocations();
  app->run(static_cast<TimeNs>(steady_s * static_cast<double>(kNsPerSec)), stop);
  const std::uint64_t steady_allocs = counter::cycle_allocations() - a0;
  counter::attribute_cycle_allocations(false);
  const std::uint64_t steady_cycles = total_cycles(*app) - warm_cycles;

  auto per_cycle = [](std::uint64_t a, std::uint64_t c) {
    return c ? static_cast<double>(a) / static_cast<double>(c) : 0.0;
  };
  std::printf("%s, simulated time: %zu components in %zu rate groups\n", name.c_str(), app->view().components.size(),
              app->view().groups.size());
  std::printf("  warm-up %.0f s (peer): %llu allocations in %llu cycles (%.2f per cycle)\n", warmup_s,
              static_cast<unsigned long long>(warm_allocs), static_cast<unsigned long long>(warm_cycles),
              per_cycle(warm_allocs, warm_cycles));
  std::printf("  steady  %.0f s: %llu allocations in %llu cycles (%.4f per cycle, goal 0)\n", steady_s,
              static_cast<unsigned long long>(steady_allocs), static_cast<unsigned long long>(steady_cycles),
              per_cycle(steady_allocs, steady_cycles));
  for (const auto* c : app->view().components)
    if (const std::uint64_t n = counter::member_allocations(c); n > 0)
      std::printf("    %-20s %llu allocations in steady state\n", c->name().c_str(),
                  static_cast<unsigned long long>(n));
  if (const std::uint64_t n = counter::unattributed_cycle_allocations(); n > 0)
    std::printf("    (between members)    %llu allocations in steady state\n", static_cast<unsigned long long>(n));
  app->stop();
  if (steady_cycles == 0) {
    std::fprintf(stderr, "steady_state_allocations: %s: no rate-group cycle ran in the steady window\n", name.c_str());
    return 1;
  }
  return steady_allocs == 0 ? 0 : 1;
}
