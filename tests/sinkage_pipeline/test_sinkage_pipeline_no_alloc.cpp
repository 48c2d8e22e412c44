// No heap allocation inside rate-group cycles once warm: the whole wheel_sinkage step (frame lease,
// angle interpolation, estimator, channel publish, bench log queue, overlay slot copy) is counted
// by replacing the global operator new (this binary only). The writer thread (log formatting,
// overlay drawing, PNG encoding) runs outside the cycles and may allocate.
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "pipeline_util.hpp"
#include "regolith/runtime/rate_group.hpp"

#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new

using namespace regolith;
using namespace regolith::sinkage::testing;

TEST(SinkagePipelineNoAlloc, StepDoesNotAllocateOnceWarm) {
  const regolith::testing::TempDir tmp("sinkage_pipeline_noalloc");
  const std::filesystem::path& dir = tmp.path();
  std::filesystem::create_directories(dir / "ov");
  const std::string comp =
      "    transducer_encoders: lvdt\n"
      "    transducer: z\n"
      "    filter: median\n"
      "    log_csv: " +
      (dir / "log.csv").string() +
      "\n"
      "    overlay_dir: " +
      (dir / "ov").string() +
      "\n"
      "    overlay_every: 3\n";
  const std::string lvdt = "    lvdt: {backend: scripted, wheels: [z], speed_rad_s: 0.001}\n";
  // Poor light (adaptive threshold path), fast wheel so that the legs sweep through the window.
  auto app =
      load(deployment("rate_hz: 10, frames: 30, speed_rad_s: 1.5, sinkage_mm: 25, illumination: poor", comp, lvdt));
  std::atomic<bool> stop{false};
  app->start();
  app->run(from_seconds(0.5), stop);  // warm-up
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  app->run(from_seconds(2.4), stop);
  const std::uint64_t allocs = regolith::testing::cycle_allocations() - a0;
  app->stop();
  EXPECT_EQ(allocs, 0u);
  EXPECT_EQ(probe_samples().size(), 30u);
  std::size_t valid = 0;
  for (const auto& s : probe_samples()) valid += s.result.valid ? 1 : 0;
  EXPECT_GE(valid, 27u);
  EXPECT_EQ(diagnostic(*app, "sinkage", "log_rows"), "30");
}

// Positive control: the same probe counts an allocation made by a member inside each cycle.
TEST(SinkagePipelineNoAlloc, ProbeSeesAllocationsInsideCycles) {
  auto app = load(replace(deployment("rate_hz: 10, frames: 4, speed_rad_s: 1.5, sinkage_mm: 25"),
                          "{type: test_sinkage_probe}", "{type: test_sinkage_probe, allocate_each_cycle: true}"));
  std::atomic<bool> stop{false};
  app->start();
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  app->run(from_seconds(1.0), stop);  // 20 cycles of the 20 Hz group
  const std::uint64_t allocs = regolith::testing::cycle_allocations() - a0;
  app->stop();
  EXPECT_GE(allocs, 20u);
}
