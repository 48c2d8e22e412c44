// Camera "synthetic_terrain": a rover camera driving over generated Lambertian terrain
// (regolith::terrain_scene), all frames rendered at configure time.
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

namespace regolith::mocks {

std::unique_ptr<hal::Camera> make_synthetic_terrain_camera(Params& p, const hal::DeviceContext& ctx) {
  namespace ts = regolith::terrain_scene;
  hal::CameraFormat fmt;
  fmt.rate_hz = p.get<double>(
      "rate_hz", 10.0,
      {.unit = "Hz", .min = 0.0, .max = 10000.0, .min_exclusive = true, .doc = "frame rate of the simulated camera"});
  fmt.format = hal::pixel_format_from_string(
      p.get<std::string>("format", "mono8", {.choices = {"mono8", "bgr8"}, .doc = "output pixel format"}));
  const detail::SceneDescription desc =
      detail::scene_description(p, ctx, {"hfov_rad", "camera_height_m", "camera_pitch_rad", "camera_roll_rad"},
                                {"sun_azimuth_rad", "sun_elevation_rad"});
  const cv::Size size = detail::scene_image_size(p, desc, {320, 240});
  fmt.width = size.width;
  fmt.height = size.height;
  const int frames = p.get<int>("frames", 20, {.min = 1, .max = 10000, .doc = "frames rendered at configure"});
  detail::check_preload(p, "frames", static_cast<std::uint64_t>(frames), size,
                        fmt.format == hal::PixelFormat::kBgr8 ? 3 : 1);
  const bool loop = p.get<bool>("loop", true, {.doc = "repeat the rendered frames (else the last one stays)"});

  ts::SceneParams scene;
  scene.seed = static_cast<std::uint64_t>(p.get<std::int64_t>("seed", 1, {.min = 0, .doc = "terrain seed"}));
  scene.resolution_m =
      p.get<double>("resolution_m", 0.02, {.unit = "m", .min = 0.002, .max = 1.0, .doc = "height-field cell size"});
  scene.fractal_rms_m =
      p.get<double>("fractal_rms_m", 0.02, {.unit = "m", .min = 0.0, .max = 1.0, .doc = "RMS of the fractal terrain"});
  scene.num_rocks = p.get<int>("rocks", 12, {.min = 0, .max = 1000, .doc = "number of rocks"});
  scene.num_craters = p.get<int>("craters", 3, {.min = 0, .max = 100, .doc = "number of craters"});

  ts::CameraPose cam;
  cam.width = fmt.width;
  cam.height = fmt.height;
  // Without a rover.cameras entry: a 1.349 rad (77 deg) horizontal field of view, 0.5 m high,
  // pitched 0.35 rad down, at the body origin.
  Pose mount{.z_m = 0.5, .pitch_rad = 0.35};
  cam.fx = cam.fy = 0.5 * fmt.width / std::tan(0.5 * 1.349);
  cam.cx = 0.5 * (fmt.width - 1);
  cam.cy = 0.5 * (fmt.height - 1);
  if (desc.camera != nullptr) {
    const CameraInfo& ci = desc.camera->info;
    cam.fx = ci.fx();
    cam.fy = ci.fy();
    cam.cx = ci.cx();
    cam.cy = ci.cy();
    mount = desc.camera->mount;
  }
  cam.height_m = mount.z_m;
  cam.pitch_rad = mount.pitch_rad;
  cam.roll_rad = mount.roll_rad;
  const double start_x = p.get<double>("start_x_m", 0.0, {.unit = "m", .doc = "rover start position (world x)"});
  const double start_y = p.get<double>("start_y_m", 0.0, {.unit = "m", .doc = "rover start position (world y)"});
  const double start_yaw = p.get<double>("start_yaw_rad", 0.0, {.unit = "rad", .doc = "rover start heading"});
  // The world is the local-level frame at start: the camera sits at the mount offset of the body.
  cam.x_m = start_x + std::cos(start_yaw) * mount.x_m - std::sin(start_yaw) * mount.y_m;
  cam.y_m = start_y + std::sin(start_yaw) * mount.x_m + std::cos(start_yaw) * mount.y_m;
  cam.yaw_rad = start_yaw + mount.yaw_rad;
  const double speed = p.get<double>(
      "speed_m_s", 0.05, {.unit = "m/s", .min = -10.0, .max = 10.0, .doc = "forward motion between frames"});
  const double yaw_rate = p.get<double>(
      "yaw_rate_rad_s", 0.0, {.unit = "rad/s", .min = -10.0, .max = 10.0, .doc = "turn rate between frames"});

  ts::Sun sun;  // without a deployment sun: 0.8 rad counter-clockwise from +x, 0.6 rad high
  sun.azimuth_rad = 0.8;
  sun.elevation_rad = 0.6;
  if (desc.sun != nullptr) {
    const Vec3 s = desc.sun->local_level();  // scene world = local level at start
    sun.azimuth_rad = azimuth_ccw(s);
    sun.elevation_rad = elevation(s);
  }
  ts::RenderOptions ro;
  ro.albedo = p.get<double>("albedo", 0.8, {.min = 0.0, .max = 1.0, .doc = "Lambertian albedo"});
  ro.noise_sigma =
      p.get<double>("noise_sigma", 0.01, {.min = 0.0, .max = 1.0, .doc = "Gaussian image noise (image range 0..1)"});
  ro.cast_shadows = p.get<bool>("cast_shadows", false, {.doc = "ray-marched cast shadows (slower)"});

  std::vector<cv::Mat> images;
  try {
    scene.validate();
    cam.validate();
    if (!ctx.open_devices) {  // `config check`: parameters validated, nothing rendered
      images.emplace_back(fmt.height, fmt.width, hal::cv_type(fmt.format), cv::Scalar::all(0));
      return std::make_unique<detail::PreloadedCamera>(ctx, fmt, std::move(images), loop);
    }
    const ts::Terrain terrain(scene);
    const double dt = 1.0 / fmt.rate_hz;
    for (int k = 0; k < frames; ++k) {
      if (cam.x_m < terrain.x_min() || cam.x_m > terrain.x_max() || cam.y_m < terrain.y_min() ||
          cam.y_m > terrain.y_max())
        p.fail("speed_m_s",
               "the camera leaves the terrain at frame " + std::to_string(k) + " (fewer frames or a lower speed)");
      ro.noise_seed = scene.seed * 1000003ULL + static_cast<std::uint64_t>(k);
      const ts::CameraImage img = ts::render_camera(terrain, cam, sun, ro);
      cv::Mat u8 = ts::to_u8(img.image);
      if (fmt.format == hal::PixelFormat::kBgr8) {
        cv::Mat bgr;
        cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
        u8 = bgr;
      }
      images.push_back(u8.isContinuous() ? u8 : u8.clone());
      cam.x_m += speed * std::cos(cam.yaw_rad) * dt;
      cam.y_m += speed * std::sin(cam.yaw_rad) * dt;
      cam.yaw_rad += yaw_rate * dt;
    }
  } catch (const std::invalid_argument& e) {
    p.fail({}, std::string("invalid scene: ") + e.what());
  }
  return std::make_unique<detail::PreloadedCamera>(ctx, fmt, std::move(images), loop);
}

}  // namespace regolith::mocks
