// Simulated time waits for devices that produce their output on a thread of their own: the
// mocked rover's front camera ray-casts its frames in the background, and lockstep runs several
// times faster than real time. Without the wait the vision components saw late frames after
// ~20 s of simulated time ("stale input" flapping, 42 of 121 frames used in 60 s).
#include <atomic>

#include <gtest/gtest.h>

#include "cli_support.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/runtime/application.hpp"

using namespace regolith;

TEST(SimTimeDevices, TheMockRoverUsesEveryRenderedFrameInLockstep) {
  cli::register_everything();
  auto cfg = Params::load_string(cli::embedded_mock_rover(), "<embedded>/config/mock_rover.yaml");
  auto app = runtime::Application::load(cfg, {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(40 * kNsPerSec, stop);
  app->stop();
  const auto* front = app->context().find<hal::Camera>("front");
  ASSERT_NE(front, nullptr);
  EXPECT_EQ(front->stats().frames, 81u);  // 2 Hz for 40 s, both ends inclusive
  for (const auto* c : app->view().components) {
    std::uint64_t stale = 0;
    for (const auto& in : c->inputs()) stale += in->stale_cycles.load();
    // Not even in the first report, before any frame: an input that never had one is stale only
    // once its timeout has passed since the start (it was 1 for every camera-fed component).
    EXPECT_EQ(stale, 0u) << c->name();
  }
}
