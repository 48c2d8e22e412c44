#include "regolith/core/rover.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "regolith/core/image_limits.hpp"

namespace regolith {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

void check_k(Params& p, std::string_view key, const std::array<double, 9>& k) {
  if (!(k[0] > 0.0) || !(k[4] > 0.0)) p.fail(key, "fx (k[0]) and fy (k[4]) must be > 0 px");
  if (k[1] != 0.0) p.fail(key, "skew (k[1]) must be 0: skewed pixels are not supported");
  if (k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0) p.fail(key, "must be [fx, 0, cx, 0, fy, cy, 0, 0, 1]");
  for (double v : k)
    if (!std::isfinite(v)) p.fail(key, "must be finite");
}

void check_distortion(Params& p, std::string_view model_key, const std::string& model, std::string_view d_key,
                      const std::vector<double>& d) {
  if (model != "plumb_bob" && model != "none")
    p.fail(model_key, "'" + model + "' is not supported (plumb_bob: D = [k1, k2, p1, p2, k3], or none)");
  if (model == "none" && !d.empty()) p.fail(d_key, "must be empty for distortion_model none");
  if (d.size() > 5) p.fail(d_key, "plumb_bob has at most 5 coefficients [k1, k2, p1, p2, k3]");
  for (double v : d)
    if (!std::isfinite(v)) p.fail(d_key, "must be finite");
}

std::array<double, 9> to_k(Params& p, std::string_view key, const std::vector<double>& v) {
  if (v.size() != 9) p.fail(key, "needs 9 numbers (row-major 3x3), got " + std::to_string(v.size()));
  std::array<double, 9> k{};
  for (std::size_t i = 0; i < 9; ++i) k[i] = v[i];
  return k;
}

CameraInfo read_inline_info(Params p) {
  CameraInfo c;
  c.width = p.require<int>("width", {.unit = "px", .min = 8, .max = kMaxImageSidePx, .doc = "image width"});
  c.height = p.require<int>("height", {.unit = "px", .min = 8, .max = kMaxImageSidePx, .doc = "image height"});
  c.k = to_k(p, "k",
             p.require<std::vector<double>>(
                 "k", {.unit = "px", .doc = "intrinsic matrix, row-major [fx 0 cx; 0 fy cy; 0 0 1]"}));
  check_k(p, "k", c.k);
  c.distortion_model =
      p.get<std::string>("distortion_model", "plumb_bob", {.doc = "plumb_bob (OpenCV k1 k2 p1 p2 k3) or none"});
  c.d = p.get<std::vector<double>>("d", {}, {.doc = "distortion coefficients [k1, k2, p1, p2, k3]"});
  check_distortion(p, "distortion_model", c.distortion_model, "d", c.d);
  p.finish();
  return c;
}

Pose read_mount(Params p) {
  Pose m;
  m.x_m = p.get<double>("x_m", 0.0, {.unit = "m", .doc = "camera position in the body frame (forward)"});
  m.y_m = p.get<double>("y_m", 0.0, {.unit = "m", .doc = "camera position in the body frame (left)"});
  m.z_m = p.require<double>(
      "z_m",
      {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "optical centre above the ground under the body centre"});
  m.roll_rad =
      p.get<double>("roll_rad", 0.0, {.unit = "rad", .min = -1.5707, .max = 1.5707, .doc = "about the optical axis"});
  m.pitch_rad = p.get<double>(
      "pitch_rad", 0.0,
      {.unit = "rad", .min = -1.5707, .max = 1.5707, .doc = "optical axis below the horizontal (down positive)"});
  m.yaw_rad = p.get<double>(
      "yaw_rad", 0.0,
      {.unit = "rad", .min = -2 * kPi, .max = 2 * kPi, .doc = "viewing heading in the body frame (pi = rear)"});
  p.finish();
  return m;
}

RoverCamera read_camera(Params p, const std::string& name, const std::string& config_dir) {
  RoverCamera c;
  c.name = name;
  c.where = p.where();
  c.frame_id =
      p.get<std::string>("frame_id", name + "_optical_frame", {.doc = "optical frame name (tf, message headers)"});
  const bool inline_info = p.has("camera_info");
  const std::string url = p.get<std::string>(
      "camera_info_url", "", {.doc = "file://PATH of a ROS camera_calibration YAML (relative to this file)"});
  if (inline_info == !url.empty())
    p.fail(inline_info ? "camera_info_url" : std::string_view(),
           "give the intrinsics once: either camera_info {width, height, k, distortion_model, d} or camera_info_url: "
           "file://PATH");
  if (inline_info) {
    c.info = read_inline_info(p.child("camera_info"));
  } else {
    const std::string prefix = "file://";
    if (url.rfind(prefix, 0) != 0) p.fail("camera_info_url", "only file:// URLs are supported (got '" + url + "')");
    std::filesystem::path path(url.substr(prefix.size()));
    if (path.is_relative()) path = std::filesystem::path(config_dir) / path;
    try {
      c.info = read_camera_calibration(path.string());
    } catch (const ConfigError& e) {
      p.fail("camera_info_url", e.what());
    }
  }
  c.mount = read_mount(p.require_child("mount"));
  p.finish();
  return c;
}

}  // namespace

Rotation Rotation::operator*(const Rotation& o) const {
  Rotation r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0.0;
      for (int k = 0; k < 3; ++k)
        s += m[static_cast<std::size_t>(3 * i + k)] * o.m[static_cast<std::size_t>(3 * k + j)];
      r.m[static_cast<std::size_t>(3 * i + j)] = s;
    }
  return r;
}

Rotation Rotation::transposed() const {
  return {{m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]}};
}

Rotation Rotation::from_rpy(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll), sr = std::sin(roll);
  const double cp = std::cos(pitch), sp = std::sin(pitch);
  const double cy = std::cos(yaw), sy = std::sin(yaw);
  const Rotation rz{{cy, -sy, 0, sy, cy, 0, 0, 0, 1}};
  const Rotation ry{{cp, 0, sp, 0, 1, 0, -sp, 0, cp}};
  const Rotation rx{{1, 0, 0, 0, cr, -sr, 0, sr, cr}};
  return rz * ry * rx;
}

std::array<double, 4> quaternion(const Rotation& r) {
  const auto& m = r.m;
  // Shepperd's method: the largest of w, x, y, z first, for accuracy.
  const double t = m[0] + m[4] + m[8];
  std::array<double, 4> q{};
  if (t > m[0] && t > m[4] && t > m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + t);
    q = {(m[7] - m[5]) / s, (m[2] - m[6]) / s, (m[3] - m[1]) / s, 0.25 * s};
  } else if (m[0] >= m[4] && m[0] >= m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0] - m[4] - m[8]);
    q = {0.25 * s, (m[1] + m[3]) / s, (m[2] + m[6]) / s, (m[7] - m[5]) / s};
  } else if (m[4] >= m[8]) {
    const double s = 2.0 * std::sqrt(1.0 + m[4] - m[0] - m[8]);
    q = {(m[1] + m[3]) / s, 0.25 * s, (m[5] + m[7]) / s, (m[2] - m[6]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[8] - m[0] - m[4]);
    q = {(m[2] + m[6]) / s, (m[5] + m[7]) / s, 0.25 * s, (m[3] - m[1]) / s};
  }
  if (q[3] < 0) q = {-q[0], -q[1], -q[2], -q[3]};
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (double& v : q) v /= n;
  return q;
}

std::vector<FrameTransform> static_transforms(const RoverDescription& rover) {
  // Optical axes in the link frame (columns): x right = -y, y down = -z, z forward = +x.
  const Rotation link_from_optical{{0, 0, 1, -1, 0, 0, 0, -1, 0}};
  std::vector<FrameTransform> out;
  for (const auto& [name, cam] : rover.cameras) {
    const Pose& m = cam.mount;
    out.push_back({rover.base_frame, name + "_link", {m.x_m, m.y_m, m.z_m}, quaternion(m.rotation())});
    out.push_back({name + "_link", cam.frame_id, {}, quaternion(link_from_optical)});
    out.push_back(
        {rover.base_frame, name + "_ground", {m.x_m, m.y_m, 0.0}, quaternion(Rotation::from_rpy(0.0, 0.0, m.yaw_rad))});
  }
  return out;
}

Vec3 Sun::local_level() const {
  const double ce = std::cos(elevation_rad);
  // Compass azimuth: clockwise from +x (heading at start) towards -y (right).
  return {ce * std::cos(azimuth_rad), -ce * std::sin(azimuth_rad), std::sin(elevation_rad)};
}

Vec3 sun_in_body(const Sun& sun, const Attitude& attitude) {
  return attitude.rotation().transposed() * sun.local_level();
}

Vec3 body_to_optical(const Pose& mount, const Vec3& v_body) {
  const Vec3 l = mount.rotation().transposed() * v_body;  // camera link: x optical axis, y left, z up
  return {-l.y, -l.z, l.x};
}

Vec3 sun_in_optical(const Sun& sun, const Pose& mount, const Attitude& attitude) {
  return body_to_optical(mount, sun_in_body(sun, attitude));
}

Vec3 sun_in_camera_ground(const Sun& sun, const Pose& mount, const Attitude& attitude) {
  return Rotation::from_rpy(0.0, 0.0, mount.yaw_rad).transposed() * sun_in_body(sun, attitude);
}

double azimuth_ccw(const Vec3& v) {
  return std::atan2(v.y, v.x);
}

double elevation(const Vec3& v) {
  const double n = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return n > 0.0 ? std::asin(std::clamp(v.z / n, -1.0, 1.0)) : 0.0;
}

Sun read_sun(Params p) {
  Sun s;
  s.azimuth_rad =
      kDeg *
      p.require<double>(
          "azimuth_deg",
          {.unit = "deg",
           .min = -360.0,
           .max = 360.0,
           .doc =
               "compass azimuth in the local-level frame: clockwise from the rover's heading at start (90 = right)"});
  s.elevation_rad =
      kDeg * p.require<double>(
                 "elevation_deg",
                 {.unit = "deg", .min = 0.0, .max = 90.0, .min_exclusive = true, .doc = "above the local horizon"});
  p.finish();
  return s;
}

CameraInfo read_camera_calibration(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw ConfigError(path + ": camera calibration file not found");
  Params p = Params::load_file(path);
  CameraInfo c;
  c.width = p.require<int>("image_width", {.unit = "px", .min = 8, .max = kMaxImageSidePx});
  c.height = p.require<int>("image_height", {.unit = "px", .min = 8, .max = kMaxImageSidePx});
  p.get<std::string>("camera_name", "");
  auto matrix = [&](std::string_view key, int rows, int cols, bool required) {
    if (!required && !p.has(key)) {
      p.child(key);  // mark as read
      return std::vector<double>{};
    }
    Params m = p.require_child(key);
    const int r = m.get<int>("rows", rows), c2 = m.get<int>("cols", cols);
    if (r != rows || c2 != cols)
      m.fail("rows", "expected " + std::to_string(rows) + "x" + std::to_string(cols) + ", got " + std::to_string(r) +
                         "x" + std::to_string(c2));
    auto data = m.require<std::vector<double>>("data");
    if (data.size() != static_cast<std::size_t>(rows * cols))
      m.fail("data", "needs " + std::to_string(rows * cols) + " numbers, got " + std::to_string(data.size()));
    m.finish();
    return data;
  };
  const auto k = matrix("camera_matrix", 3, 3, true);
  c.k = to_k(p, "camera_matrix", k);
  check_k(p, "camera_matrix", c.k);
  c.distortion_model = p.get<std::string>("distortion_model", "plumb_bob");
  if (p.has("distortion_coefficients")) {
    Params d = p.child("distortion_coefficients");
    d.get<int>("rows", 1);
    d.get<int>("cols", 5);
    c.d = d.require<std::vector<double>>("data");
    d.finish();
  }
  check_distortion(p, "distortion_model", c.distortion_model, "distortion_coefficients", c.d);
  matrix("rectification_matrix", 3, 3, false);  // monocular: identity, not used
  matrix("projection_matrix", 3, 4, false);
  p.finish();
  return c;
}

RoverDescription read_rover_description(Params& root, const std::string& config_dir) {
  RoverDescription d;
  if (root.has("sun")) d.sun = read_sun(root.child("sun"));
  Params r = root.child("rover");
  d.base_frame = r.get<std::string>("base_frame", d.base_frame,
                                    {.doc = "body frame (REP-103), origin on the ground below the body centre"});
  d.mass_kg = r.get<double>("mass_kg", 0.0, {.unit = "kg", .min = 0.0, .doc = "total rover mass (0 = not given)"});
  d.gravity_mps2 = r.get<double>("gravity_mps2", 0.0,
                                 {.unit = "m/s^2", .min = 0.0, .max = 100.0, .doc = "surface gravity (0 = not given)"});
  d.imu =
      r.get<std::string>("imu", "", {.doc = "IMU device giving the body attitude (devices.imus.<name>); empty: level"});
  std::set<std::string> wheel_names;
  for (Params w : r.child_list("wheels")) {
    Wheel wh;
    wh.name = w.require<std::string>("name", {.doc = "joint name (joint_states)"});
    if (!wheel_names.insert(wh.name).second) w.fail("name", "wheel '" + wh.name + "' is declared twice");
    wh.x_m = w.require<double>("x_m", {.unit = "m", .doc = "contact point, body x"});
    wh.y_m = w.require<double>("y_m", {.unit = "m", .doc = "contact point, body y (left +)"});
    wh.radius_m =
        w.require<double>("radius_m", {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "wheel radius"});
    wh.width_m = w.require<double>("width_m", {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "wheel width"});
    wh.encoders =
        w.get<std::string>("encoders", "", {.doc = "encoder device reporting this wheel (devices.encoders.<name>)"});
    wh.max_rate_rad_s = w.get<double>(
        "max_rate_rad_s", wh.max_rate_rad_s,
        {.unit = "rad/s",
         .min = 0.0,
         .max = 1e4,
         .min_exclusive = true,
         .doc =
             "fastest the wheel can turn: an encoder sample implying a faster turn is rejected as corrupt (counted)"});
    w.finish();
    d.wheels.push_back(std::move(wh));
  }
  Params cams = r.child("cameras");
  for (const auto& name : cams.keys()) d.cameras.emplace(name, read_camera(cams.child(name), name, config_dir));
  cams.finish();
  r.finish();
  return d;
}

}  // namespace regolith
