// The event log on the mocked rover (embedded config/mock_rover.yaml, simulated time): the hub
// camera is wrapped in the fault-injection decorator (down after 20 frames for 15 frames' worth
// of time); the application logs, off the cycles, exactly one error when it faults and one
// recovery when it streams again, with the consumer's stale input in between.
#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <string>
#include <vector>

#include "cli.hpp"
#include "regolith/runtime/application.hpp"

using namespace regolith;

TEST(EventLog, MockRoverCameraFaultAndRecoveryAreLoggedOnce) {
  cli::register_everything();
  std::string yaml = cli::embedded_mock_rover();
  const std::string from = "    wheel_cam: &wheel_scene";
  const auto at = yaml.find(from);
  ASSERT_NE(at, std::string::npos);
  // Re-indent the hub camera's block under `inner:` of a fault_injection device.
  const auto end = yaml.find("\n    front:", at);
  std::string block = yaml.substr(at + from.size(), end - at - from.size());
  std::string indented;
  for (std::size_t i = 0; i < block.size(); ++i) {
    indented += block[i];
    if (block[i] == '\n') indented += "    ";
  }
  yaml.replace(at, end - at,
               "    wheel_cam:\n      backend: fault_injection\n      disconnect_after: 20\n      reconnect_after: 15\n"
               "      inner: &wheel_scene" + indented);
  auto ring = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
  spdlog::default_logger()->sinks().push_back(ring);
  {
    auto app = runtime::Application::load(Params::load_string(yaml, "fault_rover.yaml"), {.sim_time = true, .enable_dds = false});
    std::atomic<bool> stop{false};
    app->start();
    app->run(10 * kNsPerSec, stop);
    app->stop();
  }
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::remove(sinks.begin(), sinks.end(), ring), sinks.end());
  // The camera's own events exactly once each, in order; the consumer's stale input in between
  // (other components may add events of their own when a mock renderer thread falls behind on a
  // loaded machine: those are not asserted).
  std::vector<std::string> camera, sinkage;
  for (const auto& line : ring->last_formatted()) {
    const auto level = line.find("] [", line.find("] [") + 3);
    if (line.find("camera wheel_cam") != std::string::npos) camera.push_back(line.substr(level + 1));
    if (line.find("component wheel_sinkage") != std::string::npos) sinkage.push_back(line.substr(level + 1));
  }
  ASSERT_EQ(camera.size(), 2u) << ::testing::PrintToString(camera);
  EXPECT_NE(camera[0].find("[error] camera wheel_cam: faulted"), std::string::npos) << camera[0];
  EXPECT_NE(camera[1].find("[info] camera wheel_cam: recovered (streaming)"), std::string::npos) << camera[1];
  ASSERT_GE(sinkage.size(), 2u) << ::testing::PrintToString(sinkage);
  EXPECT_NE(sinkage.front().find("[warning] component wheel_sinkage: stale input"), std::string::npos) << sinkage.front();
  EXPECT_NE(sinkage.back().find("[info] component wheel_sinkage: recovered (ok)"), std::string::npos) << sinkage.back();
}
