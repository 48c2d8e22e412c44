#include "regolith/common/camera.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "regolith/core/error.hpp"

namespace regolith::common {

direct_depth::CameraModel camera_model_of(const RoverCamera& camera) {
  const CameraInfo& ci = camera.info;
  direct_depth::CameraModel m;
  m.width = ci.width;
  m.height = ci.height;
  m.fx = ci.fx();
  m.fy = ci.fy();
  m.cx = ci.cx();
  m.cy = ci.cy();
  m.k1 = ci.d_at(0);
  m.k2 = ci.d_at(1);
  m.p1 = ci.d_at(2);
  m.p2 = ci.d_at(3);
  m.k3 = ci.d_at(4);
  m.mount_height_m = camera.mount.z_m;
  m.pitch_rad = camera.mount.pitch_rad;
  m.roll_rad = camera.mount.roll_rad;
  return m;
}

direct_depth::CameraModel camera_model_for_frames(const RoverCamera& camera, int width, int height, Params& p,
                                                  std::string_view key) {
  if (camera.info.width != width || camera.info.height != height)
    p.fail(key, "rover.cameras." + camera.name + " is " + std::to_string(camera.info.width) + "x" +
                    std::to_string(camera.info.height) + " px but the frames are " + std::to_string(width) + "x" +
                    std::to_string(height) + " px (" + camera.where + ")");
  direct_depth::CameraModel m = camera_model_of(camera);
  try {
    m.validate();
  } catch (const FieldError& e) {
    throw ConfigError(camera.where + ": rover.cameras." + camera.name + ": " + e.what());
  }
  return m;
}

CameraLight camera_light(const Sun& sun, const RoverCamera& camera, const Attitude& attitude) {
  const Vec3 s = sun_in_optical(sun, camera.mount, attitude);
  // Image frame = optical frame with z towards the viewer: S_img = (x, y, -z).
  CameraLight out;
  out.light.slant_rad = std::acos(std::clamp(-s.z, -1.0, 1.0));
  out.light.tilt_rad = std::atan2(s.y, s.x);
  out.in_view = out.light.slant_rad < 0.5 * 3.14159265358979323846;
  return out;
}

GroundSun ground_sun(const Sun& sun, const RoverCamera& camera, const Attitude& attitude) {
  const Vec3 g = sun_in_camera_ground(sun, camera.mount, attitude);
  return {azimuth_ccw(g), elevation(g)};
}

}  // namespace regolith::common
