// Camera "synthetic_tracks": a rear camera looking back along the rover's own wheel tracks
// (regolith::track_scene): ruts as deep as the rigid-wheel relation gives for the configured soil
// (k, n), wheel loads, width and diameter, shaded under a known sun. All frames are rendered at
// configure time (about 0.3 s each at 640x480); frame k uses seed + k (texture and noise).
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/track_scene/track_scene.hpp"

namespace regolith::mocks {

std::unique_ptr<hal::Camera> make_synthetic_tracks_camera(Params& p, const hal::DeviceContext& ctx) {
  namespace tsc = regolith::track_scene;
  hal::CameraFormat fmt;
  fmt.rate_hz = p.get<double>("rate_hz", 2.0,
                              {.unit = "Hz",
                               .min = 0.0,
                               .max = 1000.0,
                               .min_exclusive = true,
                               .doc = "frame rate of the simulated rear camera"});
  fmt.format = hal::pixel_format_from_string(
      p.get<std::string>("format", "mono8", {.choices = {"mono8", "bgr8"}, .doc = "output pixel format"}));
  tsc::TrackSceneParams s;
  const detail::SceneDescription desc = detail::scene_description(
      p, ctx, {"fx", "fy", "cx", "cy", "mount_height_m", "pitch_rad"}, {"sun_azimuth_rad", "sun_elevation_rad"});
  const cv::Size size = detail::scene_image_size(p, desc, {640, 480});
  fmt.width = s.camera.width = size.width;
  fmt.height = s.camera.height = size.height;
  const int frames =
      p.get<int>("frames", 2, {.min = 1, .max = 100, .doc = "frames rendered at configure (noise seeds)"});
  // Without a rover.cameras entry: fx = fy = 500 px, centred, 1.2 m high, pitched 0.61 rad down,
  // looking back (yaw pi). Without a deployment sun: from the left of the view, 45 deg high.
  s.camera.fx = s.camera.fy = 500.0;
  s.camera.cx = 0.5 * (fmt.width - 1);
  s.camera.cy = 0.5 * (fmt.height - 1);
  Pose mount{.z_m = 1.2, .pitch_rad = 0.61, .yaw_rad = 3.14159265358979323846};
  if (desc.camera != nullptr) {
    const CameraInfo& ci = desc.camera->info;
    s.camera.fx = ci.fx();
    s.camera.fy = ci.fy();
    s.camera.cx = ci.cx();
    s.camera.cy = ci.cy();
    mount = desc.camera->mount;
  }
  s.camera.mount_height_m = mount.z_m;
  s.camera.pitch_rad = mount.pitch_rad;
  if (desc.sun != nullptr) {  // the scene frame is the camera's ground frame
    const Vec3 g = sun_in_camera_ground(*desc.sun, mount);
    s.sun.azimuth_rad = azimuth_ccw(g);
    s.sun.elevation_rad = elevation(g);
  }
  s.k = p.get<double>("k", 5.0e5,
                      {.unit = "N/m^(n+2)",
                       .min = 0.0,
                       .min_exclusive = true,
                       .doc = "true Bernstein-Goriatchkin modulus of the soil"});
  s.n = p.get<double>("n", 1.0, {.min = 0.0, .max = 2.9, .doc = "true sinkage exponent"});
  if (ctx.rover != nullptr && !ctx.rover->wheels.empty()) {  // the ruts of the rover's own wheels
    const std::string where = "the wheels are described once, in rover.wheels";
    p.reject_moved("wheel_width_m", where);
    p.reject_moved("wheel_diameter_m", where);
    s.wheel_width_m = ctx.rover->wheels.front().width_m;
    s.wheel_diameter_m = 2.0 * ctx.rover->wheels.front().radius_m;
  } else {
    s.wheel_width_m =
        p.get<double>("wheel_width_m", 0.10, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "b"});
    s.wheel_diameter_m =
        p.get<double>("wheel_diameter_m", 0.30, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "D"});
  }
  const auto lat = p.get<std::vector<double>>("track_lateral_m", {0.4, -0.4},
                                              {.unit = "m", .doc = "rut centres in the camera ground frame (left +)"});
  const auto load = p.get<std::vector<double>>(
      "track_load_n", {60.0, 60.0},
      {.unit = "N", .min = 0.0, .doc = "wheel load that made each rut (one per track_lateral_m)"});
  if (lat.size() != load.size())
    p.fail("track_load_n", "needs one load per track_lateral_m entry (" + std::to_string(lat.size()) + "), got " +
                               std::to_string(load.size()));
  s.tracks.clear();
  for (std::size_t i = 0; i < lat.size(); ++i) s.tracks.push_back({lat[i], load[i]});
  s.albedo_texture = p.get<double>("albedo_texture", 0.03, {.min = 0.0, .max = 0.5, .doc = "relative albedo texture"});
  s.noise_dn = p.get<double>("noise_dn", 1.0, {.min = 0.0, .max = 50.0, .doc = "sensor noise std [DN]"});
  s.x_max_m =
      p.get<double>("scene_length_m", 10.0,
                    {.unit = "m", .min = 1.0, .max = 100.0, .doc = "ground rendered up to this range (beyond: flat)"});
  const auto seed = static_cast<std::uint32_t>(
      p.get<std::int64_t>("seed", 1, {.min = 0, .max = 4294967295.0, .doc = "texture / noise seed"}));
  const bool loop = p.get<bool>("loop", true, {.doc = "repeat the rendered frames (else the last one stays)"});

  std::vector<cv::Mat> images;
  try {
    s.validate();
    if (!ctx.open_devices) {  // `config check`: parameters validated, nothing rendered
      images.emplace_back(fmt.height, fmt.width, hal::cv_type(fmt.format), cv::Scalar::all(0));
      return std::make_unique<detail::PreloadedCamera>(ctx, fmt, std::move(images), loop);
    }
    for (int k = 0; k < frames; ++k) {
      s.seed = seed + static_cast<std::uint32_t>(k);
      tsc::TrackScene scene = tsc::generate_track_scene(s);
      cv::Mat u8 = scene.image;
      if (fmt.format == hal::PixelFormat::kBgr8) {
        cv::Mat bgr;
        cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
        u8 = bgr;
      }
      images.push_back(u8.isContinuous() ? u8 : u8.clone());
    }
  } catch (const std::invalid_argument& e) {
    p.fail({}, std::string("invalid track scene: ") + e.what());
  }
  return std::make_unique<detail::PreloadedCamera>(ctx, fmt, std::move(images), loop);
}

}  // namespace regolith::mocks
