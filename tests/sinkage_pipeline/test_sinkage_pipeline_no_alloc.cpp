// No heap allocation inside rate-group cycles once warm: the whole wheel_sinkage step (frame lease,
// angle interpolation, estimator, channel publish, bench log queue, overlay slot copy) is counted
// by replacing the global operator new (this binary only). The writer thread (log formatting,
// overlay drawing, PNG encoding) runs outside the cycles and may allocate.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "pipeline_util.hpp"
#include "regolith/runtime/rate_group.hpp"

namespace {
std::atomic<std::uint64_t> g_cycle_allocs{0};
std::atomic<bool> g_counting{false};
}  // namespace

// The replacement operators pair malloc/free consistently; GCC 12 cannot see that once it inlines
// them and warns (false positive, same as bench/sinkage).
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

void* operator new(std::size_t n) {
  if (g_counting.load(std::memory_order_relaxed) && regolith::runtime::in_rate_group_cycle()) {
    g_cycle_allocs.fetch_add(1, std::memory_order_relaxed);
  }
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

using namespace regolith;
using namespace regolith::sinkage::testing;

TEST(SinkagePipelineNoAlloc, StepDoesNotAllocateOnceWarm) {
  const auto dir = temp_dir("noalloc");
  std::filesystem::create_directories(dir / "ov");
  const std::string comp = "    transducer_encoders: lvdt\n"
                           "    transducer: z\n"
                           "    filter: median\n"
                           "    log_csv: " + (dir / "log.csv").string() + "\n"
                           "    overlay_dir: " + (dir / "ov").string() + "\n"
                           "    overlay_every: 3\n";
  const std::string lvdt = "    lvdt: {backend: scripted, wheels: [z], speed_rad_s: 0.001}\n";
  // Poor light (adaptive threshold path), fast wheel so that the legs sweep through the window.
  auto app = load(deployment("rate_hz: 10, frames: 30, speed_rad_s: 1.5, sinkage_mm: 25, illumination: poor",
                             comp, lvdt));
  std::atomic<bool> stop{false};
  app->start();
  app->run(from_seconds(0.5), stop);  // warm-up
  g_counting.store(true);
  app->run(from_seconds(2.4), stop);
  g_counting.store(false);
  app->stop();
  EXPECT_EQ(g_cycle_allocs.load(), 0u);
  EXPECT_EQ(probe_samples().size(), 30u);
  std::size_t valid = 0;
  for (const auto& s : probe_samples()) valid += s.result.valid ? 1 : 0;
  EXPECT_GE(valid, 27u);
  EXPECT_EQ(diag(*app, "sinkage", "log_rows"), "30");
  std::filesystem::remove_all(dir);
}

// Positive control: the same probe counts an allocation made by a member inside each cycle.
TEST(SinkagePipelineNoAlloc, ProbeSeesAllocationsInsideCycles) {
  auto app = load(replace(deployment("rate_hz: 10, frames: 4, speed_rad_s: 1.5, sinkage_mm: 25"),
                          "{type: test_sinkage_probe}", "{type: test_sinkage_probe, allocate_each_cycle: true}"));
  std::atomic<bool> stop{false};
  app->start();
  g_cycle_allocs.store(0);
  g_counting.store(true);
  app->run(from_seconds(1.0), stop);  // 20 cycles of the 20 Hz group
  g_counting.store(false);
  app->stop();
  EXPECT_GE(g_cycle_allocs.load(), 20u);
}
