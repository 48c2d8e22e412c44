// The terrain_map component on the moving mock rover (synthetic_drive camera, encoders and IMU),
// under the simulated clock: the corrected pose follows the mock's exact path, the wheels alone
// drift with their slip, the map fills, the counters add up; bad configuration names its field.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_support.hpp"
#include "regolith/core/error.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/stamp_checked_camera.hpp"
#include "regolith/mapping/component.hpp"
#include "regolith/mapping/config.hpp"
#include "regolith/mapping/wheel_odometry.hpp"
#include "regolith/mocks/synthetic_drive.hpp"
#include "regolith/runtime/application.hpp"
#include "temp_dir.hpp"

using namespace regolith;

namespace {

std::string test_yaml() {
  return regolith::testing::read_file(std::string(REGOLITH_SOURCE_DIR) + "/tests/mapping/terrain_map_test.yaml");
}

// The test deployment with `edit` applied to its text (find -> replace, once).
std::string edited(const std::string& find, const std::string& replace) {
  std::string s = test_yaml();
  const auto at = s.find(find);
  EXPECT_NE(at, std::string::npos) << find;
  if (at != std::string::npos) s.replace(at, find.size(), replace);
  return s;
}

std::string load_error(const std::string& yaml) {
  cli::register_everything();
  try {
    // Devices validate their parameters without opening (rendering) anything, as `config check`.
    runtime::Application::load(Params::load_string(yaml, "terrain_map_test.yaml"),
                               {.sim_time = true, .enable_dds = false, .open_devices = false});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return {};
}

// The test deployment with its camera's clock stepping by `step_ms` from frame `after` on, for
// `frames` frames (0: for good): the camera is the fault-injection decorator around the same drive
// the encoders and the IMU read.
std::string with_camera_clock_step(int after, int frames, double step_ms) {
  const std::string s = test_yaml();
  const std::string front = "    front: &drive\n";
  const auto d = s.find("devices:\n"), a = s.find(front), b = s.find("  encoders:\n"), e = s.find("rate_groups:");
  EXPECT_TRUE(d != std::string::npos && a != std::string::npos && b != std::string::npos && e != std::string::npos);
  const std::string drive = s.substr(a + front.size(), b - a - front.size());  // the drive's keys, 6 spaces in
  return s.substr(0, d) + "devices:\n  encoders:\n    wheels: &drive\n" + drive +
         "  imus:\n    body_imu: *drive\n  cameras:\n    front:\n      backend: fault_injection\n" +
         "      stamp_step_after: " + std::to_string(after) + "\n      stamp_step_for: " + std::to_string(frames) +
         "\n      stamp_step_ms: " + std::to_string(step_ms) + "\n      inner: *drive\n" + s.substr(e);
}

}  // namespace

TEST(SkidSteerOdometry, ArcFromWheelAnglesAndHeadingFromTheImu) {
  // Track 0.8 m, radius 0.15 m; a 2 m left arc of radius 4 m: left wheels roll (1 - 0.4/4) x 2 m.
  mapping::SkidSteerOdometry odo({{0.4, 0.15}, {-0.4, 0.15}});
  EXPECT_DOUBLE_EQ(odo.track_width(), 0.8);
  const double r = 4.0, s = 2.0, dyaw = s / r;
  const double left = (1 - 0.4 / r) * s / 0.15, right = (1 + 0.4 / r) * s / 0.15;
  const double zero[2] = {0, 0};
  odo.reset(zero);
  for (int k = 1; k <= 4; ++k) {  // in four steps (constant curvature: exact)
    const double a[2] = {left * k / 4, right * k / 4};
    ASSERT_TRUE(odo.update(a));
  }
  EXPECT_NEAR(odo.pose().x, r * std::sin(dyaw), 1e-9);
  EXPECT_NEAR(odo.pose().y, r * (1 - std::cos(dyaw)), 1e-9);
  EXPECT_NEAR(odo.pose().yaw, dyaw, 1e-12);
  EXPECT_NEAR(odo.distance(), s, 1e-9);
  // Heading from an IMU: equal wheel speeds, the IMU turning 0.1 rad -> an arc, not a line.
  mapping::SkidSteerOdometry imu({{0.4, 0.15}, {-0.4, 0.15}});
  imu.reset(zero, {}, 1.0);
  const double a[2] = {1.0 / 0.15, 1.0 / 0.15};
  ASSERT_TRUE(imu.update(a, 1.1));
  EXPECT_NEAR(imu.pose().yaw, 0.1, 1e-12);
  EXPECT_NEAR(imu.pose().x, 10.0 * std::sin(0.1), 1e-9);
  // A missing angle leaves the pose where it was.
  const double bad[2] = {std::nan(""), 1.0};
  EXPECT_FALSE(imu.update(bad));
  EXPECT_NEAR(imu.pose().yaw, 0.1, 1e-12);
  // Started from a corrupt reading (5274 rad), the first true angles imply a 791 m roll: the
  // odometry re-anchors on them without moving, and follows the wheels from there.
  mapping::SkidSteerOdometry jump({{0.4, 0.15}, {-0.4, 0.15}});
  const double garbage[2] = {5274.8, 0.0};
  jump.reset(garbage);
  const double truth1[2] = {0.0, 0.0}, truth2[2] = {1.0, 1.0};
  EXPECT_FALSE(jump.update(truth1, std::nan(""), 0.5));
  EXPECT_EQ(jump.pose().x, 0.0);
  ASSERT_TRUE(jump.update(truth2, std::nan(""), 0.5));
  EXPECT_NEAR(jump.pose().x, 0.15, 1e-12);
  // Wheels on one side only: the field is named.
  try {
    mapping::SkidSteerOdometry one({{0.4, 0.15}, {0.3, 0.15}});
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_EQ(e.field(), "wheels");
    EXPECT_NE(std::string(e.what()).find("2 left, 0 right"), std::string::npos) << e.what();
  }
}

TEST(SteppedOdometry, SubStepsReadFailuresAndCorruptReadings) {
  // 0.1 m/s on both wheels (r 0.15 m): 1 s is 0.1 m straight ahead, read in 50 ms sub-steps.
  const double w = 0.1 / 0.15;
  mapping::SteppedOdometry odo({{0.4, 0.15}, {-0.4, 0.15}}, from_seconds(0.05), 0.3);
  std::vector<TimeNs> reads;
  TimeNs fail_at = -1, garbage_at = -1;
  auto read = [&](TimeNs t, std::span<double> a, double& yaw) {
    reads.push_back(t);
    if (t == fail_at) return false;
    a[0] = a[1] = t == garbage_at ? 1e4 : w * to_seconds(t);
    yaw = std::nan("");
    return true;
  };
  ASSERT_TRUE(odo.advance_to(0, read));
  ASSERT_TRUE(odo.started());
  ASSERT_TRUE(odo.advance_to(from_seconds(1.0), read));
  EXPECT_EQ(reads.size(), 1u + 20u) << "the start, then 20 sub-steps of 50 ms";
  EXPECT_EQ(reads.back(), from_seconds(1.0));
  EXPECT_NEAR(odo.pose().x, 0.1, 1e-9);
  EXPECT_NEAR(odo.pose().y, 0.0, 1e-12);
  EXPECT_TRUE(odo.advance_to(from_seconds(1.0), read)) << "the same time again: nothing to do";
  EXPECT_FALSE(odo.advance_to(from_seconds(0.5), read)) << "a time before the last: nothing done";
  EXPECT_EQ(reads.size(), 21u);
  // No data at 1.1 s: false, the pose stays at the last good reading (1.05 s), the next advance
  // spans the gap.
  fail_at = from_seconds(1.1);
  EXPECT_FALSE(odo.advance_to(from_seconds(1.2), read));
  EXPECT_EQ(odo.time_ns(), from_seconds(1.05));
  EXPECT_NEAR(odo.pose().x, 0.105, 1e-9);
  fail_at = -1;
  ASSERT_TRUE(odo.advance_to(from_seconds(2.0), read));
  EXPECT_NEAR(odo.pose().x, 0.2, 1e-9);
  // One garbage reading (1e4 rad at 2.5 s): the odometry re-anchors on it and again on the next
  // true reading, losing those two sub-steps' 1 cm, and counts both.
  garbage_at = from_seconds(2.5);
  ASSERT_TRUE(odo.advance_to(from_seconds(3.0), read));
  EXPECT_EQ(odo.reanchored(), 2);
  EXPECT_NEAR(odo.pose().x, 0.29, 1e-9);
  // The clock steps back 2 s: the next read (at 1 s, wheels 0.1 m behind) becomes the reference,
  // nothing is integrated across the step, and driving on from there adds only what is driven.
  odo.clock_stepped_back();
  ASSERT_TRUE(odo.advance_to(from_seconds(1.0), read));
  EXPECT_NEAR(odo.pose().x, 0.29, 1e-9);
  EXPECT_EQ(odo.time_ns(), from_seconds(1.0));
  ASSERT_TRUE(odo.advance_to(from_seconds(1.5), read));
  EXPECT_NEAR(odo.pose().x, 0.34, 1e-9);
  // A failed or non-finite reading after the step keeps it pending.
  odo.clock_stepped_back();
  garbage_at = -1;
  fail_at = from_seconds(0.5);
  EXPECT_FALSE(odo.advance_to(from_seconds(0.5), read));
  fail_at = -1;
  ASSERT_TRUE(odo.advance_to(from_seconds(0.6), read));
  ASSERT_TRUE(odo.advance_to(from_seconds(0.7), read));
  EXPECT_NEAR(odo.pose().x, 0.35, 1e-9);
  EXPECT_NEAR(odo.distance(), 0.35, 1e-9) << "the distance goes on across the steps";
  // A long gap is crossed in at most kMaxSubsteps reads.
  reads.clear();
  ASSERT_TRUE(odo.advance_to(from_seconds(3.0 + 60.0), read));
  EXPECT_EQ(static_cast<std::int64_t>(reads.size()), mapping::SteppedOdometry::kMaxSubsteps);
  // Heading from the IMU: equal wheels, the heading read from `yaw`.
  mapping::SteppedOdometry imu({{0.4, 0.15}, {-0.4, 0.15}}, from_seconds(0.05), 0.3);
  auto turning = [&](TimeNs t, std::span<double> a, double& yaw) {
    a[0] = a[1] = w * to_seconds(t);
    yaw = 0.05 * to_seconds(t);
    return true;
  };
  ASSERT_TRUE(imu.advance_to(0, turning));
  ASSERT_TRUE(imu.advance_to(from_seconds(2.0), turning));
  EXPECT_NEAR(imu.pose().yaw, 0.1, 1e-12);
  EXPECT_NEAR(imu.pose().x, 2.0 * std::sin(0.1), 1e-9) << "an arc of radius 0.1 / 0.05 = 2 m";
  try {
    mapping::SteppedOdometry bad({{0.4, 0.15}, {-0.4, 0.15}}, 0, 0.3);
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_EQ(e.field(), "step");
  }
}

TEST(TerrainMapComponent, CorrectedPoseFollowsTheMockRoverAndTheMapFills) {
  cli::register_everything();
  auto app = runtime::Application::load(Params::load_string(test_yaml(), "terrain_map_test.yaml"),
                                        {.sim_time = true, .enable_dds = false});
  auto* cam = app->context().find<hal::Camera>("front");
  ASSERT_NE(cam, nullptr);
  const auto* checked =
      dynamic_cast<const hal::StampCheckedCamera*>(cam);  // every camera is read through the stamp check
  ASSERT_NE(checked, nullptr);
  const auto* truth = dynamic_cast<const mocks::DriveTruth*>(&checked->inner());
  ASSERT_NE(truth, nullptr);
  ASSERT_NE(truth->drive_terrain(), nullptr);
  EXPECT_GT(truth->drive_terrain()->rocks().size(), 10u);
  EXPECT_EQ(truth->drive_terrain()->craters().size(), 2u);
  auto& state = app->context().channel<mapping::TerrainMapState>(mapping::kOdometryChannel);

  std::atomic<bool> stop{false};
  app->start();
  double worst = 0.0, worst_yaw = 0.0, last_wheel_err = 0.0, last_err = 0.0;
  int samples = 0;
  std::uint64_t seen = 0;
  for (int k = 0; k < 32; ++k) {  // 16 s in 0.5 s slices: every mapped frame checked against the truth
    app->run(500 * kNsPerMs, stop);
    auto l = state.acquire();
    if (!l || l.generation() == seen) continue;
    seen = l.generation();
    const terrain_scene::DrivePose t = truth->odom_pose_at(l->stamp);
    const double e = std::hypot(l->pose.x - t.x_m, l->pose.y - t.y_m);
    const double ey = std::abs(mapping::wrap_angle(l->pose.yaw - t.yaw_rad));
    worst = std::max(worst, e);
    worst_yaw = std::max(worst_yaw, ey);
    last_err = e;
    last_wheel_err = std::hypot(l->wheel_pose.x - t.x_m, l->wheel_pose.y - t.y_m);
    ++samples;
  }
  app->stop();
  auto l = state.acquire();
  ASSERT_TRUE(l);
  const terrain_scene::DrivePose end = truth->odom_pose_at(l->stamp);
  std::printf(
      "frames %ld vo ok %ld failed %ld keyframes %ld jumps %ld cells %ld; pose error worst %.1f mm, final %.1f mm, "
      "wheel-only final %.1f mm, worst yaw %.3f deg; truth end (%.3f, %.3f, %.2f deg)\n",
      l->counters.frames, l->counters.vo_ok, l->counters.vo_failed, l->counters.keyframes, l->counters.odometry_jumps,
      l->cells_known, 1e3 * worst, 1e3 * last_err, 1e3 * last_wheel_err, worst_yaw * 57.2958, end.x_m, end.y_m,
      end.yaw_rad * 57.2958);
  EXPECT_GE(samples, 28);
  // 15 s of driving at 2 Hz: frames 0..30; the 16th second the rover stands (frame 30 held).
  EXPECT_EQ(l->counters.frames, 31);
  EXPECT_EQ(l->frames_rejected, 0);
  EXPECT_EQ(l->odometry_unavailable, 0);
  EXPECT_EQ(l->counters.odometry_jumps, 0);
  EXPECT_EQ(l->counters.vo_ok + l->counters.vo_failed, l->counters.frames - 1);
  EXPECT_GE(l->counters.vo_ok, 26);
  EXPECT_GE(l->counters.keyframes, 3);  // 1.5 m of driving, a keyframe every ~0.7 m
  EXPECT_NEAR(end.x_m, 8.0 * std::sin(1.5 / 8.0), 1e-9);
  // Wheels: 5 % slip over 1.5 m -> ~7.5 cm ahead; the corrected pose stays within a few cm.
  EXPECT_NEAR(last_wheel_err, 0.075, 0.01);
  EXPECT_LT(worst, 0.05);                     // measured 24 mm (wheels alone: 75 mm at the end)
  EXPECT_LT(last_err, 0.6 * last_wheel_err);  // measured 24 mm
  EXPECT_LT(worst_yaw, 0.5 / 57.2958);
  EXPECT_NEAR(l->distance_m, 1.05 * 1.5, 0.01);
  // The map: parallax / shadow heights over the 1.5 m drive, published every 2 frames.
  EXPECT_GT(l->cells_known, 2000);
  EXPECT_GE(l->map_updates, 15);
  const auto* tm = [&]() -> const runtime::Component* {
    for (const auto* c : app->view().components)
      if (c->name() == "terrain_map") return c;
    return nullptr;
  }();
  ASSERT_NE(tm, nullptr);
  EXPECT_EQ(tm->errors(), 0u);
  EXPECT_EQ(tm->result().rfind("map 31 frames", 0), 0u) << tm->result();
}

namespace {

// 16 s of the test drive with the camera's clock stepping (with_camera_clock_step); every published
// state's stamp in order, the last state, the component's result line and details.
struct ClockStepRun {
  std::vector<TimeNs> stamps;
  mapping::TerrainMapState last;
  std::string result;
  std::vector<std::pair<std::string, std::string>> details;
};

ClockStepRun run_with_camera_clock_step(int after, int frames, double step_ms) {
  cli::register_everything();
  auto app = runtime::Application::load(
      Params::load_string(with_camera_clock_step(after, frames, step_ms), "terrain_map_test.yaml"),
      {.sim_time = true, .enable_dds = false});
  auto& state = app->context().channel<mapping::TerrainMapState>(mapping::kOdometryChannel);
  std::atomic<bool> stop{false};
  app->start();
  ClockStepRun r;
  std::uint64_t seen = 0;
  for (int k = 0; k < 64; ++k) {  // 0.25 s slices at 2 Hz: every published state seen
    app->run(250 * kNsPerMs, stop);
    auto l = state.acquire();
    if (!l || l.generation() == seen) continue;
    seen = l.generation();
    r.stamps.push_back(l->stamp);
  }
  app->stop();
  auto l = state.acquire();
  EXPECT_TRUE(l);
  if (l) r.last = *l;
  for (const auto* c : app->view().components)
    if (c->name() == "terrain_map") {
      r.result = c->result();
      c->diagnostics(r.details);
    }
  return r;
}

std::string detail(const ClockStepRun& r, const std::string& key) {
  for (const auto& [k, v] : r.details)
    if (k == key) return v;
  ADD_FAILURE() << "no diagnostic " << key;
  return {};
}

}  // namespace

TEST(TerrainMapComponent, FramesStampedBeforeTheLastMappedOneAreSkippedAndCounted) {
  // The camera's clock steps back 1.2 s (less than the 2 s input timeout) for frames 10 and 11:
  // stamped 3.8 and 4.3 s after frame 9's 4.5 s. Both are skipped; frame 12 (6.0 s) maps again.
  const ClockStepRun r = run_with_camera_clock_step(10, 2, -1200.0);
  ASSERT_GE(r.stamps.size(), 25u);
  for (std::size_t i = 1; i < r.stamps.size(); ++i)
    EXPECT_GT(r.stamps[i], r.stamps[i - 1]) << "the odom stream never goes back in time (state " << i << ")";
  EXPECT_EQ(r.last.frames_out_of_order, 2);
  EXPECT_EQ(r.last.clock_steps, 0);
  EXPECT_EQ(r.last.counters.frames, 31 - 2);
  EXPECT_EQ(r.last.odometry_unavailable, 0) << "no frame went to the mapper without its wheel pose";
  EXPECT_EQ(r.last.frames_rejected, 0);
  EXPECT_EQ(detail(r, "frames_out_of_order"), "2");
  EXPECT_NE(r.result.find("camera clock stepped back"), std::string::npos) << r.result;
  // The drive is the same as without the step: the pose ends where the unfaulted run's does (the
  // first test: 1.5 m of a left arc of radius 8 m, the corrected pose within 5 cm of the truth).
  const double x = 8.0 * std::sin(1.5 / 8.0), y = 8.0 * (1.0 - std::cos(1.5 / 8.0));
  EXPECT_LT(std::hypot(r.last.pose.x - x, r.last.pose.y - y), 0.05);
  EXPECT_NEAR(r.last.distance_m, 1.05 * 1.5, 0.01);
}

TEST(TerrainMapComponent, SkippedFramesAreCountedWhenTheyAreSkippedNotAtTheNextMappedOne) {
  // The last two frames of the drive (29 and 30) come 1.2 s back: skipped, and no frame is mapped
  // after them. The diagnostics and the result line say so at once; the state keeps the counts of
  // its own (the last mapped) frame.
  const ClockStepRun r = run_with_camera_clock_step(29, 2, -1200.0);
  EXPECT_EQ(r.last.counters.frames, 29);
  EXPECT_EQ(r.last.frames_out_of_order, 0) << "as of frame 28, the last one mapped";
  EXPECT_EQ(detail(r, "frames_out_of_order"), "2");
  EXPECT_NE(r.result.find("camera clock stepped back"), std::string::npos) << r.result;
}

TEST(TerrainMapComponent, AClockStepBackPastTheTimeoutMapsOnFromTheNewTimeBase) {
  // From frame 10 on the camera's clock is 3 s behind for good (more than the 2 s timeout): waiting
  // for its stamps to pass frame 9's would stop the map for 3 s, so mapping goes on and the wheel
  // odometry continues from its pose on the angles read at the new stamps. Nothing is integrated
  // across the step: the wheels lose only the 0.5 s between frame 9 and frame 10.
  const ClockStepRun r = run_with_camera_clock_step(10, 0, -3000.0);
  EXPECT_EQ(r.last.clock_steps, 1);
  EXPECT_EQ(r.last.frames_out_of_order, 0);
  EXPECT_EQ(r.last.counters.frames, 31);
  EXPECT_EQ(r.last.odometry_unavailable, 0);
  EXPECT_EQ(r.last.counters.odometry_jumps, 0);
  EXPECT_EQ(detail(r, "clock_steps"), "1");
  EXPECT_NEAR(r.last.distance_m, 1.05 * (1.5 - 0.05), 0.01);
  // The last frame shows the rover at the end of its 1.5 m arc; the wheels' pose lacks the 5 cm
  // the step hid from them.
  const double x = 8.0 * std::sin(1.5 / 8.0), y = 8.0 * (1.0 - std::cos(1.5 / 8.0));
  const double e = std::hypot(r.last.pose.x - x, r.last.pose.y - y);
  std::printf("clock step back 3 s: corrected pose %.1f mm from the truth, wheels %.1f mm\n", 1e3 * e,
              1e3 * std::hypot(r.last.wheel_pose.x - x, r.last.wheel_pose.y - y));
  EXPECT_LT(e, 0.08);
  EXPECT_GT(r.last.cells_known, 2000);
}

TEST(TerrainMapComponent, BadConfigurationNamesTheField) {
  // A parameter out of range: located at its key.
  std::string e = load_error(edited("map_length_m: 12", "map_length_m: -3"));
  EXPECT_NE(e.find("components.terrain_map.map_length_m"), std::string::npos) << e;
  // Each in range, together a map too big for the rover (3000 cells per side: ~2 GB at configure).
  e = load_error(edited("map_length_m: 12", "map_length_m: 60\n    map_resolution_m: 0.02"));
  EXPECT_NE(e.find("components.terrain_map.map_resolution_m"), std::string::npos) << e;
  EXPECT_NE(e.find("map_length_m 60 m at 0.02 m per cell is 3000 cells per side; the live map takes at most 1024"),
            std::string::npos)
      << e;
  // A camera without a rover.cameras entry.
  e = load_error(edited("    camera: front\n    encoders", "    camera: nocam\n    encoders"));
  EXPECT_NE(e.find("components.terrain_map.camera"), std::string::npos) << e;
  // Heading from an IMU on a rover without one.
  e = load_error(edited("  imu: body_imu\n", ""));
  EXPECT_EQ(e, "") << "without rover.imu the heading defaults to the wheels";
  std::string y = edited("  imu: body_imu\n", "");
  y += "    heading_source: imu\n";
  e = load_error(y);
  EXPECT_NE(e.find("components.terrain_map.heading_source"), std::string::npos) << e;
  EXPECT_NE(e.find("rover.imu"), std::string::npos) << e;
  // Wheels on one side only: the odometry cannot be built.
  y = test_yaml();
  for (std::string::size_type at; (at = y.find("y_m: -0.4")) != std::string::npos;) y.replace(at, 9, "y_m: 0.45");
  e = load_error(y);
  EXPECT_NE(e.find("components.terrain_map.encoders"), std::string::npos) << e;
  EXPECT_NE(e.find("0 right"), std::string::npos) << e;
  // Unknown keys are rejected (with the runtime's did-you-mean).
  e = load_error(edited("map_publish_every: 2", "map_publish_evry: 2"));
  EXPECT_NE(e.find("map_publish_evry"), std::string::npos) << e;
}

namespace {

TEST(TerrainMapParams, OneReaderForTheComponentAndTheCli) {
  // The keys of the terrain_map component, read from YAML over given defaults: the same reader
  // serves `regolith map --config FILE --set key=value`.
  using regolith::mapping::DriveMapperParams;
  DriveMapperParams defaults;
  defaults.parallax_spacing_m = 0.15;
  regolith::Params p = regolith::Params::load_string(
      "track_rocks: false\nrock_merge_m: 0.4\nsighting_tilt_window: 3\nmap_resolution_m: 0.02\nsighting_max_width_px: "
      "0\n",
      "m.yaml");
  const DriveMapperParams got = regolith::mapping::read_drive_mapper_params(p, defaults);
  p.finish();
  EXPECT_FALSE(got.tracks.enabled);
  EXPECT_EQ(got.map.rock_min_frames, 1);  // untracked: every sighting is one frame
  regolith::Params tracked = regolith::Params::load_string("rock_min_frames: 5\n", "m.yaml");
  EXPECT_EQ(regolith::mapping::read_drive_mapper_params(tracked).map.rock_min_frames, 5);
  // Untracked with a minimum above 1 would report no rock at all: refused, located.
  regolith::Params none = regolith::Params::load_string("track_rocks: false\nrock_min_frames: 3\n", "--set");
  try {
    regolith::mapping::read_drive_mapper_params(none);
    ADD_FAILURE() << "track_rocks false with rock_min_frames 3 accepted";
  } catch (const regolith::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("--set:2:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("rock_min_frames: must be 1 with track_rocks: false"), std::string::npos)
        << e.what();
  }
  EXPECT_DOUBLE_EQ(got.map.rock_merge_m, 0.4);
  EXPECT_EQ(got.sighting_tilt_window, 3);
  EXPECT_EQ(got.sightings.max_width_px, 0);  // full size
  EXPECT_EQ(defaults.sightings.max_width_px, 480);
  EXPECT_DOUBLE_EQ(got.map.resolution_m, 0.02);
  EXPECT_DOUBLE_EQ(got.parallax_spacing_m, 0.15);  // not given: the caller's default
  EXPECT_DOUBLE_EQ(got.tracks.ground_sigma_m, DriveMapperParams{}.tracks.ground_sigma_m);
  // A bad value and an unknown key are located errors naming the key.
  regolith::Params bad = regolith::Params::load_string("rock_min_frames: 0\n", "--set");
  try {
    regolith::mapping::read_drive_mapper_params(bad);
    ADD_FAILURE() << "rock_min_frames 0 accepted";
  } catch (const regolith::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("--set:1:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("rock_min_frames"), std::string::npos) << e.what();
  }
  regolith::Params narrow = regolith::Params::load_string("sighting_max_width_px: 8\n", "--set");
  try {
    regolith::mapping::read_drive_mapper_params(narrow);
    ADD_FAILURE() << "sighting_max_width_px 8 accepted";
  } catch (const regolith::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sighting_max_width_px: must be 0 (full size) or at least 16 px"),
              std::string::npos)
        << e.what();
  }
  regolith::Params typo = regolith::Params::load_string("rock_min_frame: 4\n", "--set");
  regolith::mapping::read_drive_mapper_params(typo);
  try {
    typo.finish();
    ADD_FAILURE() << "unknown key accepted";
  } catch (const regolith::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("rock_min_frames"), std::string::npos) << e.what();  // the suggestion
  }
}

}  // namespace
