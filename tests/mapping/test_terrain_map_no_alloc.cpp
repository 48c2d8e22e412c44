// The terrain_map component allocates nothing on the heap inside rate-group cycles once running,
// with DDS on (odom, odom/wheel and the grid map are copied into pre-allocated outbox samples):
// global operator new is counted on the rate-group threads in this binary.
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <new>
#include <sstream>

#include <gtest/gtest.h>

#include "cli_support.hpp"
#include "regolith/mapping/component.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/rate_group.hpp"
#include "temp_dir.hpp"
#include "test_domain.hpp"

#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new

using namespace regolith;

TEST(TerrainMapNoAlloc, StepsAllocateNothingOnceRunningWithDds) {
  setenv("CYCLONEDDS_URI", "file://" REGOLITH_DDS_LOOPBACK_XML, 1);
  cli::register_everything();
  std::string yaml =
      regolith::testing::read_file(std::string(REGOLITH_SOURCE_DIR) + "/tests/mapping/terrain_map_test.yaml");
  // A namespace and domain of its own.
  const std::string ns = "namespace: maptest";
  yaml.replace(yaml.find(ns), ns.size(), "namespace: noalloc" + std::to_string(getpid()));
  const std::string dom = "domain: 0";
  yaml.replace(yaml.find(dom), dom.size(), "domain: " + std::to_string(regolith::testing::test_domain()));
  // Rocks enough that the map reports some (terrain/world_rocks published with rocks in it).
  const std::string ground = "fractal_rms_m: 0.003";
  yaml.replace(yaml.find(ground), ground.size(), "fractal_rms_m: 0.003\n      rocks_per_m2: 0.6\n     ");
  auto app = runtime::Application::load(Params::load_string(yaml, "terrain_map_test.yaml"), {.sim_time = true});
  ASSERT_NE(app->dds(), nullptr);
  auto& state = app->context().channel<mapping::TerrainMapState>(mapping::kOdometryChannel);
  std::atomic<bool> stop{false};
  app->start();
  app->run(3 * kNsPerSec, stop);  // warm-up: the mapper's first frames and keyframe size its buffers
  const std::uint64_t before = regolith::testing::cycle_allocations();
  const auto frames_before = state.acquire()->counters.frames;
  app->run(12 * kNsPerSec, stop);
  const auto l = state.acquire();
  app->stop();
  EXPECT_GE(l->counters.frames - frames_before, 20);  // frames mapped while counting
  EXPECT_GE(l->map_updates, 10);                      // map layers derived and published
  EXPECT_GT(l->counters.keyframes, 1);
  EXPECT_GE(l->rocks, 1);  // measured 5 at the end of the drive
  EXPECT_EQ(regolith::testing::cycle_allocations() - before, 0u) << "heap allocations inside terrain_map cycles";
}
