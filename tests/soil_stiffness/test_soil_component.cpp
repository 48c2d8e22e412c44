// Component "soil_stiffness" under the simulated clock: a deployment with the synthetic_tracks
// rear camera (known k, n, loads) and the soil component, DDS disabled. Asserts the published k
// against the synthetic truth, the sinkage layer, zero heap allocations inside rate-group cycles
// once warm, and the configuration errors (named fields, file:line:col).
// The replaced global operator new/delete pair malloc/free; GCC cannot see that they match.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>

#include <gtest/gtest.h>

#include "regolith/core/error.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/rate_group.hpp"
#include "regolith/soil_stiffness/component.hpp"
#include "regolith/track_scene/camera_model.hpp"
#include "regolith/track_scene/track_scene.hpp"

#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "diagnostics.hpp"

using namespace regolith;

namespace {

void register_all() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  mocks::register_mock_backends(hal::BackendRegistry::instance());
  soil::register_component();
}

// Truth: k = 5e5, n = 1, b = 0.15 m, D = 0.30 m, W = 140 kg * 1.62 / 6 = 37.8 N on both ruts.
const char* kDeployment = R"(name: soil_test
dds: {enabled: false}
rover:
  mass_kg: 140
  gravity_mps2: 1.62
  wheels:
    - {name: wheel_fl, x_m: 0.35, y_m: 0.4, radius_m: 0.15, width_m: 0.15}
    - {name: wheel_fr, x_m: 0.35, y_m: -0.4, radius_m: 0.15, width_m: 0.15}
    - {name: wheel_ml, x_m: 0.0, y_m: 0.4, radius_m: 0.15, width_m: 0.15}
    - {name: wheel_mr, x_m: 0.0, y_m: -0.4, radius_m: 0.15, width_m: 0.15}
    - {name: wheel_rl, x_m: -0.35, y_m: 0.4, radius_m: 0.15, width_m: 0.15}
    - {name: wheel_rr, x_m: -0.35, y_m: -0.4, radius_m: 0.15, width_m: 0.15}
  cameras:
    rear:
      camera_info: {width: 640, height: 480, k: [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]}
      mount: {x_m: -0.5, z_m: 1.2, pitch_rad: 0.61, yaw_rad: 3.141592654}
sun: {azimuth_deg: 90, elevation_deg: 45}   # due right of the rover: from the left of the rear view
devices:
  cameras:
    rear:
      backend: synthetic_tracks
      rate_hz: 1
      frames: 1
      k: 5.0e5
      n: 1.0
      track_lateral_m: [0.4, -0.4]
      track_load_n: [37.8, 37.8]
rate_groups:
  - name: soil
    rate_hz: 0.5
    members: [soil]
components:
  soil:
    type: soil_stiffness
    camera: rear
    profile: {source: photoclinometry}   # the synthetic ruts have no berms and no shadows
)";

std::string replace(std::string s, const std::string& a, const std::string& b) {
  const auto p = s.find(a);
  if (p == std::string::npos)
    ADD_FAILURE() << "'" << a << "' not in the deployment";
  else
    s.replace(p, a.size(), b);
  return s;
}

// AppOptions by assignment (robust to new fields)
runtime::AppOptions sim_options(bool open_devices = true) {
  runtime::AppOptions o;
  o.sim_time = true;
  o.enable_dds = false;
  o.open_devices = open_devices;
  return o;
}

std::string load_error(const std::string& yaml) {
  register_all();
  try {
    auto app = runtime::Application::load(Params::load_string(yaml, "rover.yaml"), sim_options(false));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(SoilComponent, EstimatesKOfTheSyntheticTracksUnderSimulatedTime) {
  register_all();
  auto app = runtime::Application::load(Params::load_string(kDeployment, "soil_test.yaml"), sim_options());
  auto& soil_ch = app->context().channel<soil::SoilStiffnessSample>(soil::kSoilChannel);
  auto& layer_ch = app->context().channel<soil::SinkageLayer>(soil::kSinkageLayerChannel);
  std::atomic<bool> stop{false};
  app->start();
  app->run(4 * kNsPerSec, stop);  // warm-up: the first estimates
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  std::uint64_t cycles0 = 0;
  for (const auto* g : app->view().groups) cycles0 += g->counters().cycles;
  app->run(16 * kNsPerSec, stop);
  const std::uint64_t steady_allocs = regolith::testing::cycle_allocations() - a0;
  std::uint64_t cycles1 = 0;
  for (const auto* g : app->view().groups) cycles1 += g->counters().cycles;
  app->stop();

  const double z_true = track_scene::rut_depth(5.0e5, 1.0, 37.8, 0.15, 0.30);
  auto s = soil_ch.acquire();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->ok) << s->reason;
  std::printf(
      "component: k %.4g +- %.2g (truth 5e5), mean sinkage %.2f mm (truth %.2f mm), %u samples, "
      "%u tracks, class %s; %llu allocations in %llu steady cycles\n",
      s->k, s->k_sigma, s->mean_sinkage_m * 1e3, z_true * 1e3, s->samples_used, s->tracks,
      soil::to_string(s->soil_class), static_cast<unsigned long long>(steady_allocs),
      static_cast<unsigned long long>(cycles1 - cycles0));
  EXPECT_FALSE(s->joint);  // equal loads: n fixed
  EXPECT_DOUBLE_EQ(s->n, 1.0);
  EXPECT_NEAR(s->k / 5.0e5, 1.0, 0.15);
  EXPECT_GT(s->k_sigma, 0.0);
  EXPECT_LT(s->k_sigma, 0.1 * s->k);
  EXPECT_NEAR(s->mean_sinkage_m / z_true, 1.0, 0.10);
  EXPECT_EQ(s->tracks, 2u);
  EXPECT_GT(s->samples_used, 200u);
  EXPECT_EQ(s->soil_class, soil::SoilClass::kNominal);  // p(1 cm) = 5 kPa
  // stamped with the capture time of the newest frame at the last 0.5 Hz cycle
  EXPECT_GT(s->stamp, 0);
  EXPECT_LE(s->stamp, app->clock().now());
  EXPECT_GT(s->stamp, app->clock().now() - 3 * kNsPerSec);
  EXPECT_GE(s->sequence, 8u);  // ~10 cycles at 0.5 Hz over 20 s, one new frame each

  auto l = layer_ch.acquire();
  ASSERT_TRUE(l);
  ASSERT_TRUE(l->valid);
  EXPECT_EQ(l->stamp_ns, s->stamp);
  ASSERT_EQ(l->track_count, 2u);
  for (std::uint32_t t = 0; t < 2; ++t) {
    const auto& tr = l->tracks[t];
    EXPECT_NEAR(std::abs(tr.lateral_m), 0.4, 0.02);
    EXPECT_DOUBLE_EQ(tr.width_m, 0.15);
    ASSERT_GT(tr.count, 100u);
    // rear camera 0.5 m behind base_link looking back: the profile lies at x < -1.3 m
    EXPECT_LT(tr.x_m[0], -1.3f);
    EXPECT_NEAR(tr.y_m[0], -tr.lateral_m, 1e-3);
  }

  // real time: once warm, no heap allocation inside the cycles, the Pentland solve (FFTW plans
  // made on the first frame) included. Every steady cycle processed a new frame (camera 1 Hz,
  // rate group 0.5 Hz).
  const std::uint64_t cycles = cycles1 - cycles0;
  EXPECT_GE(cycles, 7u);
  EXPECT_EQ(steady_allocs, 0u) << "in " << cycles << " steady cycles";
}

// The default profile source (the rut template fit) inside the estimator: once warm, an
// estimate does not allocate (the SfS solve, the template fit, its light estimate and the (k, n)
// fits).
TEST(SoilComponent, RearFramesStampedBeforeTheLastOneAreSkippedAndCounted) {
  // The rear camera's clock steps back 2.5 s for frames 2 and 3 (frame 2 is stamped before frame
  // 0, the last one read by the 0.5 Hz group): skipped and counted, so the estimates and the
  // sinkage layer (placed at the odometry of its stamp) never go back in time.
  register_all();
  const std::string yaml =
      replace(kDeployment,
              "    rear:\n      backend: synthetic_tracks\n      rate_hz: 1\n      frames: 1\n      k: 5.0e5\n"
              "      n: 1.0\n      track_lateral_m: [0.4, -0.4]\n      track_load_n: [37.8, 37.8]\n",
              "    rear:\n      backend: fault_injection\n      stamp_step_after: 2\n      stamp_step_for: 2\n"
              "      stamp_step_ms: -2500\n      inner: {backend: synthetic_tracks, rate_hz: 1, frames: 1, k: 5.0e5, "
              "n: 1.0, track_lateral_m: [0.4, -0.4], track_load_n: [37.8, 37.8]}\n");
  auto app = runtime::Application::load(Params::load_string(yaml, "soil_test.yaml"), sim_options());
  auto& soil_ch = app->context().channel<soil::SoilStiffnessSample>(soil::kSoilChannel);
  std::atomic<bool> stop{false};
  app->start();
  std::vector<TimeNs> stamps;
  for (int k = 0; k < 16; ++k) {  // 8 s in 0.5 s slices
    app->run(kNsPerSec / 2, stop);
    if (auto l = soil_ch.acquire(); l && (stamps.empty() || l->stamp != stamps.back())) stamps.push_back(l->stamp);
  }
  app->stop();
  ASSERT_GE(stamps.size(), 3u);
  for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_GT(stamps[i], stamps[i - 1]) << i;
  EXPECT_EQ(regolith::testing::diagnostic(*app, "soil", "frames_out_of_order"), "1")
      << "frame 2, read at 2 s; frame 3 is never the newest at a 0.5 Hz cycle";
  EXPECT_EQ(regolith::testing::diagnostic(*app, "soil", "clock_steps"), "0");
}

TEST(SoilComponent, WarmTemplateEstimateDoesNotAllocate) {
  track_scene::TrackSceneParams p;
  p.sun.elevation_rad = 0.5;
  const cv::Mat image = track_scene::generate_track_scene(p).image;
  const soil::CameraModel cam = track_scene::camera_model_of(p.camera);
  soil::RoverConfig rover;
  rover.wheel_width_m = p.wheel_width_m;
  rover.wheel_diameter_m = p.wheel_diameter_m;
  soil::TrackAnalysisParams ap;  // default region: the peer's 275 x 200 grid
  ASSERT_EQ(ap.profile_source, soil::ProfileSource::kTemplate);
  ap.tracks = {{0.4, 60.0}, {-0.4, 60.0}};
  soil::SoilStiffnessEstimator est(cam, rover, ap);
  soil::SoilEstimate out;
  est.reserve(out);
  const soil::SunDirection sun{p.sun.azimuth_rad, p.sun.elevation_rad};
  est.estimate(image, sun, out);
  est.estimate(image, sun, out);
  ASSERT_TRUE(out.ok) << out.reason;
  const std::uint64_t a0 = regolith::testing::allocations();
  est.estimate(image, sun, out);
  const std::uint64_t allocs = regolith::testing::allocations() - a0;
  ASSERT_TRUE(out.ok) << out.reason;
  EXPECT_EQ(out.tracks.size(), 2u);
  EXPECT_EQ(allocs, 0u);
}

TEST(SoilComponent, NoTracksMeansAnExplicitNoEstimate) {
  register_all();
  // flat ground: the same scene with no ruts
  auto app = runtime::Application::load(
      Params::load_string(replace(replace(kDeployment, "track_lateral_m: [0.4, -0.4]", "track_lateral_m: []"),
                                  "track_load_n: [37.8, 37.8]", "track_load_n: []"),
                          "soil_test.yaml"),
      sim_options());
  std::atomic<bool> stop{false};
  app->start();
  app->run(5 * kNsPerSec, stop);
  app->stop();
  auto s = app->context().channel<soil::SoilStiffnessSample>(soil::kSoilChannel).acquire();
  ASSERT_TRUE(s);
  EXPECT_FALSE(s->ok);
  EXPECT_TRUE(std::isnan(s->k));
  EXPECT_TRUE(std::isnan(s->n));
  EXPECT_EQ(s->samples_used, 0u);
  EXPECT_NE(std::string(s->reason).find("no wheel tracks"), std::string::npos) << s->reason;
  auto l = app->context().channel<soil::SinkageLayer>(soil::kSinkageLayerChannel).acquire();
  ASSERT_TRUE(l);
  EXPECT_FALSE(l->valid);
}

TEST(SoilComponent, ConfigurationErrorsNameTheField) {
  const std::string no_wheels = load_error(replace(kDeployment, "    - {name: wheel_fl", "    - {nam: wheel_fl"));
  EXPECT_NE(no_wheels.find("rover.yaml:"), std::string::npos) << no_wheels;
  EXPECT_NE(no_wheels.find("rover.yaml:7:7: rover.wheels[0].name: required string is missing"), std::string::npos)
      << no_wheels;
  const std::string radius = load_error(replace(kDeployment, "y_m: 0.4, radius_m: 0.15", "y_m: 0.4, radius_m: -0.15"));
  EXPECT_NE(radius.find("rover.wheels[0].radius_m: value must be > 0 (got -0.15)"), std::string::npos) << radius;
  const std::string width =
      load_error(replace(kDeployment, "      frames: 1\n", "      frames: 1\n      width: 320\n"));
  EXPECT_NE(width.find("devices.cameras.rear.width: 320x480 px differs from the calibration (640x480 px"),
            std::string::npos)
      << width;
  const std::string typo = load_error(replace(kDeployment, "mass_kg: 140", "mass_kgs: 140"));
  EXPECT_NE(typo.find("rover.mass_kgs: unknown key (did you mean 'mass_kg'?)"), std::string::npos) << typo;
  const std::string no_mass = load_error(replace(kDeployment, "  mass_kg: 140\n", ""));
  EXPECT_NE(no_mass.find("components.soil: soil stiffness needs the rover's mass and wheels: rover.mass_kg"),
            std::string::npos)
      << no_mass;
  const std::string no_model =
      load_error(replace(kDeployment, "    rear:\n      camera_info", "    rear_cam:\n      camera_info"));
  EXPECT_NE(no_model.find("rover.cameras.rear_cam: no camera device named 'rear_cam'"), std::string::npos) << no_model;
  const std::string loads = load_error(replace(
      kDeployment, "    camera: rear\n", "    camera: rear\n    tracks: {lateral_m: [0.4, -0.4], load_n: [30]}\n"));
  EXPECT_NE(loads.find("components.soil.tracks.load_n: needs one load per lateral_m entry (2), got 1"),
            std::string::npos)
      << loads;
  const std::string many =
      load_error(replace(kDeployment, "    camera: rear\n",
                         "    camera: rear\n    tracks: {lateral_m: [0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]}\n"));
  EXPECT_NE(many.find("components.soil.tracks.lateral_m: at most 8 ruts (got 9)"), std::string::npos) << many;
  const std::string region = load_error(replace(
      kDeployment, "    camera: rear\n", "    camera: rear\n    region: {range_min_m: 3.0, range_max_m: 1.0}\n"));
  EXPECT_NE(region.find("range_max_m: must be > range_min_m"), std::string::npos) << region;
  const std::string camera = load_error(replace(kDeployment, "    camera: rear\n", "    camera: front\n"));
  EXPECT_NE(camera.find("components.soil.camera"), std::string::npos) << camera;
  // The old format (camera, sun and rover repeated in the component): located, saying what to write.
  const std::string old = load_error(replace(
      kDeployment, "    camera: rear\n", "    camera: rear\n    sun: {azimuth_rad: 1.5708, elevation_rad: 0.7854}\n"));
  EXPECT_NE(old.find("components.soil.sun: no longer read here: the deployment has one sun: a top-level `sun: "
                     "{azimuth_deg, elevation_deg}` block"),
            std::string::npos)
      << old;
  const std::string old_model =
      load_error(replace(kDeployment, "    camera: rear\n", "    camera: rear\n    camera_model: {fx: 500}\n"));
  EXPECT_NE(old_model.find("components.soil.camera_model: no longer read here: the camera is described once, in "
                           "rover.cameras.<camera>"),
            std::string::npos)
      << old_model;
}
