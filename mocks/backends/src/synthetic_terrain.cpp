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
  fmt.rate_hz = p.get<double>("rate_hz", 10.0, {.unit = "Hz", .min = 0.0, .max = 10000.0, .min_exclusive = true,
                                                .doc = "frame rate of the simulated camera"});
  fmt.format = hal::pixel_format_from_string(
      p.get<std::string>("format", "mono8", {.choices = {"mono8", "bgr8"}, .doc = "output pixel format"}));
  fmt.width = p.get<int>("width", 320, {.unit = "px", .min = 16, .max = 4096, .doc = "image width"});
  fmt.height = p.get<int>("height", 240, {.unit = "px", .min = 16, .max = 4096, .doc = "image height"});
  const int frames = p.get<int>("frames", 20, {.min = 1, .max = 10000, .doc = "frames rendered at configure"});
  const bool loop = p.get<bool>("loop", true, {.doc = "repeat the rendered frames (else the last one stays)"});

  ts::SceneParams scene;
  scene.seed = static_cast<std::uint64_t>(p.get<std::int64_t>("seed", 1, {.min = 0, .doc = "terrain seed"}));
  scene.resolution_m = p.get<double>("resolution_m", 0.02, {.unit = "m", .min = 0.002, .max = 1.0,
                                                            .doc = "height-field cell size"});
  scene.fractal_rms_m = p.get<double>("fractal_rms_m", 0.02, {.unit = "m", .min = 0.0, .max = 1.0,
                                                              .doc = "RMS of the fractal terrain"});
  scene.num_rocks = p.get<int>("rocks", 12, {.min = 0, .max = 1000, .doc = "number of rocks"});
  scene.num_craters = p.get<int>("craters", 3, {.min = 0, .max = 100, .doc = "number of craters"});

  ts::CameraPose cam;
  cam.width = fmt.width;
  cam.height = fmt.height;
  const double hfov = p.get<double>("hfov_rad", 1.349, {.unit = "rad", .min = 0.05, .max = 3.0,
                                                        .doc = "horizontal field of view (pinhole)"});
  cam.fx = cam.fy = 0.5 * fmt.width / std::tan(0.5 * hfov);
  cam.cx = 0.5 * (fmt.width - 1);
  cam.cy = 0.5 * (fmt.height - 1);
  cam.height_m = p.get<double>("camera_height_m", 0.5, {.unit = "m", .min = 0.01, .max = 100.0,
                                                        .doc = "optical centre above z = 0"});
  cam.pitch_rad = p.get<double>("camera_pitch_rad", 0.35, {.unit = "rad", .min = -1.5, .max = 1.5,
                                                           .doc = "downward pitch of the camera"});
  cam.roll_rad = p.get<double>("camera_roll_rad", 0.0, {.unit = "rad", .min = -1.5, .max = 1.5, .doc = "roll"});
  cam.x_m = p.get<double>("start_x_m", 0.0, {.unit = "m", .doc = "rover start position (world x)"});
  cam.y_m = p.get<double>("start_y_m", 0.0, {.unit = "m", .doc = "rover start position (world y)"});
  cam.yaw_rad = p.get<double>("start_yaw_rad", 0.0, {.unit = "rad", .doc = "rover start heading"});
  const double speed = p.get<double>("speed_m_s", 0.05, {.unit = "m/s", .min = -10.0, .max = 10.0,
                                                         .doc = "forward motion between frames"});
  const double yaw_rate = p.get<double>("yaw_rate_rad_s", 0.0, {.unit = "rad/s", .min = -10.0, .max = 10.0,
                                                                .doc = "turn rate between frames"});

  ts::Sun sun;
  sun.azimuth_rad = p.get<double>("sun_azimuth_rad", 0.8, {.unit = "rad", .doc = "from +x towards +y"});
  sun.elevation_rad = p.get<double>("sun_elevation_rad", 0.6, {.unit = "rad", .min = 0.0, .max = 1.5707963,
                                                               .min_exclusive = true, .doc = "above the horizon"});
  ts::RenderOptions ro;
  ro.albedo = p.get<double>("albedo", 0.8, {.min = 0.0, .max = 1.0, .doc = "Lambertian albedo"});
  ro.noise_sigma = p.get<double>("noise_sigma", 0.01, {.min = 0.0, .max = 1.0,
                                                       .doc = "Gaussian image noise (image range 0..1)"});
  ro.cast_shadows = p.get<bool>("cast_shadows", false, {.doc = "ray-marched cast shadows (slower)"});

  std::vector<cv::Mat> images;
  try {
    scene.validate();
    cam.validate();
    const ts::Terrain terrain(scene);
    const double dt = 1.0 / fmt.rate_hz;
    for (int k = 0; k < frames; ++k) {
      if (cam.x_m < terrain.x_min() || cam.x_m > terrain.x_max() || cam.y_m < terrain.y_min() ||
          cam.y_m > terrain.y_max())
        p.fail("speed_m_s", "the camera leaves the terrain at frame " + std::to_string(k) +
                                " (fewer frames or a lower speed)");
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
