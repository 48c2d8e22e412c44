// The rover description (core/rover.hpp, components/common): one sun converted into each camera's
// frames, camera calibration inline or from a ROS camera_calibration file, and the located errors
// an old deployment file gets.
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "regolith/common/camera.hpp"
#include "regolith/common/json_camera.hpp"
#include "regolith/common/payloads.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/sfs/component.hpp"
#include "regolith/soil_stiffness/component.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"
#include "temp_dir.hpp"

using namespace regolith;
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Sun sun_deg(double az, double el) {
  return {az * kDeg, el * kDeg};
}

void expect_vec(const Vec3& v, double x, double y, double z, double tol = 1e-12) {
  EXPECT_NEAR(v.x, x, tol);
  EXPECT_NEAR(v.y, y, tol);
  EXPECT_NEAR(v.z, z, tol);
}

void register_once() {
  static bool registered = false;
  if (registered) return;
  registered = true;
  runtime::register_builtin_components();
  mocks::register_mock_backends(hal::BackendRegistry::instance());
  sfs::register_component();
  soil::register_component();
}

std::string load_error(const std::string& yaml) {
  register_once();
  try {
    runtime::Application::load(Params::load_string(yaml, "old.yaml"),
                               {.sim_time = true, .enable_dds = false, .open_devices = false});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(Sun, LocalLevelCompassConvention) {
  // Compass azimuth: 0 = the heading at start (+x), 90 deg = to the right (-y), elevation up.
  expect_vec(sun_deg(0, 0).local_level(), 1, 0, 0);
  expect_vec(sun_deg(90, 0).local_level(), 0, -1, 0);
  expect_vec(sun_deg(270, 0).local_level(), 0, 1, 0);
  expect_vec(sun_deg(123, 90).local_level(), 0, 0, 1, 1e-12);
}

TEST(Sun, IntoTheFramesOfACameraOnATiltedRover) {
  // Sun due right of the rover's start heading, 30 deg high: (0, -cos 30, sin 30) local level.
  const Sun sun = sun_deg(90, 30);
  const double c30 = std::cos(30 * kDeg), s30 = std::sin(30 * kDeg);
  // Rover pitched 10 deg nose-down (REP-103: +pitch about +y), camera pitched 20 deg down on it:
  // the optical axis is 30 deg below the horizon in the plane of x and z. By hand: in the camera
  // link frame the sun is (-sin 30 sin 30, -cos 30, cos 30 sin 30) = (-0.25, -0.866, 0.433);
  // optical (x right = -y, y down = -z, z forward = x) = (0.866, -0.433, -0.25).
  const Attitude pitched{.pitch_rad = 10 * kDeg};
  const Pose mount{.x_m = 0.3, .z_m = 0.9, .pitch_rad = 20 * kDeg};
  expect_vec(sun_in_body(sun, pitched), -std::sin(10 * kDeg) * s30, -c30, std::cos(10 * kDeg) * s30);
  expect_vec(sun_in_optical(sun, mount, pitched), c30, -s30 * c30, -s30 * s30);
  // The same camera on a level rover sees the sun 10 deg differently along the optical axis only.
  const Vec3 level = sun_in_optical(sun, mount);
  EXPECT_NEAR(level.x, c30, 1e-12);
  EXPECT_NEAR(level.z, -std::sin(20 * kDeg) * s30, 1e-12);
  // Rover rolled 20 deg left side up: the right-hand sun rises to 50 deg in the body frame.
  const Vec3 rolled = sun_in_body(sun, {.roll_rad = 20 * kDeg});
  EXPECT_NEAR(elevation(rolled), 50 * kDeg, 1e-12);
  EXPECT_NEAR(azimuth_ccw(rolled), -90 * kDeg, 1e-12);
  // A camera looking back (yaw pi): the right-hand sun is on the left of its ground frame.
  RoverCamera rear;
  rear.mount = {.z_m = 1.2, .pitch_rad = 0.61, .yaw_rad = 180 * kDeg};
  const common::GroundSun g = common::ground_sun(sun, rear);
  EXPECT_NEAR(g.azimuth_rad, 90 * kDeg, 1e-12);
  EXPECT_NEAR(g.elevation_rad, 30 * kDeg, 1e-12);
}

TEST(Sun, ImageLightMatchesTheIndependentSceneRenderer) {
  // mocks/terrain_scene converts a world sun into the image frame its own way (for rendering);
  // the rover description's conversion must agree with it for any mount.
  for (double pitch : {0.0, 0.2, 0.35, 0.7})
    for (double roll : {0.0, 0.1, -0.25})
      for (double az_ccw : {0.3, 1.5, 2.5, -2.0})
        for (double el : {0.3, 0.6, 1.1}) {
          terrain_scene::CameraPose cam;
          cam.pitch_rad = pitch;
          cam.roll_rad = roll;
          const cv::Vec2d want = terrain_scene::camera_light(cam, terrain_scene::Sun{az_ccw, el});
          RoverCamera rc;
          rc.mount = {.z_m = 0.5, .roll_rad = roll, .pitch_rad = pitch};
          const common::CameraLight got = common::camera_light(Sun{-az_ccw, el}, rc);
          EXPECT_NEAR(got.light.slant_rad, want[0], 1e-9) << pitch << " " << roll << " " << az_ccw << " " << el;
          const double dt = std::remainder(got.light.tilt_rad - want[1], 2 * 3.14159265358979323846);
          if (want[0] > 1e-6) {
            EXPECT_NEAR(dt, 0.0, 1e-9) << pitch << " " << roll << " " << az_ccw << " " << el;
          }
          EXPECT_EQ(got.in_view, want[0] < 0.5 * 3.14159265358979323846);
        }
}

// A recorded scene's or drive's camera block (input.json) is read one way by `regolith map`,
// `soil --scene` and `assess --scene`: the drives call the height mount_height_m, the scenes h_m.
TEST(CameraCalibration, SceneAndDriveCameraBlocksReadTheSame) {
  const auto block = [](const char* height_key, double height) {
    return nlohmann::json{{"camera",
                           {{"width", 320},
                            {"height", 240},
                            {"fx", 219.7},
                            {"fy", 219.5},
                            {"cx", 159.5},
                            {"cy", 119.5},
                            {height_key, height},
                            {"pitch_deg", 35.0},
                            {"roll_deg", -2.0}}}};
  };
  const auto drive = common::read_json_camera(block("mount_height_m", 0.67), "drive/input.json");
  const auto scene = common::read_json_camera(block("h_m", 0.67), "scene/input.json");
  for (const auto& c : {drive, scene}) {
    EXPECT_EQ(c.width, 320);
    EXPECT_EQ(c.height, 240);
    EXPECT_DOUBLE_EQ(c.fx, 219.7);
    EXPECT_DOUBLE_EQ(c.fy, 219.5);
    EXPECT_DOUBLE_EQ(c.cx, 159.5);
    EXPECT_DOUBLE_EQ(c.mount_height_m, 0.67);
    EXPECT_NEAR(c.pitch_rad, 35.0 * kDeg, 1e-15);
    EXPECT_NEAR(c.roll_rad, -2.0 * kDeg, 1e-15);
    EXPECT_FALSE(c.has_distortion());
  }
  const auto error = [](const nlohmann::json& j) {
    try {
      common::read_json_camera(j, "x/input.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  nlohmann::json both = block("h_m", 0.67);
  both["camera"]["mount_height_m"] = 0.7;
  EXPECT_NE(error(both).find("x/input.json: camera.h_m: the height is given twice"), std::string::npos) << error(both);
  nlohmann::json none = block("h_m", 0.67);
  none["camera"].erase("h_m");
  EXPECT_NE(error(none).find("x/input.json: camera.h_m: missing"), std::string::npos) << error(none);
  EXPECT_NE(error(block("h_m", -1.0)).find("x/input.json: camera: "), std::string::npos) << error(block("h_m", -1.0));
  nlohmann::json no_fx = block("h_m", 0.67);
  no_fx["camera"]["fx"] = "wide";
  EXPECT_EQ(error(no_fx), "x/input.json: camera.fx: must be a number");
  EXPECT_NE(error(nlohmann::json{{"camera", 3}}).find("x/input.json: camera: must be an object"), std::string::npos);
}

// A scene's camera given by its rotation (the development scenes' R_world_from_camera: camera x right,
// y down, z optical in a world X right, Y forward, Z up). The matrices here are built from the camera's
// axes, not from direct_depth's formula: the test is that a ground point projected through the matrix
// comes back to its place through the model read from it.
TEST(CameraCalibration, TheRotationOfAScenePlacesTheGroundAsItDoes) {
  const auto rotation = [](double pitch_deg, double roll_deg, double yaw_deg) {
    const double a = pitch_deg * kDeg, r = roll_deg * kDeg, y = yaw_deg * kDeg;
    const cv::Vec3d z(std::sin(y) * std::cos(a), std::cos(y) * std::cos(a), -std::sin(a));  // optical axis
    const cv::Vec3d x0(std::cos(y), -std::sin(y), 0.0);                                     // level, to the right
    const cv::Vec3d y0 = z.cross(x0);                                                       // down the image
    const cv::Vec3d x = std::cos(r) * x0 + std::sin(r) * y0, yy = -std::sin(r) * x0 + std::cos(r) * y0;
    return nlohmann::json::array({{x[0], yy[0], z[0]}, {x[1], yy[1], z[1]}, {x[2], yy[2], z[2]}});
  };
  const auto scene = [](const nlohmann::json& r) {
    return nlohmann::json{{"camera",
                           {{"width", 640},
                            {"height", 480},
                            {"fx", 600.0},
                            {"fy", 600.0},
                            {"cx", 319.5},
                            {"cy", 239.5},
                            {"h_m", 0.8},
                            {"R_world_from_camera", r}}}};
  };
  // The first development track scene's matrix, as written there: 48.10 deg down, no roll.
  const nlohmann::json dev = {
      {1.0, 0.0, 0.0}, {0.0, -0.744356348416, 0.667782619251}, {0.0, -0.667782619251, -0.744356348416}};
  const auto c0 = common::read_json_camera(scene(dev), "tracks_dev_0/input.json");
  EXPECT_NEAR(c0.pitch_rad / kDeg, 48.1038438857836, 1e-6);
  EXPECT_NEAR(c0.roll_rad, 0.0, 1e-9);

  for (const double roll : {-6.0, 0.0, 4.0}) {
    const nlohmann::json r = rotation(40.0, roll, 0.0);
    const auto c = common::read_json_camera(scene(r), "x/input.json");
    EXPECT_NEAR(c.pitch_rad / kDeg, 40.0, 1e-9);
    const direct_depth::DirectDepth model(c, direct_depth::DirectDepth::Maps::kNone);
    for (const cv::Vec3d& ground : {cv::Vec3d(0.0, 1.5, 0.0), cv::Vec3d(-0.4, 1.0, 0.0), cv::Vec3d(0.6, 2.5, 0.0)}) {
      cv::Matx33d m;
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) m(i, k) = r[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)].get<double>();
      const cv::Vec3d p = m.t() * (ground - cv::Vec3d(0.0, 0.0, 0.8));  // in the camera
      const double u = 600.0 * p[0] / p[2] + 319.5, v = 600.0 * p[1] / p[2] + 239.5;
      const direct_depth::GroundPoint g = model.ground(u, v);
      ASSERT_TRUE(g.valid) << "roll " << roll;
      EXPECT_NEAR(g.range_m, ground[1], 1e-6) << "roll " << roll << ", world X " << ground[0];
      EXPECT_NEAR(g.lateral_m, -ground[0], 1e-6) << "roll " << roll << ", world X " << ground[0];
    }
  }

  const auto error = [&](nlohmann::json j) {
    try {
      common::read_json_camera(j, "x/input.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  nlohmann::json disagree = scene(rotation(40.0, 0.0, 0.0));
  disagree["camera"]["pitch_deg"] = 35.0;
  EXPECT_EQ(
      error(disagree),
      "x/input.json: camera.pitch_deg: 35.00 deg, but camera.R_world_from_camera tilts the optical axis 40.00 deg "
      "down: the two disagree");
  nlohmann::json agree = scene(rotation(40.0, 2.0, 0.0));
  agree["camera"]["pitch_deg"] = 40.2;
  agree["camera"]["roll_deg"] = 2.0;
  EXPECT_NEAR(common::read_json_camera(agree, "x/input.json").pitch_rad / kDeg, 40.2, 1e-9);  // the stated one
  EXPECT_NE(
      error(scene(rotation(40.0, 0.0, 5.0)))
          .find("camera.R_world_from_camera: the optical axis points 5.00 deg right of the scene's forward (+Y) axis"),
      std::string::npos)
      << error(scene(rotation(40.0, 0.0, 5.0)));
  nlohmann::json mirror = scene(rotation(40.0, 0.0, 0.0));
  for (auto& row : mirror["camera"]["R_world_from_camera"]) row[0] = -row[0].get<double>();
  EXPECT_EQ(error(mirror), "x/input.json: camera.R_world_from_camera: a reflection (determinant -1), not a rotation");
  EXPECT_EQ(error(scene({{1, 0}, {0, 1}})), "x/input.json: camera.R_world_from_camera: must be 3 rows of 3 numbers");
  EXPECT_EQ(error(scene({{1, 0, 0}, {0, 2, 0}, {0, 0, 1}})),
            "x/input.json: camera.R_world_from_camera: not a rotation (its columns are not orthonormal)");
  EXPECT_EQ(error(scene({{1, 0, 0}, {0, "a", 0}, {0, 0, 1}})),
            "x/input.json: camera.R_world_from_camera: row 1, column 1: must be a finite number");
  nlohmann::json neither = scene(rotation(40.0, 0.0, 0.0));
  neither["camera"].erase("R_world_from_camera");
  EXPECT_NE(error(neither).find("x/input.json: camera.pitch_deg: missing"), std::string::npos) << error(neither);
}

TEST(CameraCalibration, RosCalibrationFileAndInlineAgree) {
  const regolith::testing::TempDir tmp("rover");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  std::ofstream(dir / "front.yaml") << R"(image_width: 640
image_height: 480
camera_name: front
camera_matrix: {rows: 3, cols: 3, data: [512.5, 0, 320.1, 0, 511.0, 241.7, 0, 0, 1]}
distortion_model: plumb_bob
distortion_coefficients: {rows: 1, cols: 5, data: [-0.21, 0.04, 0.001, -0.002, 0.0]}
rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}
projection_matrix: {rows: 3, cols: 4, data: [512.5, 0, 320.1, 0, 0, 511.0, 241.7, 0, 0, 0, 1, 0]}
)";
  Params root = Params::load_string(R"(rover:
  cameras:
    a: {camera_info_url: file://front.yaml, mount: {z_m: 0.9, pitch_rad: 0.35}}
    b:
      camera_info: {width: 640, height: 480, k: [512.5, 0, 320.1, 0, 511.0, 241.7, 0, 0, 1],
                    distortion_model: plumb_bob, d: [-0.21, 0.04, 0.001, -0.002, 0.0]}
      mount: {z_m: 0.9, pitch_rad: 0.35}
)",
                                    (dir / "deploy.yaml").string());
  const RoverDescription d = read_rover_description(root, dir.string());
  ASSERT_EQ(d.cameras.size(), 2u);
  const auto ma = common::camera_model_of(d.cameras.at("a")), mb = common::camera_model_of(d.cameras.at("b"));
  EXPECT_EQ(ma.width, 640);
  EXPECT_DOUBLE_EQ(ma.fx, 512.5);
  EXPECT_DOUBLE_EQ(ma.fy, 511.0);
  EXPECT_DOUBLE_EQ(ma.cy, 241.7);
  EXPECT_DOUBLE_EQ(ma.k1, -0.21);
  EXPECT_DOUBLE_EQ(ma.p2, -0.002);
  EXPECT_DOUBLE_EQ(ma.mount_height_m, 0.9);
  EXPECT_EQ(std::make_tuple(ma.fx, ma.fy, ma.cx, ma.cy, ma.k1, ma.k2, ma.p1, ma.p2, ma.k3),
            std::make_tuple(mb.fx, mb.fy, mb.cx, mb.cy, mb.k1, mb.k2, mb.p1, mb.p2, mb.k3));
  EXPECT_EQ(d.cameras.at("a").frame_id, "a_optical_frame");

  // Errors name the file and the field.
  std::ofstream(dir / "bad.yaml")
      << "image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 3, cols: 3, data: [1, 2]}\n";
  Params bad = Params::load_string("rover:\n  cameras:\n    a: {camera_info_url: file://bad.yaml, mount: {z_m: 1}}\n",
                                   (dir / "deploy.yaml").string());
  try {
    read_rover_description(bad, dir.string());
    FAIL() << "9-number K accepted with 2";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("rover.cameras.a.camera_info_url: " + (dir / "bad.yaml").string() + ":3:"), std::string::npos)
        << m;
    EXPECT_NE(m.find("camera_matrix.data: needs 9 numbers, got 2"), std::string::npos) << m;
  }
  Params both = Params::load_string(
      "rover:\n  cameras:\n    a: {camera_info_url: file://front.yaml, camera_info: {width: 8}, mount: {z_m: 1}}\n",
      "d.yaml");
  EXPECT_THROW(read_rover_description(both, dir.string()), ConfigError);
  Params rational = Params::load_string(
      "rover:\n  cameras:\n    a:\n      camera_info: {width: 64, height: 48, k: [50, 0, 32, 0, 50, 24, 0, 0, 1], "
      "distortion_model: rational_polynomial}\n      mount: {z_m: 1}\n",
      "d.yaml");
  try {
    read_rover_description(rational, dir.string());
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("d.yaml:4:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(
                  "rover.cameras.a.camera_info.distortion_model: 'rational_polynomial' is not supported"),
              std::string::npos)
        << e.what();
  }
}

TEST(OldDeployment, EachRepeatedGeometryIsALocatedErrorSayingWhatToWrite) {
  // Fragments of the format before the rover description (config/mock_rover.yaml at 8b6dd0b).
  const std::string head = R"(name: old
dds: {enabled: false}
rover:
  cameras:
    front:
      camera_info: {width: 320, height: 240, k: [200, 0, 159.5, 0, 200, 119.5, 0, 0, 1]}
      mount: {z_m: 0.5, pitch_rad: 0.35}
sun: {azimuth_deg: 216.76, elevation_deg: 34.38}
rate_groups: [{name: t, rate_hz: 2, members: [sfs]}]
)";
  const std::string scene_old = load_error(head + R"(devices:
  cameras:
    front: {backend: synthetic_terrain, camera_height_m: 0.5}
components:
  sfs: {type: sfs, camera: front}
)");
  EXPECT_NE(scene_old.find("old.yaml:12:"), std::string::npos) << scene_old;
  EXPECT_NE(
      scene_old.find("devices.cameras.front.camera_height_m: no longer read here: the camera is described once, "
                     "in rover.cameras.front {camera_info: {width, height, k, d}, mount: {x_m, y_m, z_m, roll_rad, "
                     "pitch_rad, yaw_rad}}"),
      std::string::npos)
      << scene_old;
  const std::string sun_old = load_error(head + R"(devices:
  cameras:
    front: {backend: synthetic_terrain}
components:
  sfs: {type: sfs, camera: front, sun_slant_rad: 0.6185, sun_tilt_rad: -2.5904}
)");
  EXPECT_NE(sun_old.find("old.yaml:14:"), std::string::npos) << sun_old;
  EXPECT_NE(sun_old.find("components.sfs.sun_slant_rad: no longer read here: the deployment has one sun: a top-level "
                         "`sun: {azimuth_deg, elevation_deg}` block"),
            std::string::npos)
      << sun_old;
  const std::string source_old = load_error(head + R"(devices:
  cameras:
    front: {backend: synthetic_terrain}
components:
  sfs: {type: sfs, camera: front, light_source: config}
)");
  EXPECT_NE(source_old.find("components.sfs.light_source: `config` (sun_slant_rad/sun_tilt_rad) is replaced by `sun`"),
            std::string::npos)
      << source_old;
  // A camera without a calibration, and a calibration without a camera.
  const std::string uncalibrated = load_error(R"(name: x
dds: {enabled: false}
sun: {azimuth_deg: 0, elevation_deg: 30}
devices:
  cameras:
    front: {backend: synthetic_terrain}
rate_groups: [{name: t, rate_hz: 2, members: [sfs]}]
components:
  sfs: {type: sfs, camera: front}
)");
  EXPECT_NE(uncalibrated.find("old.yaml:9:"), std::string::npos) << uncalibrated;
  EXPECT_NE(uncalibrated.find("components.sfs.camera: camera 'front' has no calibration: declare it once as "
                              "rover.cameras.front"),
            std::string::npos)
      << uncalibrated;
  const std::string orphan = load_error(head + R"(devices:
  cameras:
    cam0: {backend: synthetic_terrain}
components:
  sfs: {type: sfs, camera: cam0}
)");
  EXPECT_NE(orphan.find("old.yaml:6:"), std::string::npos) << orphan;
  EXPECT_NE(orphan.find("rover.cameras.front: no camera device named 'front' in devices.cameras"), std::string::npos)
      << orphan;
  // No sun at all, with the sun as the light source.
  std::string no_sun = head;
  no_sun.erase(no_sun.find("sun: {"), no_sun.find("rate_groups") - no_sun.find("sun: {"));
  const std::string nosun = load_error(no_sun + R"(devices:
  cameras:
    front: {backend: synthetic_terrain}
components:
  sfs: {type: sfs, camera: front}
)");
  EXPECT_NE(nosun.find("sfs light_source sun needs the sun: add a top-level `sun: {azimuth_deg, elevation_deg}` block"),
            std::string::npos)
      << nosun;
}

TEST(Imu, AttitudeFromTheImuTurnsTheSunIntoEachFrame) {
  // A rover pitched 8 deg nose-down and rolled 5 deg (scripted IMU, rover.imu): the sfs component
  // solves each frame with the sun converted through that attitude, not a level one; the
  // imu_publisher publishes the attitude it read.
  register_once();
  const std::string yaml = R"(name: imu_test
dds: {enabled: false}
rover:
  imu: body_imu
  cameras:
    front:
      camera_info: {width: 320, height: 240, k: [200, 0, 159.5, 0, 200, 119.5, 0, 0, 1]}
      mount: {z_m: 0.5, pitch_rad: 0.35}
sun: {azimuth_deg: 216.76, elevation_deg: 34.38}
devices:
  cameras:
    front: {backend: synthetic_terrain, rate_hz: 2, frames: 1, speed_m_s: 0}
  imus:
    body_imu: {backend: scripted, rate_hz: 50, roll_deg: 5, pitch_deg: 8}
rate_groups:
  - {name: io, rate_hz: 50, members: [imu]}
  - {name: terrain, rate_hz: 2, members: [sfs]}
components:
  imu: {type: imu_publisher, imu: body_imu}
  sfs: {type: sfs, camera: front}
)";
  auto app = runtime::Application::load(Params::load_string(yaml, "imu.yaml"), {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(2 * kNsPerSec, stop);
  app->stop();
  const Attitude tilted{.roll_rad = 5 * kDeg, .pitch_rad = 8 * kDeg};
  RoverCamera cam;
  cam.mount = {.z_m = 0.5, .pitch_rad = 0.35};
  const Sun sun = sun_deg(216.76, 34.38);
  const common::CameraLight want = common::camera_light(sun, cam, tilted);
  const common::CameraLight level = common::camera_light(sun, cam);
  auto dtm = app->context().channel<common::DtmFrame>(common::kDtmChannel).acquire();
  ASSERT_TRUE(dtm);
  EXPECT_NEAR(dtm->light.slant_rad, want.light.slant_rad, 1e-12);
  EXPECT_NEAR(dtm->light.tilt_rad, want.light.tilt_rad, 1e-12);
  EXPECT_GT(
      std::abs(dtm->light.slant_rad - level.light.slant_rad) + std::abs(dtm->light.tilt_rad - level.light.tilt_rad),
      0.05);  // the attitude matters
  auto imu = app->context().channel<hal::ImuSample>("imu").acquire();
  ASSERT_TRUE(imu);
  EXPECT_NEAR(imu->attitude.roll_rad, 5 * kDeg, 1e-12);
  EXPECT_NEAR(imu->attitude.pitch_rad, 8 * kDeg, 1e-12);
  // Specific force at rest: gravity (1.62 m/s^2 by default) seen from the tilted body.
  const double g = std::sqrt(imu->linear_acceleration.x * imu->linear_acceleration.x +
                             imu->linear_acceleration.y * imu->linear_acceleration.y +
                             imu->linear_acceleration.z * imu->linear_acceleration.z);
  EXPECT_NEAR(g, 1.62, 1e-9);
  EXPECT_NEAR(imu->linear_acceleration.x, -1.62 * std::sin(8 * kDeg), 1e-9);  // nose down: +x sees -g sin(pitch)
  // The quaternion of the message agrees with the rotation matrix.
  const hal::Quaternion q = hal::to_quaternion(tilted);
  const Rotation r = tilted.rotation();
  EXPECT_NEAR(1 - 2 * (q.y * q.y + q.z * q.z), r.m[0], 1e-12);
  EXPECT_NEAR(2 * (q.x * q.z - q.w * q.y), r.m[6], 1e-12);
  // The data-flow graph shows the IMU as an input of both.
  std::ostringstream flow;
  app->dataflow().print(flow);
  EXPECT_NE(flow.str().find("imu body_imu --> imu"), std::string::npos) << flow.str();
  EXPECT_NE(flow.str().find("imu body_imu --> sfs"), std::string::npos) << flow.str();
}

// The rotation -> quaternion conversion (every branch of it) reproduces the matrix.
TEST(RoverFrames, QuaternionOfARotationReproducesTheMatrix) {
  for (double roll : {0.0, 0.3, -2.9, 3.1})
    for (double pitch : {0.0, 1.2, -1.5})
      for (double yaw : {0.0, 0.7, 3.1, -3.0}) {
        const Rotation r = Rotation::from_rpy(roll, pitch, yaw);
        const auto q = quaternion(r);
        EXPECT_GE(q[3], 0.0);
        EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
        const double x = q[0], y = q[1], z = q[2], w = q[3];
        const std::array<double, 9> m{1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
                                      2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                                      2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
        for (int k = 0; k < 9; ++k) EXPECT_NEAR(m[k], r.m[k], 1e-12) << roll << " " << pitch << " " << yaw << " " << k;
      }
}

// /tf_static content: per camera the mount (base -> link), the optical rotation (link -> optical:
// z forward, x right, y down) and the ground frame below the camera.
TEST(RoverFrames, StaticTransformsOfEveryCamera) {
  RoverDescription d;
  RoverCamera cam;
  cam.name = "rear";
  cam.frame_id = "rear_optical_frame";
  cam.mount = {-0.5, 0.1, 1.2, 0.0, 0.6, M_PI};  // looking backwards, 0.6 rad down
  d.cameras["rear"] = cam;
  const auto tf = static_transforms(d);
  ASSERT_EQ(tf.size(), 3u);
  EXPECT_EQ(tf[0].parent, "base_link");
  EXPECT_EQ(tf[0].child, "rear_link");
  EXPECT_EQ(tf[1].parent, "rear_link");
  EXPECT_EQ(tf[1].child, "rear_optical_frame");
  EXPECT_EQ(tf[2].parent, "base_link");
  EXPECT_EQ(tf[2].child, "rear_ground");
  EXPECT_DOUBLE_EQ(tf[0].translation.z, 1.2);
  EXPECT_DOUBLE_EQ(tf[2].translation.x, -0.5);
  EXPECT_DOUBLE_EQ(tf[2].translation.y, 0.1);
  EXPECT_DOUBLE_EQ(tf[2].translation.z, 0.0);
  auto rotate = [](const std::array<double, 4>& q, const Vec3& v) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    return Vec3{(1 - 2 * (y * y + z * z)) * v.x + 2 * (x * y - z * w) * v.y + 2 * (x * z + y * w) * v.z,
                2 * (x * y + z * w) * v.x + (1 - 2 * (x * x + z * z)) * v.y + 2 * (y * z - x * w) * v.z,
                2 * (x * z - y * w) * v.x + 2 * (y * z + x * w) * v.y + (1 - 2 * (x * x + y * y)) * v.z};
  };
  // The optical axis (z) in the body: backwards and 0.6 rad down; the image's x (right) is the
  // body's +y when looking backwards; image y (down) has a negative z part.
  const Vec3 axis = rotate(tf[0].rotation, rotate(tf[1].rotation, {0, 0, 1}));
  EXPECT_NEAR(axis.x, -std::cos(0.6), 1e-12);
  EXPECT_NEAR(axis.y, 0.0, 1e-12);
  EXPECT_NEAR(axis.z, -std::sin(0.6), 1e-12);
  const Vec3 right = rotate(tf[0].rotation, rotate(tf[1].rotation, {1, 0, 0}));
  EXPECT_NEAR(right.y, 1.0, 1e-12);
  const Vec3 down = rotate(tf[0].rotation, rotate(tf[1].rotation, {0, 1, 0}));
  EXPECT_LT(down.z, -0.8);
  // The same as body_to_optical (the project's one convention for the optical frame).
  const Vec3 fwd_in_optical = body_to_optical(cam.mount, axis);
  EXPECT_NEAR(fwd_in_optical.z, 1.0, 1e-12);
  // The ground frame looks where the camera looks (yaw pi).
  const Vec3 gx = rotate(tf[2].rotation, {1, 0, 0});
  EXPECT_NEAR(gx.x, -1.0, 1e-12);
  EXPECT_TRUE(static_transforms(RoverDescription{}).empty());
}
