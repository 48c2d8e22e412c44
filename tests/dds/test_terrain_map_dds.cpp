// The terrain_map component's DDS output read from another process: `regolith run` publishes the
// moving mock rover (tests/mapping/terrain_map_test.yaml, simulated clock) in a child process;
// this process subscribes to odom, odom/wheel (nav_msgs/Odometry) and terrain/world_map
// (grid_map_msgs/GridMap) and checks the values against the mock's exact path.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dds_test_util.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/terrain_scene/drive.hpp"

extern char** environ;
namespace fs = std::filesystem;
namespace rd = regolith::dds;
namespace tst = regolith::dds::testing;
namespace m = regolith::msgs;
using regolith::kNsPerMs;
using regolith::kNsPerSec;

namespace {

std::string slurp(const std::string& f) {
  std::ifstream in(f);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void replace_once(std::string& s, const std::string& find, const std::string& with) {
  const auto at = s.find(find);
  ASSERT_NE(at, std::string::npos) << find;
  s.replace(at, find.size(), with);
}

struct OdomSample {
  double t = 0, x = 0, y = 0, yaw = 0, cxx = 0, cyy = 0, cyaw = 0, cz = 0, sym = 0;
  std::string frame, child;
};
OdomSample odom_of(const m::nav_msgs::Odometry& o) {
  OdomSample s;
  s.t = static_cast<double>(rd::to_ns(o.header.stamp)) * 1e-9;
  s.x = o.pose.pose.position.x;
  s.y = o.pose.pose.position.y;
  s.yaw = 2.0 * std::atan2(o.pose.pose.orientation.z, o.pose.pose.orientation.w);
  s.cxx = o.pose.covariance[0];
  s.cyy = o.pose.covariance[7];
  s.cyaw = o.pose.covariance[35];
  s.cz = o.pose.covariance[14];
  s.sym =
      std::abs(o.pose.covariance[1] - o.pose.covariance[6]) + std::abs(o.pose.covariance[5] - o.pose.covariance[30]);
  s.frame = o.header.frame_id != nullptr ? o.header.frame_id : "";
  s.child = o.child_frame_id != nullptr ? o.child_frame_id : "";
  return s;
}

struct MapSample {
  std::vector<std::string> layers;
  std::string frame;
  double resolution = 0, length_x = 0, length_y = 0, cx = 0, cy = 0;
  std::size_t cells = 0, known = 0, unknown = 0, bad_hazard = 0, bad_count = 0;
  double min_z = 1e9, max_z = -1e9;
};

}  // namespace

TEST(TerrainMapDds, OdometryAndWorldMapReadInAnotherProcess) {
  tst::use_loopback_config();
  const auto domain = tst::test_domain();
  const std::string ns = tst::unique_ns();
  const fs::path dir = fs::temp_directory_path() / ("regolith_map_dds_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::string yaml = slurp(std::string(REGOLITH_SOURCE_DIR) + "/tests/mapping/terrain_map_test.yaml");
  replace_once(yaml, "domain: 0", "domain: " + std::to_string(domain));
  replace_once(yaml, "namespace: maptest", "namespace: " + ns);
  const fs::path cfg = dir / "terrain_map_test.yaml";
  std::ofstream(cfg) << yaml;

  rd::Participant pp({domain, ns});
  rd::Reader<m::nav_msgs::Odometry> odom(pp, "odom", rd::find_topic("odom")->reader_qos());
  rd::Reader<m::nav_msgs::Odometry> wheel(pp, "odom/wheel", rd::find_topic("odom/wheel")->reader_qos());
  rd::Reader<m::grid_map_msgs::GridMap> map(pp, "terrain/world_map", rd::find_topic("terrain/world_map")->reader_qos());

  // The rover waits for our readers before its clock starts: nothing is published unseen.
  const std::string exe = REGOLITH_EXE, out = (dir / "run.txt").string();
  std::vector<std::string> args{exe,          "run",        "--config",   cfg.string(),       "--sim-time",
                                "--duration", "16",         "--quiet",    "--wait-for",       "odom",
                                "--wait-for", "odom/wheel", "--wait-for", "terrain/world_map"};
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, (out + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  ASSERT_EQ(posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&fa);

  std::vector<OdomSample> corrected, wheels;
  MapSample last_map;
  std::size_t maps = 0;
  auto drain = [&] {
    odom.take([&](const m::nav_msgs::Odometry& o, const dds_sample_info_t&) { corrected.push_back(odom_of(o)); }, 1000);
    wheel.take([&](const m::nav_msgs::Odometry& o, const dds_sample_info_t&) { wheels.push_back(odom_of(o)); }, 1000);
    map.take(
        [&](const m::grid_map_msgs::GridMap& g, const dds_sample_info_t&) {
          ++maps;
          MapSample s;
          s.frame = g.header.frame_id != nullptr ? g.header.frame_id : "";
          for (std::uint32_t k = 0; k < g.layers._length; ++k) s.layers.emplace_back(g.layers._buffer[k]);
          s.resolution = g.info.resolution;
          s.length_x = g.info.length_x;
          s.length_y = g.info.length_y;
          s.cx = g.info.pose.position.x;
          s.cy = g.info.pose.position.y;
          if (g.data._length == s.layers.size() && !s.layers.empty()) {
            const auto& el = g.data._buffer[0].data;   // elevation
            const auto& hz = g.data._buffer[2].data;   // hazard
            const auto& cnt = g.data._buffer[4].data;  // observed_count
            s.cells = el._length;
            for (std::uint32_t i = 0; i < el._length && i < hz._length && i < cnt._length; ++i) {
              if (std::isfinite(el._buffer[i])) {
                ++s.known;
                s.min_z = std::min(s.min_z, static_cast<double>(el._buffer[i]));
                s.max_z = std::max(s.max_z, static_cast<double>(el._buffer[i]));
                if (!(hz._buffer[i] >= 0.0f && hz._buffer[i] <= 1.0f)) ++s.bad_hazard;
                if (!(cnt._buffer[i] >= 1.0f)) ++s.bad_count;
              } else {
                ++s.unknown;
              }
            }
          }
          last_map = s;
        },
        100);
  };
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (waitpid(pid, &status, WNOHANG) == 0 && std::chrono::steady_clock::now() < deadline) {
    odom.wait(50 * kNsPerMs);
    drain();
  }
  for (int k = 0; k < 10; ++k) {  // what is still in flight
    odom.wait(20 * kNsPerMs);
    drain();
  }
  ASSERT_TRUE(WIFEXITED(status)) << "the rover did not finish";
  EXPECT_EQ(WEXITSTATUS(status), 0) << slurp(out + ".err");

  // 15 s of driving at 2 Hz (frames 0..30), the 16th second standing on the last frame.
  ASSERT_EQ(corrected.size(), 31u);
  ASSERT_EQ(wheels.size(), 31u);
  regolith::terrain_scene::DrivePath path;
  path.speed_m_s = 0.1;
  path.turn_radius_m = 8.0;
  path.duration_s = 15.0;
  double worst = 0, worst_wheel_scale = 0;
  for (std::size_t k = 0; k < corrected.size(); ++k) {
    const OdomSample& c = corrected[k];
    const OdomSample& w = wheels[k];
    EXPECT_EQ(c.frame, "odom");
    EXPECT_EQ(c.child, "base_link");
    EXPECT_EQ(w.frame, "odom");
    EXPECT_DOUBLE_EQ(w.t, c.t);
    const double t = c.t - corrected.front().t;
    EXPECT_NEAR(t, 0.5 * static_cast<double>(k), 1e-6);
    const auto truth = path.pose_at(t);
    worst = std::max(worst, std::hypot(c.x - truth.x_m, c.y - truth.y_m));
    EXPECT_NEAR(c.yaw, truth.yaw_rad, 0.5 * M_PI / 180) << k;
    // Wheels with 5 % slip and the IMU heading: the true arc scaled by 1.05.
    worst_wheel_scale = std::max(worst_wheel_scale, std::hypot(w.x - 1.05 * truth.x_m, w.y - 1.05 * truth.y_m));
    EXPECT_NEAR(w.yaw, truth.yaw_rad, 1e-6) << k;
    if (k > 0) {
      EXPECT_GT(c.cxx, 0.0);
      EXPECT_GT(c.cyy, 0.0);
      EXPECT_GT(c.cyaw, 0.0);
      EXPECT_GE(w.cxx, wheels[k - 1].cxx);  // wheel-only uncertainty only grows
    }
    EXPECT_LT(c.sym, 1e-12);
    EXPECT_EQ(c.cz, 1e6);  // z is not estimated
  }
  EXPECT_LT(worst, 0.05);
  EXPECT_LT(worst_wheel_scale, 0.002);
  EXPECT_NEAR(std::hypot(wheels.back().x - corrected.back().x, wheels.back().y - corrected.back().y), 0.075, 0.06);

  // The map: every 2nd frame, latched (keep-last 1, so a reader may see fewer than published).
  EXPECT_GE(maps, 1u);
  EXPECT_EQ(last_map.frame, "odom");
  EXPECT_EQ(last_map.layers, (std::vector<std::string>{"elevation", "elevation_variance", "hazard", "confidence",
                                                       "observed_count", "traversability"}));
  EXPECT_DOUBLE_EQ(last_map.resolution, 0.04);
  EXPECT_NEAR(last_map.length_x, 12.0, 0.04);
  EXPECT_NEAR(last_map.length_y, 12.0, 0.04);
  EXPECT_EQ(last_map.cells, 300u * 300u);
  EXPECT_GT(last_map.known, 2000u);     // measured ~7500 cells after 1.5 m
  EXPECT_GT(last_map.unknown, 60000u);  // never seen: NaN
  EXPECT_EQ(last_map.bad_hazard, 0u);
  EXPECT_EQ(last_map.bad_count, 0u);
  EXPECT_GT(last_map.min_z, -0.3);
  EXPECT_LT(last_map.max_z, 0.5);
  EXPECT_LT(std::abs(last_map.cx), 6.0);
  fs::remove_all(dir);
}
