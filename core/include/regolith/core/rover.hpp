#pragma once
// The rover description of a deployment: the body frame, the wheels, every camera's calibration
// and mount, and the one sun. Declared once in the deployment YAML (`rover:` and `sun:` blocks),
// read by one reader, handed to every consumer (components, mock scenes, CLI tools).
//
// Frames (REP-103 / REP-105):
//  * body (`base_link`): x forward, y left, z up; origin on the ground below the body centre, so a
//    mount's z is its height above level ground.
//  * local level: the body frame at start-up with roll and pitch removed (x = the heading at start,
//    y left, z up). The sun is given here. Compass azimuth: clockwise seen from above, 0 = the
//    rover's heading at start (taken as north), 90 deg = to its right (east).
//  * camera link: the mount pose's frame (x along the optical axis, y left, z up); optical frame:
//    z forward along the optical axis, x right, y down (ROS `camera_optical_frame`).
//  * mount pose: translation (x, y, z) and roll, pitch, yaw of the camera link in the body frame,
//    R = Rz(yaw) Ry(pitch) Rx(roll). Pitch > 0 tilts the optical axis DOWN (REP-103 right hand
//    about +y left), yaw = pi looks backwards.
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"

namespace regolith {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

/// 3x3 rotation, row-major.
struct Rotation {
  std::array<double, 9> m{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3 operator*(const Vec3& v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z};
  }
  Rotation operator*(const Rotation& o) const;
  Rotation transposed() const;
  /// Rz(yaw) Ry(pitch) Rx(roll): the REP-103 fixed-axis roll-pitch-yaw convention.
  static Rotation from_rpy(double roll, double pitch, double yaw);
};

/// A frame's pose in its parent: translation [m] and roll, pitch, yaw [rad].
struct Pose {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;
  double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;
  Rotation rotation() const { return Rotation::from_rpy(roll_rad, pitch_rad, yaw_rad); }
};

/// Body attitude in the local-level frame (IMU orientation, or level: all zero).
struct Attitude {
  double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;
  Rotation rotation() const { return Rotation::from_rpy(roll_rad, pitch_rad, yaw_rad); }
};

/// ROS `sensor_msgs/CameraInfo` intrinsics: image size, K and the distortion model with D.
struct CameraInfo {
  int width = 0, height = 0;                           ///< px
  std::array<double, 9> k{0, 0, 0, 0, 0, 0, 0, 0, 1};  ///< [fx 0 cx; 0 fy cy; 0 0 1], px
  std::string distortion_model = "plumb_bob";          ///< plumb_bob (D = k1 k2 p1 p2 k3) or none
  std::vector<double> d;                               ///< distortion coefficients
  double fx() const { return k[0]; }
  double fy() const { return k[4]; }
  double cx() const { return k[2]; }
  double cy() const { return k[5]; }
  /// D entry i, 0 when D is shorter.
  double d_at(std::size_t i) const { return i < d.size() ? d[i] : 0.0; }
};

struct RoverCamera {
  std::string name;      ///< the camera device (devices.cameras.<name>)
  std::string frame_id;  ///< optical frame name, default <name>_optical_frame
  CameraInfo info;
  Pose mount;         ///< camera link in the body frame
  std::string where;  ///< "file:line:col" of its declaration (for messages)
};

struct Wheel {
  std::string name;             ///< joint name, e.g. wheel_fl
  double x_m = 0.0, y_m = 0.0;  ///< contact point in the body frame
  double radius_m = 0.0, width_m = 0.0;
  std::string encoders;          ///< encoder device that reports it (devices.encoders.<name>)
  double max_rate_rad_s = 50.0;  ///< fastest it can turn: encoder samples implying more are rejected
};

/// Direction towards the sun in the local-level frame: compass azimuth (clockwise from the heading
/// at start) and elevation above the horizon. One per deployment.
struct Sun {
  double azimuth_rad = 0.0;
  double elevation_rad = 0.0;
  /// Unit vector towards the sun in the local-level frame (x forward at start, y left, z up).
  Vec3 local_level() const;
};

struct RoverDescription {
  std::string base_frame = "base_link";
  double mass_kg = 0.0;       ///< 0 = not given
  double gravity_mps2 = 0.0;  ///< surface gravity, 0 = not given
  std::vector<Wheel> wheels;
  std::map<std::string, RoverCamera> cameras;
  std::string imu;  ///< IMU device giving the body attitude (devices.imus.<name>), empty = level
  std::optional<Sun> sun;

  const RoverCamera* camera(const std::string& name) const {
    const auto it = cameras.find(name);
    return it == cameras.end() ? nullptr : &it->second;
  }
};

/// Unit vector towards the sun in the body frame for a body at `attitude` (level when default).
Vec3 sun_in_body(const Sun& sun, const Attitude& attitude = {});
/// A body-frame vector in a camera's optical frame (z forward, x right, y down).
Vec3 body_to_optical(const Pose& mount, const Vec3& v_body);
/// Unit vector towards the sun in the camera's optical frame.
Vec3 sun_in_optical(const Sun& sun, const Pose& mount, const Attitude& attitude = {});
/// Unit vector towards the sun in a camera's ground frame: the body frame turned by the mount's
/// yaw (x = the camera's viewing heading, y left, z up). The frame of the track scenes and soil.
Vec3 sun_in_camera_ground(const Sun& sun, const Pose& mount, const Attitude& attitude = {});
/// Azimuth of a z-up vector from +x towards +y (counter-clockwise seen from above) [rad].
double azimuth_ccw(const Vec3& v);
/// Elevation of a z-up vector above the x-y plane [rad].
double elevation(const Vec3& v);

/// Unit quaternion (x, y, z, w) of a rotation (w >= 0).
std::array<double, 4> quaternion(const Rotation& r);

/// One fixed transform of the rover (tf2): the pose of `child` in `parent`.
struct FrameTransform {
  std::string parent, child;
  Vec3 translation;                            ///< m, child origin in the parent frame
  std::array<double, 4> rotation{0, 0, 0, 1};  ///< unit quaternion (x, y, z, w)
};
/// The rover's fixed frames for /tf_static, per camera (REP-103/105 names):
///   base_frame -> <camera>_link: the mount (x along the optical axis, y left, z up);
///   <camera>_link -> frame_id (<camera>_optical_frame): z forward, x right, y down;
///   base_frame -> <camera>_ground: the camera's ground frame (origin on level ground below the
///   camera, x = its viewing heading, y left, z up; the frame of soil profiles and track scenes).
std::vector<FrameTransform> static_transforms(const RoverDescription& rover);

/// Reads the deployment's `rover:` mapping (may be absent: an empty description) and the top-level
/// `sun:` mapping. `camera_info_url: file://PATH` (relative to `config_dir`) loads a ROS
/// `camera_calibration` YAML file. Every problem is a located ConfigError.
RoverDescription read_rover_description(Params& root, const std::string& config_dir);
/// Reads one ROS camera_calibration YAML file (image_width, image_height, camera_matrix,
/// distortion_model, distortion_coefficients, ...). ConfigError naming the file and field.
CameraInfo read_camera_calibration(const std::string& path);
/// The `sun:` mapping: azimuth_deg / elevation_deg (compass, local level).
Sun read_sun(Params p);

}  // namespace regolith
