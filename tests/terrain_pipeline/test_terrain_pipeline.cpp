// The sfs and traversability component wrappers in a deployment under the simulated clock (DDS
// off), checked against the library run on the same rendered frame and against the scene's
// geometry; heap allocations inside rate-group cycles after warm-up; the assess and calibrate
// vignetting commands of the regolith tool (run as a process) with good and bad inputs.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <new>
#include <regex>
#include <string>

#include <execinfo.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/payloads.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/rate_group.hpp"
#include "regolith/sfs/component.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"
#include "regolith/traversability/component.hpp"

#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "diagnostics.hpp"
#include "temp_dir.hpp"

namespace {
using namespace regolith;
namespace fs = std::filesystem;
using regolith::testing::diagnostic;
using regolith::testing::read_file;

void register_once() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  mocks::register_mock_backends(hal::BackendRegistry::instance());
  sfs::register_component();
  traversability::register_component();
}

// Scene and camera of the deployment below (synthetic_terrain defaults, static rover).
constexpr double kHfov = 1.349, kCamH = 0.5, kPitch = 0.35, kSunAz = 2.5, kSunEl = 0.6;

std::string deployment(const std::string& method, const std::string& sfs_frame = "ground") {
  const double fx = 0.5 * 320 / std::tan(0.5 * kHfov);
  // The scene sun (counter-clockwise from +x) as the deployment's compass azimuth (clockwise).
  const double az_deg = -kSunAz * 180.0 / CV_PI, el_deg = kSunEl * 180.0 / CV_PI;
  char buf[2048];
  std::snprintf(buf, sizeof buf, R"(name: terrain_test
dds: {enabled: false}
rover:
  cameras:
    front:
      camera_info: {width: 320, height: 240, k: [%.9f, 0, 159.5, 0, %.9f, 119.5, 0, 0, 1]}
      mount: {z_m: %.3f, pitch_rad: %.3f}
sun: {azimuth_deg: %.9f, elevation_deg: %.9f}
devices:
  cameras:
    front: {backend: synthetic_terrain, rate_hz: 2, frames: 1, speed_m_s: 0, noise_sigma: 0.01}
rate_groups:
  - {name: terrain, rate_hz: 2, members: [sfs, traversability]}
components:
  sfs: {type: sfs, camera: front, method: %s}
  traversability:
    type: traversability
    camera: front
    sfs_frame: %s
    center_x_m: 2.5
    length_x_m: 3.0
    length_y_m: 4.0
)",
                fx, fx, kCamH, kPitch, az_deg, el_deg, method.c_str(), sfs_frame.c_str());
  return buf;
}

class Pipeline : public ::testing::TestWithParam<std::string> {};

TEST_P(Pipeline, GridMapMatchesLibraryAndSceneGeometry) {
  register_once();
  auto app = runtime::Application::load(Params::load_string(deployment(GetParam()), "<test>"),
                                        {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(3 * kNsPerSec, stop);  // warm-up
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  if (std::getenv("REGOLITH_TRACE_ALLOC") != nullptr) regolith::testing::trace_cycle_allocations(1);
  app->run(5 * kNsPerSec, stop);
  const std::uint64_t allocs = regolith::testing::cycle_allocations() - a0;
  auto& ch = app->context().channel<traversability::GridMapFrame>(traversability::kGridMapChannel);
  auto lease = ch.acquire();
  ASSERT_TRUE(lease);
  const traversability::GridMap& g = lease->map;
  std::printf("%s: steady-state allocations in cycles: %llu\n", GetParam().c_str(),
              static_cast<unsigned long long>(allocs));
  EXPECT_EQ(allocs, 0u);  // both methods (Pentland: FFTW plans made on the first frame)
  EXPECT_GT(lease->stamp, 0);
  EXPECT_EQ(lease->stamp % (kNsPerSec / 2), 0);  // a capture time of the 2 Hz camera
  for (const auto* c : app->view().components) {
    EXPECT_EQ(c->errors(), 0u) << c->name();
    // Traversability's ground path reads only the grey image and the sun: nobody reads the DTM
    // heights, so the sfs component does not solve the full frame (issue 17: solve once).
    if (c->name() == "sfs") {
      EXPECT_STREQ(c->status_message(),
                   "no consumer reads the DTM heights: SfS not run (grey image and sun published)");
    }
  }
  {
    auto dtm = app->context().channel<common::DtmFrame>(common::kDtmChannel).acquire();
    ASSERT_TRUE(dtm);
    EXPECT_FALSE(dtm->solved);
    EXPECT_EQ(cv::countNonZero(dtm->valid), 0);
  }

  // Same frame through the libraries directly: the wrapper must reproduce it exactly.
  terrain_scene::SceneParams sp;  // synthetic_terrain defaults
  const terrain_scene::Terrain terrain(sp);
  terrain_scene::CameraPose cam;
  cam.width = 320;
  cam.height = 240;
  cam.fx = cam.fy = 0.5 * 320 / std::tan(0.5 * kHfov);
  cam.cx = 159.5;
  cam.cy = 119.5;
  cam.height_m = kCamH;
  cam.pitch_rad = kPitch;
  terrain_scene::RenderOptions ro;
  ro.noise_sigma = 0.01;
  ro.noise_seed = sp.seed * 1000003ULL;
  const auto img = terrain_scene::render_camera(terrain, cam, terrain_scene::Sun{kSunAz, kSunEl}, ro);
  sfs::SfsParams spar;
  spar.method = sfs::method_from_string(GetParam());
  const auto res = sfs::shape_from_shading(terrain_scene::to_u8(img.image),
                                           sfs::LightDirection{img.light_slant_rad, img.light_tilt_rad}, spar);
  direct_depth::CameraModel m;
  m.fx = m.fy = cam.fx;
  m.cx = 159.5;
  m.cy = 119.5;
  m.width = 320;
  m.height = 240;
  m.mount_height_m = kCamH;
  m.pitch_rad = kPitch;
  const direct_depth::DirectDepth dd(m);
  traversability::TraversabilityParams tp;
  tp.center_x_m = 2.5;
  tp.length_x_m = 3.0;
  tp.length_y_m = 4.0;
  traversability::TraversabilityMapper mapper(dd, tp);
  traversability::GridMap ref;
  // The component's default sfs_frame is ground: it solves the DTM frame's grey image itself.
  mapper.compute_from_image(terrain_scene::to_u8(img.image), {img.light_slant_rad, img.light_tilt_rad}, ref);
  ASSERT_EQ(g.layers, ref.layers);
  ASSERT_EQ(g.size_x(), 60);
  ASSERT_EQ(g.size_y(), 80);
  int known = 0;
  for (std::size_t k = 0; k < g.layers.size(); ++k)
    for (int i = 0; i < g.size_x(); ++i)
      for (int j = 0; j < g.size_y(); ++j) {
        const float a = g.data[k].at<float>(i, j), b = ref.data[k].at<float>(i, j);
        ASSERT_EQ(std::isfinite(a), std::isfinite(b)) << g.layers[k] << " " << i << "," << j;
        if (std::isfinite(a)) {
          EXPECT_NEAR(a, b, 1e-4) << g.layers[k];
        }
        if (k == 0 && std::isfinite(a)) ++known;
      }
  EXPECT_GT(known, 1000);

  // Footprint: cells the camera cannot see are NaN with confidence 0; cells it sees are known.
  int i = 0, j = 0;
  ASSERT_TRUE(g.cell_of(1.1, 1.9, i, j));  // 1.1 m ahead, 1.9 m left: outside the 77 deg view
  EXPECT_TRUE(std::isnan(g.layer("elevation").at<float>(i, j)));
  EXPECT_TRUE(std::isnan(g.layer("traversability").at<float>(i, j)));
  EXPECT_EQ(g.layer("confidence").at<float>(i, j), 0.0f);
  ASSERT_TRUE(g.cell_of(2.5, 0.0, i, j));
  EXPECT_TRUE(std::isfinite(g.layer("traversability").at<float>(i, j)));
  EXPECT_GT(g.layer("confidence").at<float>(i, j), 0.0f);

  // Rocks: the elevation over a visible rock exceeds the ring of ground around it (sign and
  // placement of the projection), on average over the rocks in the map.
  double diff = 0;
  int rocks = 0;
  for (const auto& rk : terrain.rocks()) {
    if (rk.x_m < 1.3 || rk.x_m > 3.8 || std::abs(rk.y_m) > 1.2) continue;
    double on = 0, off = 0;
    int non = 0, noff = 0;
    for (int a = 0; a < g.size_x(); ++a)
      for (int b = 0; b < g.size_y(); ++b) {
        const float e = g.layer("elevation").at<float>(a, b);
        if (!std::isfinite(e)) continue;
        const cv::Point2d p = g.cell_center(a, b);
        const double d = std::hypot((p.x - rk.x_m) / rk.radius_x_m, (p.y - rk.y_m) / rk.radius_y_m);
        if (d < 0.7) {
          on += e;
          ++non;
        } else if (d > 1.5 && d < 2.5) {
          off += e;
          ++noff;
        }
      }
    if (non == 0 || noff == 0) continue;
    diff += on / non - off / noff;
    ++rocks;
  }
  std::printf("%s: %d rocks in the map, mean rock - ring elevation %.4f m\n", GetParam().c_str(), rocks,
              rocks ? diff / rocks : 0.0);
  ASSERT_GT(rocks, 0);
  EXPECT_GT(diff / rocks, 0.0);
  app->stop();
}

TEST_P(Pipeline, AHeightReaderGetsTheSolvedDtmWithoutAllocating) {
  // Traversability on the image-frame heights declares that it reads them: the sfs component
  // solves every frame, allocation-free once running (Pentland: FFTW plans made on the first frame).
  register_once();
  auto app = runtime::Application::load(Params::load_string(deployment(GetParam(), "image"), "<test>"),
                                        {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(3 * kNsPerSec, stop);  // warm-up
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  app->run(5 * kNsPerSec, stop);
  EXPECT_EQ(regolith::testing::cycle_allocations() - a0, 0u);
  app->stop();
  for (const auto* c : app->view().components) {
    EXPECT_EQ(c->errors(), 0u) << c->name();
    if (c->name() == "sfs") {
      EXPECT_STREQ(c->status_message(), "ok");
    }
  }
  auto dtm = app->context().channel<common::DtmFrame>(common::kDtmChannel).acquire();
  ASSERT_TRUE(dtm);
  EXPECT_TRUE(dtm->solved);
  EXPECT_GT(cv::countNonZero(dtm->valid), 320 * 240 / 2);
  auto grid = app->context().channel<traversability::GridMapFrame>(traversability::kGridMapChannel).acquire();
  ASSERT_TRUE(grid);
  const cv::Mat& elev = grid->map.layer("elevation");
  EXPECT_GT(cv::countNonZero(elev == elev), 1000);
}

/// A DTM reader that needs the heights at a quarter of the resolution only (as SAMS's structure
/// channel does); `full: true` makes it a full-resolution reader as well.
class QuarterReader final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    ctx.consume<common::DtmFrame>(common::kDtmChannel);
    ctx.want(common::kDtmChannel, common::kDtmHeightQuarter);
    if (p.get<bool>("full", false)) ctx.want(common::kDtmChannel, common::kDtmHeight);
  }
  void step(const runtime::CycleInfo&) override {}
};

TEST_P(Pipeline, QuarterResolutionReadersGetTheReducedSolve) {
  // Readers that declare only kDtmHeightQuarter (SAMS): the sfs component solves the frame reduced
  // 4x, 16x fewer pixels, and publishes that solve as it is (height_level 2, height4), allocation-free;
  // one full-resolution reader among them brings the full-frame solve back.
  register_once();
  static const bool registered = [] {
    runtime::ComponentRegistry::instance().add("quarter_reader", "test DTM reader (quarter resolution)",
                                               [] { return std::make_unique<QuarterReader>(); });
    return true;
  }();
  (void)registered;
  std::string y = std::regex_replace(deployment(GetParam(), "image"), std::regex("members: \\[sfs, traversability\\]"),
                                     "members: [sfs, reader]");
  y = std::regex_replace(y, std::regex("  traversability:\n(    .*\n)*"), "  reader: {type: quarter_reader}\n");
  cv::Mat quarter_height;
  for (const bool full : {false, true}) {
    const std::string yy =
        full ? std::regex_replace(y, std::regex("type: quarter_reader"), "type: quarter_reader, full: true") : y;
    auto app = runtime::Application::load(Params::load_string(yy, "<test>"), {.sim_time = true, .enable_dds = false});
    std::atomic<bool> stop{false};
    app->start();
    app->run(3 * kNsPerSec, stop);  // warm-up
    const std::uint64_t a0 = regolith::testing::cycle_allocations();
    app->run(5 * kNsPerSec, stop);
    EXPECT_EQ(regolith::testing::cycle_allocations() - a0, 0u) << (full ? "full" : "quarter");
    app->stop();
    for (const auto* c : app->view().components) {
      EXPECT_EQ(c->errors(), 0u) << c->name();
      if (c->name() == "sfs") {
        EXPECT_EQ(diagnostic(*c, "solve_resolution"), full ? "full" : "quarter");
      }
    }
    auto dtm = app->context().channel<common::DtmFrame>(common::kDtmChannel).acquire();
    ASSERT_TRUE(dtm);
    ASSERT_TRUE(dtm->solved);
    EXPECT_EQ(dtm->height_level, full ? 0 : 2);
    if (!full) {
      // The reduced solve as it is (80x60, heights in the frame's pixel units); the frame-size
      // layers are not written.
      ASSERT_EQ(dtm->height4.size(), cv::Size(80, 60));
      EXPECT_GT(cv::countNonZero(dtm->valid4), 80 * 60 / 2);
      EXPECT_EQ(cv::countNonZero(dtm->valid), 0);
      cv::resize(dtm->height4, quarter_height, cv::Size(320, 240), 0, 0, cv::INTER_LINEAR);
      continue;
    }
    ASSERT_EQ(dtm->height.size(), cv::Size(320, 240));
    EXPECT_GT(cv::countNonZero(dtm->valid), 320 * 240 / 2);
    // The reduced solve is the full one seen at a quarter of the resolution: the same relief
    // (heights in the frame's pixel units) once both are smoothed to that scale.
    cv::Mat a, b, mask = dtm->valid.clone();
    cv::Mat qa = quarter_height.clone(), fb = dtm->height.clone();
    cv::patchNaNs(qa, 0.0);
    cv::patchNaNs(fb, 0.0);
    cv::GaussianBlur(qa, a, cv::Size(0, 0), 4.0);
    cv::GaussianBlur(fb, b, cv::Size(0, 0), 4.0);
    cv::Scalar ma, sa, mb, sb;
    cv::meanStdDev(a, ma, sa, mask);
    cv::meanStdDev(b, mb, sb, mask);
    cv::Mat prod;
    cv::multiply(a - ma[0], b - mb[0], prod);
    const double r = cv::mean(prod, mask)[0] / (sa[0] * sb[0]);
    std::printf("%s: quarter vs full solve, Pearson r (smoothed 4 px) %.3f, sd %.3f vs %.3f px\n", GetParam().c_str(),
                r, sa[0], sb[0]);
    EXPECT_GT(r, 0.8);
    // Amplitudes differ by method (Pentland's low-frequency response depends on the image size in
    // pixels: ~4x the full solve's sd here, Tsai-Shah ~1.3x); SAMS normalises each channel.
    EXPECT_GT(sa[0], 0.5 * sb[0]);
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, Pipeline, ::testing::Values("tsai_shah", "pentland"));

TEST(PipelineStamps, FramesStampedBeforeTheLastSolvedOneAreSkippedAndCounted) {
  // The camera's clock steps back 1.2 s for frames 4 and 5 (stamped 0.8 and 1.3 s, after frame 3's
  // 1.5 s; the limit is the 2 s input timeout): sfs skips both, so the DTM and the grid map made
  // from it never go back in time.
  register_once();
  std::string yaml = deployment("pentland");
  const std::string cam = "    front: {backend: synthetic_terrain,";
  const auto at = yaml.find(cam);
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, cam.size(),
               "    front: {backend: fault_injection, stamp_step_after: 4, stamp_step_for: 2, stamp_step_ms: -1200, "
               "inner: {backend: synthetic_terrain,");
  yaml.replace(yaml.find("noise_sigma: 0.01}"), 18, "noise_sigma: 0.01}}");
  auto app = runtime::Application::load(Params::load_string(yaml, "<test>"), {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  auto& dtm = app->context().channel<common::DtmFrame>(common::kDtmChannel);
  auto& grid = app->context().channel<traversability::GridMapFrame>(traversability::kGridMapChannel);
  std::vector<TimeNs> dtm_stamps, grid_stamps;
  for (int k = 0; k < 20; ++k) {  // 5 s in 0.25 s slices: every published frame seen
    app->run(kNsPerSec / 4, stop);
    if (auto l = dtm.acquire(); l && (dtm_stamps.empty() || l->stamp != dtm_stamps.back()))
      dtm_stamps.push_back(l->stamp);
    if (auto l = grid.acquire(); l && (grid_stamps.empty() || l->stamp != grid_stamps.back()))
      grid_stamps.push_back(l->stamp);
  }
  app->stop();
  for (const auto* stamps : {&dtm_stamps, &grid_stamps}) {
    ASSERT_GE(stamps->size(), 6u);
    for (std::size_t i = 1; i < stamps->size(); ++i) EXPECT_GT((*stamps)[i], (*stamps)[i - 1]) << i;
  }
  EXPECT_EQ(diagnostic(*app, "sfs", "frames_out_of_order"), "2");
  EXPECT_EQ(diagnostic(*app, "sfs", "clock_steps"), "0");
  for (const auto* c : app->view().components)
    if (c->name() == "sfs") {
      EXPECT_EQ(c->errors(), 0u);
    }
}

TEST(PipelineConfig, BadSunAndSizeAreConfigErrors) {
  register_once();
  std::string y = deployment("tsai_shah");
  const std::string bad_sun = std::regex_replace(y, std::regex("elevation_deg: [0-9.]+"), "elevation_deg: -5");
  try {
    runtime::Application::load(Params::load_string(bad_sun, "<test>"), {.sim_time = true, .enable_dds = false});
    FAIL() << "sun below the horizon accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("<test>:8:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sun.elevation_deg"), std::string::npos) << e.what();
  }
  // A calibration whose size differs from what the camera delivers: a located configuration
  // error at the device key, before anything runs.
  const std::string bad_size =
      std::regex_replace(y, std::regex("speed_m_s: 0,"), "speed_m_s: 0, width: 640, height: 480,");
  try {
    runtime::Application::load(Params::load_string(bad_size, "<test>"), {.sim_time = true, .enable_dds = false});
    FAIL() << "calibration of another size accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("devices.cameras.front.width: 640x480 px differs from the calibration (320x240 px"),
        std::string::npos)
        << e.what();
  }
  // A flat field that is not an image: located at the key, with the file and the reader's reason
  // (the same reader as `assess --flat-field`).
  const regolith::testing::TempDir tmp("ffcfg");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  std::ofstream(dir / "ff.png") << "not a png";
  const std::string bad_ff = std::regex_replace(y, std::regex("method: tsai_shah"),
                                                "method: tsai_shah, flat_field: " + (dir / "ff.png").string());
  try {
    runtime::Application::load(Params::load_string(bad_ff, "<test>"), {.sim_time = true, .enable_dds = false});
    FAIL() << "unreadable flat field accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("flat_field: '" + (dir / "ff.png").string() + "': not an image regolith reads"),
        std::string::npos)
        << e.what();
  }
}

TEST(PipelineConfig, SunAheadOfTheCameraIsNormalForTheGroundPath) {
  // Sun in front of the rover, low: behind the image plane of the forward camera (image slant
  // >= 90 deg). Image-frame SfS has nothing to invert; the sfs component says so in its status and
  // still publishes the grey frame and the sun; traversability's ground-frame path maps it.
  register_once();
  const std::string y =
      std::regex_replace(deployment("tsai_shah"), std::regex("azimuth_deg: [-0-9.]+, elevation_deg: [0-9.]+"),
                         "azimuth_deg: 10, elevation_deg: 15");
  auto app = runtime::Application::load(Params::load_string(y, "<test>"), {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(3 * kNsPerSec, stop);
  app->stop();
  for (const auto* c : app->view().components) {
    EXPECT_EQ(c->errors(), 0u) << c->name();
    if (c->name() == "sfs") {
      EXPECT_NE(std::string(c->status_message()).find("sun ahead of the camera"), std::string::npos)
          << c->status_message();
    }
  }
  auto& ch = app->context().channel<traversability::GridMapFrame>(traversability::kGridMapChannel);
  auto lease = ch.acquire();
  ASSERT_TRUE(lease);
  const cv::Mat& elev = lease->map.layer("elevation");
  const int known = cv::countNonZero(elev == elev);  // not NaN
  std::printf("sun ahead: %d of %d cells mapped\n", known, static_cast<int>(elev.total()));
  EXPECT_GT(known, static_cast<int>(elev.total() / 4));
}

#ifdef REGOLITH_TOOL
int run_tool(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(REGOLITH_TOOL) + " " + args + " > " + log.string() + " 2>&1";
  const int st = std::system(cmd.c_str());
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}
// A 320x240 frame (f = 300 px) of the terrain `rp` with one dome of `radius_m` and `height_m`
// at (x_m, 0), seen from a camera `cam_height_m` up, pitched `pitch_rad` down; the sun at
// azimuth 2.2 rad, elevation 0.6 rad.
terrain_scene::CameraImage render_dome(const terrain_scene::SceneParams& rp, double x_m, double radius_m,
                                       double height_m, double cam_height_m, double pitch_rad) {
  const terrain_scene::Terrain flat(rp);
  cv::Mat hf = flat.height().clone();
  for (int r = 0; r < hf.rows; ++r)
    for (int c = 0; c < hf.cols; ++c) {
      const double x = flat.x_max() - r * flat.resolution(), y = flat.y_max() - c * flat.resolution();
      const double q = 1 - (std::pow((x - x_m) / radius_m, 2) + std::pow(y / radius_m, 2));
      if (q > 0) hf.at<float>(r, c) += static_cast<float>(height_m * std::sqrt(q));
    }
  const terrain_scene::Terrain rock(hf, flat.resolution(), flat.x_max(), flat.y_max());
  terrain_scene::CameraPose pose;
  pose.width = 320;
  pose.height = 240;
  pose.fx = pose.fy = 300;
  pose.cx = 159.5;
  pose.cy = 119.5;
  pose.height_m = cam_height_m;
  pose.pitch_rad = pitch_rad;
  return terrain_scene::render_camera(rock, pose, terrain_scene::Sun{2.2, 0.6});
}

// `regolith assess IMAGE --out OUT` for a frame of render_dome: its camera (f = 300 px,
// 320x240), its height and pitch, and the light the renderer reports.
std::string assess_dome_args(const fs::path& image, const fs::path& out, const terrain_scene::CameraImage& img,
                             double cam_height_m, double pitch_rad) {
  char args[768];
  std::snprintf(
      args, sizeof args,
      "assess %s --out %s --sun-slant %.4f --sun-tilt %.4f --camera 300,300,159.5,119.5 --height %g --pitch %.4f",
      image.c_str(), out.c_str(), img.light_slant_rad * 180 / CV_PI, img.light_tilt_rad * 180 / CV_PI, cam_height_m,
      pitch_rad * 180 / CV_PI);
  return args;
}

TEST(AssessCli, WritesOutputsAndRejectsBadInput) {
  const regolith::testing::TempDir tmp("assess");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  // A rendered orthographic patch with a known sun.
  terrain_scene::SceneParams sp;
  sp.x_min_m = 0;
  sp.x_max_m = 3.2;
  sp.y_min_m = -1.6;
  sp.y_max_m = 1.6;
  sp.place_x_min_m = 0.4;
  sp.place_x_max_m = 2.8;
  sp.place_y_abs_max_m = 1.2;
  sp.num_rocks = 8;
  sp.num_craters = 1;
  sp.rock_radius_min_m = 0.12;
  sp.rock_radius_max_m = 0.25;
  const terrain_scene::Terrain t(sp);
  const auto o = terrain_scene::render_ortho(t, terrain_scene::Sun{135 * CV_PI / 180, 35 * CV_PI / 180});
  const fs::path png = dir / "patch.png";
  ASSERT_TRUE(cv::imwrite(png.string(), terrain_scene::to_u8(o.image)));
  char args[512];
  std::snprintf(args, sizeof args, "assess %s --out %s --sun-slant %.4f --sun-tilt %.4f --pixel-size 0.02", png.c_str(),
                (dir / "out").c_str(), o.light_slant_rad * 180 / CV_PI, o.light_tilt_rad * 180 / CV_PI);
  ASSERT_EQ(run_tool(args, dir / "log.txt"), 0) << read_file(dir / "log.txt");
  const cv::Mat h = cv::imread((dir / "out" / "height.tiff").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(h.type(), CV_32FC1);
  ASSERT_EQ(h.size(), o.image.size());
  // Height up: correlates positively with the truth.
  cv::Mat hd, td;
  h.convertTo(hd, CV_64F);
  o.height_px.convertTo(td, CV_64F);
  cv::Scalar mh, sh, mt, st;
  cv::meanStdDev(hd, mh, sh);
  cv::meanStdDev(td, mt, st);
  const double r = cv::mean((hd - mh[0]).mul(td - mt[0]))[0] / (sh[0] * st[0]);
  std::printf("assess: height.tiff vs truth r = %.3f\n", r);
  EXPECT_GT(r, 0.5);
  for (const char* f :
       {"height_heatmap.png", "hillshade.png", "elevation.png", "traversability.png", "traversability_slope.png",
        "traversability_step.png", "traversability_roughness.png", "confidence.png"})
    EXPECT_FALSE(cv::imread((dir / "out" / f).string()).empty()) << f;
  const auto j = nlohmann::json::parse(read_file(dir / "out" / "summary.json"));
  EXPECT_EQ(j["method"], "pentland");  // library default (most accurate per ms)
  EXPECT_EQ(j["light"]["source"], "given");
  EXPECT_NEAR(j["light"]["slant_deg"].get<double>(), o.light_slant_rad * 180 / CV_PI, 1e-3);
  EXPECT_GE(j["iterations"].get<int>(), 1);
  EXPECT_TRUE(j["timings_ms"].contains("sfs"));
  EXPECT_TRUE(j["hazards"].is_array());

  // Bad inputs: exit code 2 and a message naming the file / option.
  std::ofstream(dir / "not_an_image.png") << "hello";
  EXPECT_EQ(
      run_tool("assess " + (dir / "not_an_image.png").string() + " --out " + (dir / "o2").string(), dir / "e1.txt"), 2);
  EXPECT_NE(read_file(dir / "e1.txt").find("not_an_image.png"), std::string::npos) << read_file(dir / "e1.txt");
  EXPECT_EQ(run_tool("assess " + (dir / "missing.png").string() + " --out " + (dir / "o2").string(), dir / "e2.txt"),
            2);
  EXPECT_NE(read_file(dir / "e2.txt").find("missing.png"), std::string::npos);
  // The same patch as a 12-bit camera stores it (0..4095 in a 16-bit PNG) is assessed as its 8-bit
  // copy: the samples are scaled by the bits the image uses, not shifted by 8 (which left 0..15).
  {
    cv::Mat twelve;
    cv::imread(png.string(), cv::IMREAD_UNCHANGED).convertTo(twelve, CV_16U, 4095.0 / 255.0);
    ASSERT_TRUE(cv::imwrite((dir / "deep.png").string(), twelve));
    std::snprintf(args, sizeof args, "assess %s --out %s --sun-slant %.4f --sun-tilt %.4f --pixel-size 0.02",
                  (dir / "deep.png").c_str(), (dir / "o12").c_str(), o.light_slant_rad * 180 / CV_PI,
                  o.light_tilt_rad * 180 / CV_PI);
    ASSERT_EQ(run_tool(args, dir / "e3.txt"), 0) << read_file(dir / "e3.txt");
    const cv::Mat h12 = cv::imread((dir / "o12" / "height.tiff").string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(h12.size(), h.size());
    EXPECT_EQ(cv::norm(h12, h, cv::NORM_INF), 0.0);
    const auto j12 = nlohmann::json::parse(read_file(dir / "o12" / "summary.json"));
    EXPECT_EQ(j12["hazards"], j["hazards"]);
  }
  EXPECT_EQ(run_tool("assess " + png.string() + " --out " + (dir / "o2").string() + " --sun-slant 95 --sun-tilt 0",
                     dir / "e4.txt"),
            2);
  EXPECT_NE(read_file(dir / "e4.txt").find("--sun-slant 95 deg: must be 0 to below 90 deg"), std::string::npos)
      << read_file(dir / "e4.txt");
  // NaN was taken for "not given" ("--sun-slant and --sun-tilt must be given together").
  EXPECT_EQ(run_tool("assess " + png.string() + " --out " + (dir / "o2").string() + " --sun-slant nan --sun-tilt 0",
                     dir / "e4n.txt"),
            2);
  EXPECT_NE(read_file(dir / "e4n.txt").find("--sun-slant: must be a finite number (got nan)"), std::string::npos)
      << read_file(dir / "e4n.txt");
  // A file name that is not UTF-8 (Linux names are bytes): summary.json is still written, the
  // name's bad byte as U+FFFD (json threw on it and the run ended without summary.json).
  const fs::path latin1 = dir / "caf\xe9.png";
  fs::copy_file(png, latin1, fs::copy_options::overwrite_existing);
  EXPECT_EQ(run_tool("assess " + latin1.string() + " --out " + (dir / "o8").string() + " --sun-slant 30 --sun-tilt 0",
                     dir / "e8.txt"),
            0)
      << read_file(dir / "e8.txt");
  const auto j8 = nlohmann::json::parse(read_file(dir / "o8" / "summary.json"));
  EXPECT_NE(j8["image"].get<std::string>().find("caf\xEF\xBF\xBD.png"), std::string::npos) << j8["image"];
  // A flat field with a black pixel, and one that is not an image: the option, the file and why.
  cv::Mat ff_zero(64, 64, CV_8U, cv::Scalar(200));
  ff_zero.at<uchar>(3, 3) = 0;
  ASSERT_TRUE(cv::imwrite((dir / "ff_zero.png").string(), ff_zero));
  EXPECT_EQ(run_tool("assess " + png.string() + " --out " + (dir / "o2").string() +
                         " --sun-slant 30 --sun-tilt 0 --flat-field " + (dir / "ff_zero.png").string(),
                     dir / "e6.txt"),
            2);
  EXPECT_NE(read_file(dir / "e6.txt").find("--flat-field '" + (dir / "ff_zero.png").string() + "': it has pixels of 0"),
            std::string::npos)
      << read_file(dir / "e6.txt");
  EXPECT_EQ(run_tool("assess " + png.string() + " --out " + (dir / "o2").string() +
                         " --sun-slant 30 --sun-tilt 0 --flat-field " + (dir / "not_an_image.png").string(),
                     dir / "e7.txt"),
            2);
  EXPECT_NE(read_file(dir / "e7.txt").find("not_an_image.png': not an image regolith reads"), std::string::npos)
      << read_file(dir / "e7.txt");
  // Camera pointing above the horizon: no crash, an all-unknown map and a warning.
  EXPECT_EQ(run_tool("assess " + png.string() + " --out " + (dir / "o3").string() +
                         " --sun-slant 40 --sun-tilt 45 --camera 200,200,160,160 --height 0.5 --pitch -60",
                     dir / "e5.txt"),
            0)
      << read_file(dir / "e5.txt");
  const auto j3 = nlohmann::json::parse(read_file(dir / "o3" / "summary.json"));
  EXPECT_EQ(j3["grid"]["known_cells"].get<int>(), 0);
  EXPECT_TRUE(j3.contains("warning"));
  // Camera mode on a rendered rover frame: the ground-rectified path (default) writes the
  // rectified input and a metric grid in which a 10+ cm rock ahead is a hazard.
  {
    terrain_scene::SceneParams rp;
    rp.seed = 5;
    rp.fractal_rms_m = 0.003;
    rp.num_craters = 0;
    rp.num_rocks = 0;
    rp.x_min_m = -1;
    rp.x_max_m = 8;
    rp.y_min_m = -4;
    rp.y_max_m = 4;
    // One 0.30 m x 0.30 m, 0.15 m tall dome at x = 2 m, y = 0.
    const auto cimg = render_dome(rp, 2.0, 0.15, 0.15, 0.6, 0.45);
    ASSERT_TRUE(cv::imwrite((dir / "rover.png").string(), terrain_scene::to_u8(cimg.image)));
    const std::string cargs = assess_dome_args(dir / "rover.png", dir / "cam", cimg, 0.6, 0.45);
    ASSERT_EQ(run_tool(cargs, dir / "cam.txt"), 0) << read_file(dir / "cam.txt");
    const auto jc = nlohmann::json::parse(read_file(dir / "cam" / "summary.json"));
    EXPECT_EQ(jc["grid_sfs_frame"], "ground");
    // The sun's elevation above the ground, from the image slant / tilt and the camera's pitch:
    // the renderer's 0.6 rad.
    EXPECT_NEAR(jc["light"]["ground_elevation_deg"].get<double>(), 0.6 * 180 / CV_PI, 0.05);
    EXPECT_FALSE(jc.contains("warning")) << jc["warning"];
    // A sun given below the ground plane (tilt towards the image bottom, past the pitch): the
    // run still writes its outputs, with every cell unknown and a warning that says why.
    ASSERT_EQ(run_tool("assess " + (dir / "rover.png").string() + " --out " + (dir / "below").string() +
                           " --sun-slant 48 --sun-tilt 90 --camera 300,300,159.5,119.5 --height 0.6 --pitch 25.78",
                       dir / "below.txt"),
              0)
        << read_file(dir / "below.txt");
    const auto jb = nlohmann::json::parse(read_file(dir / "below" / "summary.json"));
    EXPECT_LT(jb["light"]["ground_elevation_deg"].get<double>(), 0.0);
    EXPECT_EQ(jb["grid"]["known_cells"].get<int>(), 0);
    EXPECT_NE(jb.value("warning", "").find("the sun is not above the ground plane (elevation -"), std::string::npos)
        << jb.dump();
    EXPECT_NE(read_file(dir / "below.txt").find("warning: the sun is not above the ground plane"), std::string::npos)
        << read_file(dir / "below.txt");
    // An all-black frame (a lens cap, a night frame): the warning says there is no shading to read,
    // not that the camera looks above the horizon.
    ASSERT_TRUE(cv::imwrite((dir / "black.png").string(), cv::Mat(240, 320, CV_8U, cv::Scalar(0))));
    ASSERT_EQ(run_tool("assess " + (dir / "black.png").string() + " --out " + (dir / "black").string() +
                           " --sun-slant 48 --sun-tilt -90 --camera 300,300,159.5,119.5 --height 0.6 --pitch 25.78",
                       dir / "black.txt"),
              0)
        << read_file(dir / "black.txt");
    const auto jk = nlohmann::json::parse(read_file(dir / "black" / "summary.json"));
    EXPECT_EQ(
        jk.value("warning", ""),
        "no shading to read: 0 of 76800 pixels are neither black, saturated nor in shadow; every grid cell unknown")
        << jk.dump();
    EXPECT_GT(jc["grid"]["known_cells"].get<int>(), 1000);
    EXPECT_FALSE(cv::imread((dir / "cam" / "rectified.png").string()).empty());
    bool rock_hazard = false;
    for (const auto& hz : jc["hazards"]) {
      std::printf("assess camera mode: hazard at %.2f, %.2f m, max elevation %.3f m\n", hz["x_m"].get<double>(),
                  hz["y_m"].get<double>(), hz["max_elevation_m"].get<double>());
      if (std::abs(hz["x_m"].get<double>() - 2.0) < 0.5 && std::abs(hz["y_m"].get<double>()) < 0.4) rock_hazard = true;
    }
    EXPECT_TRUE(rock_hazard) << read_file(dir / "cam" / "summary.json");
    EXPECT_TRUE(jc["edge_hazards"].is_array());
    // The hazards drawn on the camera image: overlay.png is the frame (+ a caption strip) with
    // the rock's hazard cells painted red around where the dome stands (2 m ahead, centre).
    const cv::Mat ov = cv::imread((dir / "cam" / "overlay.png").string());
    ASSERT_FALSE(ov.empty());
    EXPECT_EQ(ov.cols, 320);
    EXPECT_EQ(ov.rows, 240 + 26);
    const auto rock_px = direct_depth::DirectDepth(
                             direct_depth::CameraModel{300, 300, 159.5, 119.5, 0, 0, 0, 0, 0, 320, 240, 0.6, 0.45, 0})
                             .project(2.0, 0.0);
    ASSERT_TRUE(rock_px);
    int red_near = 0, red_far = 0;
    for (int py = 0; py < 240; ++py)
      for (int px = 0; px < 320; ++px) {
        const cv::Vec3b v = ov.at<cv::Vec3b>(py, px);
        if (!(v[2] > v[1] + 60 && v[2] > v[0] + 60)) continue;
        (std::hypot(px - rock_px->x, py - rock_px->y) < 60 ? red_near : red_far) += 1;
      }
    EXPECT_GT(red_near, 100) << "hazard paint around the rock at " << rock_px->x << ", " << rock_px->y;
    EXPECT_GT(red_near, red_far);
    // The rock itself, ranged and sized from the image (summary.json "rocks", rocks.csv): the
    // dome is 0.30 m wide, 0.15 m tall, centred 2 m ahead; range.tiff = DirectDepth's range map.
    const nlohmann::json* dome = nullptr;
    for (const auto& rk : jc["rocks"]) {
      std::printf("assess camera mode: rock at %.2f, %.2f m, %.3f m wide, %.3f m tall, box %s\n",
                  rk["range_m"].get<double>(), rk["lateral_m"].get<double>(), rk["width_m"].get<double>(),
                  rk["height_m"].get<double>(), rk["box_px"].dump().c_str());
      if (std::abs(rk["range_m"].get<double>() - 2.0) < 0.3 && std::abs(rk["lateral_m"].get<double>()) < 0.2)
        dome = &rk;
    }
    ASSERT_NE(dome, nullptr) << jc["rocks"].dump();
    EXPECT_NEAR((*dome)["width_m"].get<double>(), 0.30, 0.35 * 0.30);  // measured 0.39 (its side shadow)
    EXPECT_NEAR((*dome)["height_m"].get<double>(), 0.15, 0.3 * 0.15);  // measured 0.153
    EXPECT_FALSE((*dome)["height_is_lower_bound"].get<bool>());
    ASSERT_TRUE((*dome)["height_sfs_m"].is_number()) << dome->dump();  // the ground solve's height of it
    std::printf("assess camera mode: the dome's SfS height %.3f m\n", (*dome)["height_sfs_m"].get<double>());
    // measured 0.067 m: the ground solve under-reads a rock (0.45 of it), but sees it
    EXPECT_GT((*dome)["height_sfs_m"].get<double>(), 0.04);
    EXPECT_LT((*dome)["height_sfs_m"].get<double>(), 0.2);
    EXPECT_EQ(jc["outputs"]["rocks"], "rocks.csv");
    EXPECT_EQ(
        read_file(dir / "cam" / "rocks.csv")
            .rfind(
                "id,range_m,lateral_m,width_m,height_m,height_is_lower_bound,score,xmin,ymin,xmax,ymax,height_sfs_m\n",
                0),
        0u);
    const cv::Mat range =
        cv::imread((dir / "cam" / jc["outputs"]["range"].get<std::string>()).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(range.type(), CV_32FC1);
    const direct_depth::DirectDepth dd(
        direct_depth::CameraModel{300, 300, 159.5, 119.5, 0, 0, 0, 0, 0, 320, 240, 0.6, 0.45, 0});
    EXPECT_NEAR(range.at<float>(200, 160), dd.ground(160, 200).range_m, 1e-4);
    EXPECT_NE(run_tool(std::string(cargs) + " --sfs-frame sideways", dir / "cam2.txt"), 0);
    EXPECT_NE(read_file(dir / "cam2.txt").find("--sfs-frame"), std::string::npos) << read_file(dir / "cam2.txt");

    // The same frame with the camera and sun taken from a deployment's rover description
    // (--rover FILE --device NAME): the same light (to the 1e-4 deg printed above) and hazards.
    char dep[1024];
    std::snprintf(dep, sizeof dep, R"(rover:
  cameras:
    front:
      camera_info: {width: 320, height: 240, k: [300, 0, 159.5, 0, 300, 119.5, 0, 0, 1]}
      mount: {z_m: 0.6, pitch_rad: 0.45}
sun: {azimuth_deg: %.9f, elevation_deg: %.9f}
)",
                  -2.2 * 180 / CV_PI, 0.6 * 180 / CV_PI);
    std::ofstream(dir / "deployment.yaml") << dep;
    const std::string rargs = "assess " + (dir / "rover.png").string() + " --out " + (dir / "cam3").string() +
                              " --rover " + (dir / "deployment.yaml").string() + " --device front";
    ASSERT_EQ(run_tool(rargs, dir / "cam3.txt"), 0) << read_file(dir / "cam3.txt");
    const auto jr = nlohmann::json::parse(read_file(dir / "cam3" / "summary.json"));
    EXPECT_NEAR(jr["light"]["slant_deg"].get<double>(), jc["light"]["slant_deg"].get<double>(), 1e-3);
    EXPECT_NEAR(jr["light"]["tilt_deg"].get<double>(), jc["light"]["tilt_deg"].get<double>(), 1e-3);
    EXPECT_EQ(jr["light"]["source"], "given");
    EXPECT_EQ(jr["hazards"].size(), jc["hazards"].size());
    std::string rear = rargs;
    rear.replace(rear.rfind("front"), 5, "rear");
    EXPECT_EQ(run_tool(rear, dir / "cam4.txt"), 2);
    EXPECT_NE(read_file(dir / "cam4.txt").find("no rover.cameras.rear (described: front)"), std::string::npos)
        << read_file(dir / "cam4.txt");
  }
  // Terrain without a sun: the estimator is not trusted -> clear error, exit 2.
  EXPECT_EQ(run_tool("assess " + png.string() + " --out " + (dir / "o4").string(), dir / "e6.txt"), 2);
  EXPECT_NE(read_file(dir / "e6.txt").find("--sun-slant"), std::string::npos) << read_file(dir / "e6.txt");
  // One line: what to pass, and why (the shading cannot be solved without the sun).
  EXPECT_NE(read_file(dir / "e6.txt").find("--rover DEPLOYMENT.yaml"), std::string::npos) << read_file(dir / "e6.txt");
  EXPECT_NE(read_file(dir / "e6.txt").find("shape from shading needs it"), std::string::npos)
      << read_file(dir / "e6.txt");
  const std::string e6 = read_file(dir / "e6.txt");
  EXPECT_EQ(std::count(e6.begin(), e6.end(), '\n'), 1) << e6;

  // calibrate vignetting on a synthetic flat field with known coefficients.
  cv::Mat ff(240, 320, CV_8U);
  const double hd2 = std::hypot(160.0, 120.0);
  for (int rr = 0; rr < ff.rows; ++rr)
    for (int cc = 0; cc < ff.cols; ++cc) {
      const double q = std::hypot(cc - 159.5, rr - 119.5) / hd2, q2 = q * q;
      ff.at<uchar>(rr, cc) = cv::saturate_cast<uchar>(220 * (1 - 0.3 * q2 + 0.04 * q2 * q2));
    }
  ASSERT_TRUE(cv::imwrite((dir / "flat.png").string(), ff));
  ASSERT_EQ(run_tool("calibrate vignetting " + (dir / "flat.png").string(), dir / "v.txt"), 0)
      << read_file(dir / "v.txt");
  const std::string v = read_file(dir / "v.txt");
  const auto a2pos = v.find("vignetting_a2: ");
  ASSERT_NE(a2pos, std::string::npos) << v;
  EXPECT_NEAR(std::stod(v.substr(a2pos + 15)), -0.3, 0.03) << v;
  EXPECT_EQ(run_tool("calibrate vignetting " + (dir / "nope.png").string(), dir / "v2.txt"), 2);
  EXPECT_NE(read_file(dir / "v2.txt").find("nope.png"), std::string::npos);
}

// A camera close to the ground (0.3 m up, 52 deg down: 0.1-0.5 m of view) gets a 1 cm grid.
// Every cell the camera sees is known (the ground solve's rectified cells are at most half a
// grid cell: with the default 2 cm ones, rows and columns of the 1 cm grid had no sample and the
// holes read as hazards); the 8 cm dome 0.33 m ahead is one counted hazard even where its red
// ground runs on to the edge of the view; the height picture paints its elevation on the image.
TEST(AssessCli, ACloseCameraMapsEveryCellItSeesAndDrawsHeightsOnTheImage) {
  const regolith::testing::TempDir tmp("assess_close");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  terrain_scene::SceneParams rp;
  rp.seed = 7;
  rp.fractal_rms_m = 0.001;
  rp.num_craters = 0;
  rp.num_rocks = 0;
  rp.x_min_m = -0.5;
  rp.x_max_m = 2;
  rp.y_min_m = -1;
  rp.y_max_m = 1;
  rp.resolution_m = 0.002;
  const double rx = 0.33;
  const auto img = render_dome(rp, rx, 0.06, 0.08, 0.3, 0.9);
  ASSERT_TRUE(cv::imwrite((dir / "close.png").string(), terrain_scene::to_u8(img.image)));
  const std::string args = assess_dome_args(dir / "close.png", dir / "out", img, 0.3, 0.9);
  ASSERT_EQ(run_tool(args, dir / "out.txt"), 0) << read_file(dir / "out.txt");
  const auto j = nlohmann::json::parse(read_file(dir / "out" / "summary.json"));
  const auto& g = j["grid"];
  const double res = g["resolution_m"].get<double>();
  EXPECT_LE(res, 0.012);
  // Cells whose centre the camera sees, against the known ones.
  const direct_depth::DirectDepth dd(
      direct_depth::CameraModel{300, 300, 159.5, 119.5, 0, 0, 0, 0, 0, 320, 240, 0.3, 0.9, 0});
  const int nx = static_cast<int>(std::lround(g["length_x_m"].get<double>() / res));
  const int ny = static_cast<int>(std::lround(g["length_y_m"].get<double>() / res));
  int seen = 0;
  for (int i = 0; i < nx; ++i)
    for (int k = 0; k < ny; ++k) {
      const double x = g["center_x_m"].get<double>() + 0.5 * nx * res - (i + 0.5) * res;
      const double y = g["center_y_m"].get<double>() + 0.5 * ny * res - (k + 0.5) * res;
      const auto p = dd.project(x, y);
      seen += (p && p->x >= 0 && p->y >= 0 && p->x <= 319 && p->y <= 239) ? 1 : 0;
    }
  const int known = g["known_cells"].get<int>();
  std::printf("close camera: %d of %d seen cells known (%.1f cm cells)\n", known, seen, 100 * res);
  EXPECT_GE(known, 0.97 * seen);
  int at_rock = 0;
  for (const auto& hz : j["hazards"])
    if (std::hypot(hz["x_m"].get<double>() - rx, hz["y_m"].get<double>()) < 0.1) ++at_rock;
  EXPECT_EQ(at_rock, 1) << j["hazards"].dump() << " edge: " << j["edge_hazards"].dump();
  // height_heatmap.png: the camera image with the elevation painted on it, warm at the dome.
  const cv::Mat heat = cv::imread((dir / "out" / "height_heatmap.png").string());
  ASSERT_FALSE(heat.empty());
  const auto px = dd.project(rx, 0.0);
  ASSERT_TRUE(px);
  // The picture is the 320 x 240 image scaled to 400 rows, 12 px in, below 58 px of title.
  const double f = 400.0 / 240;
  const cv::Vec3b at = heat.at<cv::Vec3b>(58 + static_cast<int>(px->y * f), 12 + static_cast<int>(px->x * f));
  EXPECT_GT(at[2], at[0] + 40) << "not warm at the dome: " << at;
}

// Rocks sized from one perspective image on the independent renderer's development scenes
// (persp_dev_*): each measurable rock (>= 30 visible px, not on the border, < 30 % occluded)
// matched to the reported box with the largest IoU (> 0.2), its width and height errors as the
// thesis reports them (|derived - truth| / truth). persp_dev_0's sun is ahead of the camera
// (image slant 92.7 deg): no image-frame SfS, but the ground path and the rocks still run.
TEST(AssessCli, RockSizesOnTheDevelopmentPerspectiveScenes) {
  const fs::path root = fs::path(REGOLITH_SHARED_DIR) / "data" / "synthetic_dev" / "sfs";
  if (!fs::exists(root / "persp_dev_0")) GTEST_SKIP() << root << " not present";
  const regolith::testing::TempDir tmp("assess_persp");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  std::vector<double> werr, herr;                         // persp_dev_0 and _1 (the first two scenes)
  std::map<std::string, std::vector<double>> sfs_err;     // per scene: the grid's SfS height of each boxed rock
  std::map<std::string, std::vector<double>> scene_herr;  // per scene: the box height's error
  int sfs_missing = 0;
  int measurable = 0;
  int false_boxes = 0, below_min_score = 0;
  for (const char* name : {"persp_dev_0", "persp_dev_1", "persp_dev_2", "persp_dev_3"}) {
    if (!fs::exists(root / name)) continue;
    const bool first_two = std::string(name) == "persp_dev_0" || std::string(name) == "persp_dev_1";
    const auto in = nlohmann::json::parse(read_file(root / name / "input.json"));
    // The scene's own description (--scene): camera, mount and the world sun, which assess turns
    // into the image frame itself; the renderer's image-frame sun is the check of that conversion.
    const std::string args = "assess " + (root / name / "image.png").string() + " --out " + (dir / name).string() +
                             " --scene " + (root / name / "input.json").string();
    ASSERT_EQ(run_tool(args, dir / (std::string(name) + ".txt")), 0) << read_file(dir / (std::string(name) + ".txt"));
    const auto summary = nlohmann::json::parse(read_file(dir / name / "summary.json"));
    EXPECT_EQ(summary["mode"], "camera");
    EXPECT_NEAR(summary["light"]["slant_deg"].get<double>(), in["sun_slant_deg_image"].get<double>(), 0.01);
    EXPECT_NEAR(
        std::remainder(summary["light"]["tilt_deg"].get<double>() - in["sun_tilt_deg_image"].get<double>(), 360.0), 0.0,
        0.01);
    if (in["sun_slant_deg_image"].get<double>() >= 90.0) {
      EXPECT_NE(summary["image_sfs"].get<std::string>().find("sun ahead of the camera"), std::string::npos);
      EXPECT_GT(summary["grid"]["known_cells"].get<int>(), 0);
      // No image-frame heights to shade: hillshade.png shades the grid's elevation instead of
      // being black (grey ground, blue unknown cells).
      const cv::Mat hs = cv::imread((dir / name / "hillshade.png").string());
      ASSERT_FALSE(hs.empty());
      int grey = 0;
      for (auto it = hs.begin<cv::Vec3b>(); it != hs.end<cv::Vec3b>(); ++it)
        grey += ((*it)[0] == (*it)[1] && (*it)[1] == (*it)[2] && (*it)[0] > 60 && (*it)[0] < 250) ? 1 : 0;
      EXPECT_GT(grey, static_cast<int>(hs.total() / 5)) << "hillshade.png mostly black or white";
    }
    // Scored by `regolith eval assess` (each measurable rock's box of largest IoU > 0.2; boxes on
    // no rock: IoU <= 0.2 with every rock of >= 10 visible px, i.e. texture and shadows).
    const fs::path scored = dir / (std::string(name) + ".eval.json");
    ASSERT_EQ(run_tool("eval assess " + (root / name).string() + " --out " + (dir / name).string(), scored), 0)
        << read_file(scored);
    const auto ev = nlohmann::json::parse(read_file(scored));
    false_boxes += ev["boxes_on_no_rock"].get<int>();
    below_min_score += ev["rocks_below_min_score"].get<int>();
    EXPECT_EQ(ev["reported_boxes"].get<std::size_t>(), summary["rocks"].size());
    for (const auto& row : ev["rocks"]) {
      measurable += first_two;
      if (!row["matched"].get<bool>()) continue;
      const double th = row["height_m"].get<double>();
      const double he = std::abs(row["reported_height_m"].get<double>() / th - 1);
      scene_herr[name].push_back(he);
      if (!first_two) continue;
      werr.push_back(std::abs(row["reported_width_m"].get<double>() / row["width_m"].get<double>() - 1));
      herr.push_back(he);
      if (!row.contains("reported_height_sfs_m"))
        ++sfs_missing;
      else
        sfs_err[name].push_back(std::abs(row["reported_height_sfs_m"].get<double>() / th - 1));
    }
    EXPECT_EQ(ev["boxed"].get<std::size_t>(), scene_herr[name].size());
  }
  ASSERT_GT(measurable, 10);
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  ASSERT_FALSE(werr.empty());
  std::printf("persp_dev: %zu of %d measurable rocks boxed; median width error %.0f %%, height error %.0f %%\n",
              werr.size(), measurable, 100 * median(werr), 100 * median(herr));
  EXPECT_GE(werr.size() * 10, static_cast<std::size_t>(measurable) * 9);  // measured 19 of 19
  EXPECT_LT(median(werr), 0.15);                                          // measured 9 % (goal 15 %)
  EXPECT_LT(median(herr), 0.25);  // measured 14 % (goal 25 %; the thesis' box formula ~138 %)
  // Every scene on its own (steep views with the sun behind read the silhouette's top, not the
  // apex's, without the sun-aware height: persp_dev_1 78 %, persp_dev_3 58 %; measured 14 / 17 /
  // 16 / 15 % with it).
  // The contrast score's floor (--min-rock-score 0.35) leaves out texture and shadow blobs: 6 boxes
  // on no rock in the four scenes with every blob listed, 0 with the floor, and no rock lost.
  std::printf("persp_dev: %d boxes on no rock, %d blobs below the score floor\n", false_boxes, below_min_score);
  EXPECT_LE(false_boxes, 1);
  EXPECT_GE(below_min_score, 4);
  for (const auto& [scene, errors] : scene_herr) {
    ASSERT_GE(errors.size(), 5u) << scene;
    std::printf("%s: %zu rocks boxed, median height error %.0f %%\n", scene.c_str(), errors.size(),
                100 * median(errors));
    EXPECT_LT(median(errors), 0.25) << scene;
  }
  // The shading's own height of each rock (summary.json height_sfs_m): reported for every boxed
  // rock; close to the truth with the sun ahead (persp_dev_0, measured median error 17 %), far
  // below it on persp_dev_1 (~90 %: its low camera and a sun from behind flatten the ground solve).
  EXPECT_EQ(sfs_missing, 0);
  ASSERT_EQ(sfs_err["persp_dev_0"].size(), 9u);
  std::printf("persp_dev: SfS rock heights, median error %.0f %% (persp_dev_0), %.0f %% (persp_dev_1)\n",
              100 * median(sfs_err["persp_dev_0"]), 100 * median(sfs_err["persp_dev_1"]));
  EXPECT_LT(median(sfs_err["persp_dev_0"]), 0.25);
}

// `regolith eval assess` on files it cannot score: one line naming the file and the field, exit 2.
TEST(AssessCli, EvalAssessNamesTheFileAndFieldItCannotScore) {
  const regolith::testing::TempDir tmp("eval_assess_bad");
  const fs::path& dir = tmp.path();
  fs::create_directories(dir / "scene");
  fs::create_directories(dir / "out");
  const fs::path log = dir / "log.txt";
  // No truth.json in the scene.
  EXPECT_EQ(run_tool("eval assess " + (dir / "scene").string() + " --out " + (dir / "out").string(), log), 2);
  EXPECT_NE(read_file(log).find("truth.json"), std::string::npos) << read_file(log);
  // A rock whose box is not four numbers.
  std::ofstream(dir / "scene" / "truth.json")
      << R"({"rocks": [{"visible_px": 50, "touches_border": false, "occluded_fraction": 0, "bbox_px": [1, 2, 3],
                        "width_m": 0.1, "height_above_ground_m": 0.05}]})";
  std::ofstream(dir / "out" / "summary.json") << R"({"rocks": []})";
  EXPECT_EQ(run_tool("eval assess " + (dir / "scene").string() + " --out " + (dir / "out").string(), log), 2);
  EXPECT_NE(read_file(log).find("truth.json: rocks[0]: bbox_px: must be [xmin, ymin, xmax, ymax]"), std::string::npos)
      << read_file(log);
  // An orthographic run of assess has no rocks to score.
  std::ofstream(dir / "scene" / "truth.json")
      << R"({"rocks": [{"visible_px": 50, "touches_border": false, "occluded_fraction": 0, "bbox_px": [1, 2, 30, 40],
                        "width_m": 0.1, "height_above_ground_m": 0.05}]})";
  std::ofstream(dir / "out" / "summary.json") << R"({"mode": "orthographic"})";
  EXPECT_EQ(run_tool("eval assess " + (dir / "scene").string() + " --out " + (dir / "out").string(), log), 2);
  EXPECT_NE(read_file(log).find("summary.json: rocks: missing"), std::string::npos) << read_file(log);
  // Scored: one measurable rock, one box on it (IoU 0.9) and one on nothing.
  std::ofstream(dir / "out" / "summary.json")
      << R"({"rocks": [{"box_px": [2, 3, 30, 40], "width_m": 0.12, "height_m": 0.04},
                       {"box_px": [100, 100, 120, 120], "width_m": 0.05, "height_m": 0.02}],
             "rocks_below_min_score": 3})";
  ASSERT_EQ(run_tool("eval assess " + (dir / "scene").string() + " --out " + (dir / "out").string(), log), 0)
      << read_file(log);
  const auto ev = nlohmann::json::parse(read_file(log));
  EXPECT_EQ(ev["measurable_rocks"].get<int>(), 1);
  EXPECT_EQ(ev["boxed"].get<int>(), 1);
  EXPECT_EQ(ev["boxes_on_no_rock"].get<int>(), 1);
  EXPECT_EQ(ev["rocks_below_min_score"].get<int>(), 3);
  EXPECT_NEAR(ev["median_width_error_pct"].get<double>(), 20.0, 1e-9);
  EXPECT_NEAR(ev["median_height_error_pct"].get<double>(), 20.0, 1e-9);
  EXPECT_TRUE(ev["median_height_sfs_error_pct"].is_null());
}

// `assess IMAGE --scene input.json` on an orthographic development patch does exactly what the
// patch's numbers given as options do (pixel size, image-frame sun, the flat field beside the
// file), and the run says which scene it read.
TEST(AssessCli, AnOrthographicSceneFileIsTheSameRunAsItsNumbers) {
  const fs::path patch = fs::path(REGOLITH_SHARED_DIR) / "data" / "synthetic_dev" / "sfs" / "ortho_vignette_dev_1";
  if (!fs::exists(patch / "input.json")) GTEST_SKIP() << patch << " not present";
  const regolith::testing::TempDir tmp("assess_scene");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const auto in = nlohmann::json::parse(read_file(patch / "input.json"));
  ASSERT_TRUE(in["flat_field"].is_string());
  char numbers[512];
  std::snprintf(numbers, sizeof numbers, " --sun-slant %.17g --sun-tilt %.17g --pixel-size %.17g --flat-field %s",
                in["sun_slant_deg"].get<double>(), in["sun_tilt_deg"].get<double>(), in["gsd_m"].get<double>(),
                (patch / in["flat_field"].get<std::string>()).c_str());
  const std::string image = "assess " + (patch / "image.png").string();
  ASSERT_EQ(run_tool(image + " --out " + (dir / "scene").string() + " --scene " + (patch / "input.json").string(),
                     dir / "scene.txt"),
            0)
      << read_file(dir / "scene.txt");
  ASSERT_EQ(run_tool(image + " --out " + (dir / "numbers").string() + numbers, dir / "numbers.txt"), 0)
      << read_file(dir / "numbers.txt");
  EXPECT_EQ(read_file(dir / "scene" / "height.tiff"), read_file(dir / "numbers" / "height.tiff"));
  const auto summary = nlohmann::json::parse(read_file(dir / "scene" / "summary.json"));
  EXPECT_EQ(summary["scene"], (patch / "input.json").string());
  EXPECT_EQ(summary["mode"], "orthographic");
}

// A scene file that cannot describe the image: one line naming the file and the field, exit 2;
// and --scene with the options it replaces is refused before anything runs.
TEST(AssessCli, ABadSceneFileNamesTheFileAndTheField) {
  const regolith::testing::TempDir tmp("assess_bad_scene");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path png = dir / "ground.png";
  ASSERT_TRUE(cv::imwrite(png.string(), cv::Mat(120, 160, CV_8U, cv::Scalar(128))));
  const auto attempt = [&](const std::string& name, const std::string& text, const std::string& extra = "") {
    const fs::path scene = dir / (name + ".json");
    std::ofstream(scene) << text;
    const int rc =
        run_tool("assess " + png.string() + " --out " + (dir / "out").string() + " --scene " + scene.string() + extra,
                 dir / (name + ".txt"));
    return std::make_pair(rc, read_file(dir / (name + ".txt")));
  };
  const std::string camera =
      R"("camera": {"width": 160, "height": 120, "fx": 150, "fy": 150, "cx": 79.5, "cy": 59.5, "h_m": 0.6, "pitch_deg": 30})";
  const std::string sun = R"("sun_elevation_deg": 40, "sun_azimuth_deg": 90)";
  const struct {
    const char* name;
    std::string text, expected;
  } cases[] = {
      {"no_cx", R"({"projection": "perspective", "camera": {"width": 160, "height": 120, "fx": 150, "fy": 150}})",
       "no_cx.json: camera.cx: missing"},
      {"other_size",
       R"({"projection": "perspective", "camera": {"width": 640, "height": 480, "fx": 150, "fy": 150, "cx": 79.5, "cy": 59.5, "h_m": 0.6, "pitch_deg": 30}, )" +
           sun + "}",
       "other_size.json: camera.width x camera.height is 640x480 px, but the image is 160x120"},
      {"no_projection", "{" + camera + ", " + sun + "}", "no_projection.json: projection: must be"},
      {"drive", R"({"traverse": "t", "frames_csv": "frames.csv", )" + camera + "}",
       "drive.json: a recorded drive's description (frames_csv), not one image's scene: `regolith map DIR`"},
      {"sun_text", R"({"projection": "perspective", )" + camera + R"(, "sun_elevation_deg": "high"})",
       "sun_text.json: sun_elevation_deg: must be a number"},
      {"no_pixel_size", R"({"projection": "orthographic", "sun_slant_deg": 30, "sun_tilt_deg": 0})",
       "no_pixel_size.json: gsd_m: missing"},
      {"not_json", "{\"projection\": ", "not_json.json: not valid JSON"},
  };
  for (const auto& c : cases) {
    const auto [rc, log] = attempt(c.name, c.text);
    EXPECT_EQ(rc, 2) << c.name << ": " << log;
    EXPECT_NE(log.find(c.expected), std::string::npos) << c.name << ": " << log;
    EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << c.name << ": " << log;
  }
  const std::string good = R"({"projection": "perspective", )" + camera + ", " + sun + "}";
  const auto [ok, ok_log] = attempt("good", good);
  EXPECT_EQ(ok, 0) << ok_log;
  const auto [both, both_log] = attempt("both", good, " --height 0.5");
  EXPECT_NE(both, 0);
  EXPECT_NE(both_log.find("--height excludes --scene"), std::string::npos) << both_log;
}
#endif

}  // namespace
