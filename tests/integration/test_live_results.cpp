// The live summary's per-component results and CPU times on the mocked rover (embedded
// config/mock_rover.yaml, simulated time): every perception component reports its latest output,
// and the numbers agree with the mock scenes' ground truth.
#include <atomic>
#include <cstdio>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "cli_support.hpp"
#include "regolith/runtime/application.hpp"

using namespace regolith;

TEST(LiveResults, MockRoverComponentsReportTheirLatestOutput) {
  cli::register_everything();
  auto app =
      runtime::Application::load(Params::load_string(cli::embedded_mock_rover(), "<embedded>/config/mock_rover.yaml"),
                                 {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(6 * kNsPerSec, stop);
  app->stop();
  std::map<std::string, std::string> result;
  for (const auto* c : app->view().components) {
    result[c->name()] = c->result();
    std::printf("%-16s %s\n", c->name().c_str(), c->result().c_str());
    // CPU time is measured on every step, and a step cannot use more CPU than wall time (+ clock
    // granularity).
    EXPECT_EQ(c->cpu().summary().count, c->heartbeat()) << c->name();
    EXPECT_LE(static_cast<double>(c->cpu().summary().mean), static_cast<double>(c->wall().summary().mean) * 1.25 + 2e4)
        << c->name();
  }
  // Truth of the mock scenes: 20 mm wheel sinkage; soil k = 5e5 N/m^3 (n = 1).
  double mm = 0, conf = 0;
  ASSERT_EQ(std::sscanf(result["wheel_sinkage"].c_str(), "sinkage %lf mm (conf %lf)", &mm, &conf), 2)
      << result["wheel_sinkage"];
  EXPECT_NEAR(mm, 20.0, 1.0);
  double k = 0, n = 0;
  ASSERT_EQ(std::sscanf(result["soil"].c_str(), "k %lf n %lf", &k, &n), 2) << result["soil"];
  EXPECT_NEAR(k / 5e5, 1.0, 0.15);
  unsigned rocks = 0;
  ASSERT_EQ(std::sscanf(result["sams"].c_str(), "rocks %u", &rocks), 1) << result["sams"];
  EXPECT_GT(rocks, 0u);
  double unknown = 0;
  ASSERT_EQ(std::sscanf(result["traversability"].c_str(), "map %lf %% unknown", &unknown), 1)
      << result["traversability"];
  EXPECT_LT(unknown, 50.0);
  // The sfs component solves the quarter level its readers use (320x240 frames -> 80x60): the
  // result speaks of that level, and most of it is valid (it said "0 % valid" of the unsolved
  // full-size mask before 2026-12-02).
  double valid_pct = -1;
  ASSERT_EQ(std::sscanf(result["sfs"].c_str(), "DTM 80x60 (quarter resolution), %lf %% valid", &valid_pct), 1)
      << result["sfs"];
  EXPECT_GT(valid_pct, 50.0) << result["sfs"];
  // terrain_map on the moving mock rover: 6 s at 2 Hz = frames 0..12, every frame after the first
  // tracked by the ground VO, the map growing.
  long frames = 0, vo_ok = 0, vo_failed = 0, keyframes = 0, cells = 0;
  ASSERT_EQ(std::sscanf(result["terrain_map"].c_str(),
                        "map %ld frames (VO %ld ok / %ld failed, %ld keyframes), %ld cells known", &frames, &vo_ok,
                        &vo_failed, &keyframes, &cells),
            5)
      << result["terrain_map"];
  EXPECT_EQ(frames, 13);
  EXPECT_EQ(vo_ok + vo_failed, frames - 1);
  EXPECT_GE(vo_ok, 10);
  EXPECT_GE(keyframes, 1);
  EXPECT_GT(cells, 1000);
  EXPECT_TRUE(result["health"].empty());  // not a perception component
}
