// The terrain_map component's DDS output read from another process: `regolith run` publishes the
// moving mock rover (tests/mapping/terrain_map_test.yaml, simulated clock) in a child process;
// this process subscribes to odom, odom/wheel (nav_msgs/Odometry) and terrain/world_map
// (grid_map_msgs/GridMap) and checks the values against the mock's exact path.
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "child_process.hpp"
#include "dds_test_util.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/terrain_scene/drive.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
namespace rt = regolith::testing;
namespace rd = regolith::dds;
namespace tst = regolith::dds::testing;
namespace m = regolith::msgs;
using regolith::kNsPerMs;
using regolith::kNsPerSec;

namespace {

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
  std::size_t cells = 0, known = 0, unknown = 0, bad_hazard = 0, bad_count = 0, faint = 0;
  double min_z = 1e9, max_z = -1e9;
};

// One rock of terrain/world_rocks (vision_msgs/Detection3D).
struct RockSample {
  std::string frame, class_id, id;
  std::size_t results = 0;
  double score = 0, x = 0, y = 0, z = 0, cxx = 0, cxy = 0, cyx = 0, cyy = 0, czz = 0, cyaw = 0;
  double bx = 0, by = 0, bz = 0, sx = 0, sy = 0, sz = 0;
};
std::vector<RockSample> rocks_of(const m::vision_msgs::Detection3DArray& a) {
  std::vector<RockSample> out;
  for (std::uint32_t k = 0; k < a.detections._length; ++k) {
    const auto& d = a.detections._buffer[k];
    RockSample r;
    r.frame = d.header.frame_id != nullptr ? d.header.frame_id : "";
    r.id = d.id != nullptr ? d.id : "";
    r.results = d.results._length;
    if (d.results._length > 0) {
      const auto& h = d.results._buffer[0];
      r.class_id = h.hypothesis.class_id != nullptr ? h.hypothesis.class_id : "";
      r.score = h.hypothesis.score;
      r.x = h.pose.pose.position.x;
      r.y = h.pose.pose.position.y;
      r.z = h.pose.pose.position.z;
      r.cxx = h.pose.covariance[0];
      r.cxy = h.pose.covariance[1];
      r.cyx = h.pose.covariance[6];
      r.cyy = h.pose.covariance[7];
      r.czz = h.pose.covariance[14];
      r.cyaw = h.pose.covariance[35];
    }
    r.bx = d.bbox.center.position.x;
    r.by = d.bbox.center.position.y;
    r.bz = d.bbox.center.position.z;
    r.sx = d.bbox.size.x;
    r.sy = d.bbox.size.y;
    r.sz = d.bbox.size.z;
    out.push_back(r);
  }
  return out;
}

struct Tf {
  std::string parent, child;
  double t = 0;
  double x = 0, y = 0, z = 0, qx = 0, qy = 0, qz = 0, qw = 1;
};
void take_tf(const m::tf2_msgs::TFMessage& msg, std::vector<Tf>& out) {
  for (std::uint32_t i = 0; i < msg.transforms._length; ++i) {
    const auto& t = msg.transforms._buffer[i];
    const auto& r = t.transform.rotation;
    const auto& v = t.transform.translation;
    out.push_back({t.header.frame_id != nullptr ? t.header.frame_id : "",
                   t.child_frame_id != nullptr ? t.child_frame_id : "",
                   static_cast<double>(rd::to_ns(t.header.stamp)) * 1e-9, v.x, v.y, v.z, r.x, r.y, r.z, r.w});
  }
}
// Rotates v by the unit quaternion (x, y, z, w).
std::array<double, 3> rotate(const Tf& q, std::array<double, 3> v) {
  const double ux = q.qx, uy = q.qy, uz = q.qz, w = q.qw;
  const double cx = uy * v[2] - uz * v[1], cy = uz * v[0] - ux * v[2], cz = ux * v[1] - uy * v[0];
  const double c2x = uy * cz - uz * cy, c2y = uz * cx - ux * cz, c2z = ux * cy - uy * cx;
  return {v[0] + 2 * (w * cx + c2x), v[1] + 2 * (w * cy + c2y), v[2] + 2 * (w * cz + c2z)};
}

}  // namespace

TEST(TerrainMapDds, OdometryAndWorldMapReadInAnotherProcess) {
  tst::use_loopback_config();
  const auto domain = tst::test_domain();
  const std::string ns = tst::unique_ns();
  const regolith::testing::TempDir tmp("map_dds");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  std::string yaml = rt::read_file(std::string(REGOLITH_SOURCE_DIR) + "/tests/mapping/terrain_map_test.yaml");
  replace_once(yaml, "domain: 0", "domain: " + std::to_string(domain));
  replace_once(yaml, "namespace: maptest", "namespace: " + ns);
  // Rocks enough for terrain/world_rocks to report some on this 1.5 m drive (the shared test tile
  // has too few in view for any to be sighted in three frames).
  replace_once(yaml, "fractal_rms_m: 0.003", "fractal_rms_m: 0.003\n      rocks_per_m2: 0.6\n     ");
  const fs::path cfg = dir / "terrain_map_test.yaml";
  std::ofstream(cfg) << yaml;

  rd::Participant pp({domain, ns});
  rd::Reader<m::nav_msgs::Odometry> odom(pp, "odom", rd::find_topic("odom")->reader_qos());
  rd::Reader<m::nav_msgs::Odometry> wheel(pp, "odom/wheel", rd::find_topic("odom/wheel")->reader_qos());
  rd::Reader<m::grid_map_msgs::GridMap> map(pp, "terrain/world_map", rd::find_topic("terrain/world_map")->reader_qos());
  rd::Reader<m::vision_msgs::Detection3DArray> rocks(pp, "terrain/world_rocks",
                                                     rd::find_topic("terrain/world_rocks")->reader_qos());
  rd::Reader<m::tf2_msgs::TFMessage> tf(pp, "/tf", rd::find_topic("/tf")->reader_qos());
  rd::Reader<m::tf2_msgs::TFMessage> tf_static(pp, "/tf_static", rd::find_topic("/tf_static")->reader_qos());
  rd::Reader<m::rosgraph_msgs::Clock> clock(pp, "/clock", rd::find_topic("/clock")->reader_qos());

  // The rover waits for our readers before its clock starts: nothing is published unseen.
  const std::string exe = REGOLITH_EXE, out = (dir / "run.txt").string();
  std::vector<std::string> args{exe,          "run",
                                "--config",   cfg.string(),
                                "--sim-time", "--duration",
                                "16",         "--quiet",
                                "--wait-for", "odom",
                                "--wait-for", "odom/wheel",
                                "--wait-for", "terrain/world_map",
                                "--wait-for", "terrain/world_rocks",
                                "--wait-for", "/tf",
                                "--wait-for", "/clock"};
  const pid_t pid = rt::spawn(args, out);
  ASSERT_GT(pid, 0);

  std::vector<OdomSample> corrected, wheels;
  std::vector<Tf> dynamic_tf, static_tf;
  std::vector<double> clock_s;
  MapSample last_map;
  std::size_t maps = 0, rock_samples = 0;
  std::string rocks_frame;
  std::vector<RockSample> last_rocks;
  std::map<std::string, std::vector<RockSample>> by_id;  // every sample's rocks by their id
  std::size_t duplicate_ids = 0;
  auto drain = [&] {
    rocks.take(
        [&](const m::vision_msgs::Detection3DArray& a, const dds_sample_info_t&) {
          ++rock_samples;
          rocks_frame = a.header.frame_id != nullptr ? a.header.frame_id : "";
          last_rocks = rocks_of(a);
          std::set<std::string> ids;
          for (const RockSample& r : last_rocks) {
            duplicate_ids += ids.insert(r.id).second ? 0 : 1;
            by_id[r.id].push_back(r);
          }
        },
        100);
    odom.take([&](const m::nav_msgs::Odometry& o, const dds_sample_info_t&) { corrected.push_back(odom_of(o)); }, 1000);
    wheel.take([&](const m::nav_msgs::Odometry& o, const dds_sample_info_t&) { wheels.push_back(odom_of(o)); }, 1000);
    tf.take([&](const m::tf2_msgs::TFMessage& t, const dds_sample_info_t&) { take_tf(t, dynamic_tf); }, 1000);
    tf_static.take([&](const m::tf2_msgs::TFMessage& t, const dds_sample_info_t&) { take_tf(t, static_tf); }, 10);
    clock.take([&](const m::rosgraph_msgs::Clock& c,
                   const dds_sample_info_t&) { clock_s.push_back(static_cast<double>(rd::to_ns(c.clock)) * 1e-9); },
               1000);
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
            const auto& cf = g.data._buffer[3].data;   // confidence
            const auto& cnt = g.data._buffer[4].data;  // observed_count
            s.cells = el._length;
            for (std::uint32_t i = 0; i < el._length && i < hz._length && i < cnt._length; ++i) {
              if (std::isfinite(el._buffer[i])) {
                ++s.known;
                s.min_z = std::min(s.min_z, static_cast<double>(el._buffer[i]));
                s.max_z = std::max(s.max_z, static_cast<double>(el._buffer[i]));
                // A hazard in [0, 1]; NaN (not assessed) only for a cell seen too faintly for its
                // relief (WorldMapParams::hazard_min_weight 0.05: confidence 1 - e^-0.05 = 0.049).
                if (std::isnan(hz._buffer[i]) && i < cf._length && cf._buffer[i] < 0.049f)
                  ++s.faint;
                else if (!(hz._buffer[i] >= 0.0f && hz._buffer[i] <= 1.0f))
                  ++s.bad_hazard;
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
  bool exited = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!(exited = waitpid(pid, &status, WNOHANG) == pid) && std::chrono::steady_clock::now() < deadline) {
    odom.wait(50 * kNsPerMs);
    drain();
  }
  if (!exited) rt::wait_exit(pid, std::chrono::milliseconds(0));  // killed and reaped, not left running
  for (int k = 0; k < 10; ++k) {                                  // what is still in flight
    odom.wait(20 * kNsPerMs);
    drain();
  }
  ASSERT_TRUE(exited) << "the rover did not finish in 120 s";
  EXPECT_EQ(rt::exit_status(status), 0) << rt::read_file(out + ".err");

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

  // /tf: odom -> base_link with every corrected pose, same stamp and values as odom.
  ASSERT_EQ(dynamic_tf.size(), corrected.size());
  for (std::size_t k = 0; k < corrected.size(); ++k) {
    EXPECT_EQ(dynamic_tf[k].parent, "odom");
    EXPECT_EQ(dynamic_tf[k].child, "base_link");
    EXPECT_DOUBLE_EQ(dynamic_tf[k].t, corrected[k].t);
    EXPECT_DOUBLE_EQ(dynamic_tf[k].x, corrected[k].x);
    EXPECT_DOUBLE_EQ(dynamic_tf[k].y, corrected[k].y);
    EXPECT_NEAR(2.0 * std::atan2(dynamic_tf[k].qz, dynamic_tf[k].qw), corrected[k].yaw, 1e-9);
  }
  // /tf_static (latched): base_link -> front_link -> front_optical_frame and front_ground; the
  // tree is connected from odom to the camera's optical frame, whose z axis (the optical axis)
  // points forward and 0.35 rad down in base_link, 0.5 m up.
  ASSERT_EQ(static_tf.size(), 3u);
  auto parent_of = [&](const std::string& child) -> const Tf* {
    for (const Tf& t : static_tf)
      if (t.child == child) return &t;
    for (const Tf& t : dynamic_tf)
      if (t.child == child) return &t;
    return nullptr;
  };
  std::string frame = "front_optical_frame";
  std::array<double, 3> axis{0, 0, 1}, origin{0, 0, 0};
  std::vector<std::string> chain{frame};
  while (const Tf* t = parent_of(frame)) {
    if (frame == "base_link") break;
    axis = rotate(*t, axis);
    const auto o = rotate(*t, origin);
    origin = {o[0] + t->x, o[1] + t->y, o[2] + t->z};
    frame = t->parent;
    chain.push_back(frame);
  }
  EXPECT_EQ(chain, (std::vector<std::string>{"front_optical_frame", "front_link", "base_link"}));
  EXPECT_NEAR(axis[0], std::cos(0.35), 1e-9);
  EXPECT_NEAR(axis[1], 0.0, 1e-9);
  EXPECT_NEAR(axis[2], -std::sin(0.35), 1e-9);
  EXPECT_NEAR(origin[2], 0.5, 1e-12);
  ASSERT_NE(parent_of("base_link"), nullptr);
  EXPECT_EQ(parent_of("base_link")->parent, "odom");
  ASSERT_NE(parent_of("front_ground"), nullptr);
  EXPECT_EQ(parent_of("front_ground")->parent, "base_link");
  // /clock under --sim-time: strictly increasing simulated time that covers every stamp.
  ASSERT_GT(clock_s.size(), 30u);
  for (std::size_t k = 1; k < clock_s.size(); ++k) EXPECT_GT(clock_s[k], clock_s[k - 1]) << k;
  EXPECT_LE(clock_s.front(), corrected.front().t);
  EXPECT_GE(clock_s.back(), corrected.back().t);

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
  EXPECT_LT(last_map.faint, last_map.known / 2) << "most known cells are assessed";
  EXPECT_EQ(last_map.bad_count, 0u);
  EXPECT_GT(last_map.min_z, -0.3);
  EXPECT_LT(last_map.max_z, 0.5);
  EXPECT_LT(std::abs(last_map.cx), 6.0);

  // terrain/world_rocks: the map's rocks in the odom frame (latched, published with the map),
  // each a Detection3D "rock" with a score, a pose covariance that is symmetric and positive in
  // x / y, z from the height, orientation unobserved, and a box as high as the rock. Against the
  // mock's own tile (the same seed and parameters as tests/mapping/terrain_map_test.yaml).
  EXPECT_GE(rock_samples, 1u);
  EXPECT_EQ(rocks_frame, "odom");
  regolith::terrain_scene::DriveTileParams tile;
  tile.seed = 3;
  tile.fractal_rms_m = 0.003;
  tile.rocks_per_m2 = 0.6;
  tile.keep_clear_m = 0.6;  // the synthetic_drive backend's default
  const auto terrain = regolith::terrain_scene::make_drive_tile(path, tile);
  int near_truth = 0;
  for (const RockSample& r : last_rocks) {
    EXPECT_EQ(r.frame, "odom");
    EXPECT_EQ(r.results, 1u);
    EXPECT_EQ(r.class_id, "rock");
    EXPECT_GT(r.score, 0.0);
    EXPECT_LE(r.score, 1.0);
    EXPECT_GT(r.cxx, 0.0);
    EXPECT_GT(r.cyy, 0.0);
    EXPECT_EQ(r.cxy, r.cyx);
    EXPECT_LT(r.cxy * r.cxy, r.cxx * r.cyy);
    EXPECT_NEAR(r.czz, 0.25 * r.sz * r.sz, 1e-9);
    EXPECT_EQ(r.cyaw, 1e6);
    EXPECT_DOUBLE_EQ(r.bx, r.x);
    EXPECT_DOUBLE_EQ(r.by, r.y);
    EXPECT_DOUBLE_EQ(r.bz, r.z);
    EXPECT_GT(r.sz, 0.0);
    EXPECT_GT(r.sx, 0.0);
    EXPECT_EQ(r.sx, r.sy);
    double nearest = 1e9;
    for (const auto& t : terrain.rocks()) nearest = std::min(nearest, std::hypot(r.x - t.x_m, r.y - t.y_m));
    near_truth += nearest < 0.3 ? 1 : 0;
    std::printf("world rock (%.2f, %.2f) h %.2f w %.2f score %.2f sd %.2f / %.2f m, nearest true rock %.2f m\n", r.x,
                r.y, r.sz, r.sx, r.score, std::sqrt(r.cxx), std::sqrt(r.cyy), nearest);
  }
  EXPECT_GE(last_rocks.size(), 1u);
  EXPECT_GE(2 * near_truth, static_cast<int>(last_rocks.size())) << "most published rocks stand on a true rock";
  // Identity across updates: every rock has an id (its track number), unique within a message;
  // the rocks of the last message were published before under the same id, and an id stays on one
  // rock (its reports stay within 0.3 m of each other).
  EXPECT_EQ(by_id.count(""), 0u) << "a tracked rock without an id";
  EXPECT_EQ(duplicate_ids, 0u);
  int seen_before = 0;
  for (const RockSample& r : last_rocks) seen_before += by_id[r.id].size() > 1 ? 1 : 0;
  EXPECT_GE(seen_before, 1) << "no rock of the last message kept its id from an earlier one";
  for (const auto& [id, reports] : by_id) {
    double spread = 0;
    for (const RockSample& a : reports)
      for (const RockSample& b : reports) spread = std::max(spread, std::hypot(a.x - b.x, a.y - b.y));
    std::printf("world rock id %s: %zu reports within %.3f m\n", id.c_str(), reports.size(), spread);
    EXPECT_LT(spread, 0.3) << "id " << id << " moved between rocks";
  }
}
