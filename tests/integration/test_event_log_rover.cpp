// The event log on the mocked rover (embedded config/mock_rover.yaml, simulated time): the hub
// camera is wrapped in the fault-injection decorator (down after 20 frames for 15 frames' worth
// of time); the application logs, off the cycles, exactly one error when it faults and one
// recovery when it streams again, with the consumer's stale input in between.
#include <algorithm>
#include <atomic>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include "cli_support.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/runtime/application.hpp"

using namespace regolith;

namespace {

/// The embedded mocked rover with its hub camera under `inner:` of a fault_injection device with
/// `faults` (YAML lines indented by six spaces).
std::string mock_rover_with_faulty_hub_camera(const std::string& faults) {
  std::string yaml = cli::embedded_mock_rover();
  const std::string from = "    wheel_cam: &wheel_scene";
  const auto at = yaml.find(from);
  EXPECT_NE(at, std::string::npos);
  if (at == std::string::npos) return yaml;
  // Re-indent the hub camera's block under `inner:` of a fault_injection device.
  const auto end = yaml.find("\n    front:", at);
  std::string block = yaml.substr(at + from.size(), end - at - from.size());
  std::string indented;
  for (std::size_t i = 0; i < block.size(); ++i) {
    indented += block[i];
    if (block[i] == '\n') indented += "    ";
  }
  yaml.replace(at, end - at,
               "    wheel_cam:\n      backend: fault_injection\n" + faults + "      inner: &wheel_scene" + indented);
  return yaml;
}

/// The log lines of a 10 s simulated run of `yaml` that name `camera` / `component`.
struct Events {
  std::vector<std::string> camera, component;
};
Events run_and_log(const std::string& yaml, const std::string& camera, const std::string& component,
                   hal::CameraStats* stats = nullptr) {
  auto ring = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
  spdlog::default_logger()->sinks().push_back(ring);
  {
    auto app = runtime::Application::load(Params::load_string(yaml, "fault_rover.yaml"),
                                          {.sim_time = true, .enable_dds = false});
    std::atomic<bool> stop{false};
    app->start();
    app->run(10 * kNsPerSec, stop);
    app->stop();
    if (stats != nullptr) *stats = app->context().find<hal::Camera>(camera)->stats();
  }
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::remove(sinks.begin(), sinks.end(), ring), sinks.end());
  Events ev;
  for (const auto& line : ring->last_formatted()) {
    const auto level = line.find("] [", line.find("] [") + 3);
    if (line.find("camera " + camera) != std::string::npos) ev.camera.push_back(line.substr(level + 1));
    if (line.find("component " + component) != std::string::npos) ev.component.push_back(line.substr(level + 1));
  }
  return ev;
}

}  // namespace

TEST(EventLog, MockRoverCameraFaultAndRecoveryAreLoggedOnce) {
  cli::register_everything();
  const Events ev =
      run_and_log(mock_rover_with_faulty_hub_camera("      disconnect_after: 20\n      reconnect_after: 15\n"),
                  "wheel_cam", "wheel_sinkage");
  // The camera's own events exactly once each, in order; the consumer's stale input in between
  // (other components may add events of their own when a mock renderer thread falls behind on a
  // loaded machine: those are not asserted).
  const auto& camera = ev.camera;
  const auto& sinkage = ev.component;
  ASSERT_EQ(camera.size(), 2u) << ::testing::PrintToString(camera);
  EXPECT_NE(camera[0].find("[error] camera wheel_cam: faulted"), std::string::npos) << camera[0];
  EXPECT_NE(camera[1].find("[info] camera wheel_cam: recovered (streaming)"), std::string::npos) << camera[1];
  ASSERT_GE(sinkage.size(), 2u) << ::testing::PrintToString(sinkage);
  EXPECT_NE(sinkage.front().find("[warning] component wheel_sinkage: stale input"), std::string::npos)
      << sinkage.front();
  EXPECT_NE(sinkage.back().find("[info] component wheel_sinkage: recovered (ok)"), std::string::npos) << sinkage.back();
}

TEST(EventLog, ACameraClockSteppingForwardIsWithheldCountedAndLogged) {
  // The hub camera's clock runs 60 s ahead for frames 20..34 (1.5 s at 10 Hz): the stamp check
  // every camera is read through withholds exactly those 15 frames, the health entry warns once
  // and recovers, and the sinkage component sees its camera input go stale meanwhile.
  cli::register_everything();
  hal::CameraStats st;
  const Events ev =
      run_and_log(mock_rover_with_faulty_hub_camera(
                      "      stamp_step_after: 20\n      stamp_step_for: 15\n      stamp_step_ms: 60000\n"),
                  "wheel_cam", "wheel_sinkage", &st);
  EXPECT_EQ(st.bad_stamps, 15u);
  EXPECT_EQ(st.stamp_steps, 0u);
  ASSERT_EQ(ev.camera.size(), 2u) << ::testing::PrintToString(ev.camera);
  EXPECT_NE(ev.camera[0].find(
                "[warning] camera wheel_cam: frames stamped in the future withheld since last report (device clock)"),
            std::string::npos)
      << ev.camera[0];
  EXPECT_NE(ev.camera[1].find("[info] camera wheel_cam: recovered (streaming)"), std::string::npos) << ev.camera[1];
  ASSERT_GE(ev.component.size(), 2u) << ::testing::PrintToString(ev.component);
  EXPECT_NE(ev.component.front().find("[warning] component wheel_sinkage: stale input"), std::string::npos)
      << ev.component.front();
  EXPECT_NE(ev.component.back().find("[info] component wheel_sinkage: recovered (ok)"), std::string::npos)
      << ev.component.back();
}
