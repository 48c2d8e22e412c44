#include "regolith/common/json_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "regolith/core/error.hpp"
#include "regolith/core/json_file.hpp"

namespace regolith::common {

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

std::string degrees(double rad) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", rad / kDeg);
  return buf;
}

struct Orientation {
  double pitch_rad = 0.0, roll_rad = 0.0;
};

// `camera.R_world_from_camera` when present: the camera's axes (x right, y down, z along the optical
// axis) in the scene's world (X right, Y forward, Z up), as the development scenes give it. Returns
// the pitch (the axis' depression) and roll (about the axis) of direct_depth's model, which is
// R_body_from_optical = Pitch(a) * b0 * Rz(roll) in the body frame (x = Y, y = -X, z = Z). A matrix
// that is not a rotation, or whose axis points sideways (the model looks straight ahead), is an
// InputError naming the field.
std::optional<Orientation> read_rotation(const nlohmann::json& description, const std::string& file) {
  if (!description.is_object() || !description.contains("camera")) return std::nullopt;
  const nlohmann::json& cam = description.at("camera");
  if (!cam.is_object() || !cam.contains("R_world_from_camera")) return std::nullopt;
  const std::string field = file + ": camera.R_world_from_camera: ";
  const nlohmann::json rows = cam.at("R_world_from_camera");
  if (!rows.is_array() || rows.size() != 3) throw InputError(field + "must be 3 rows of 3 numbers");
  cv::Matx33d m;
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json row = rows.at(static_cast<std::size_t>(i));
    if (!row.is_array() || row.size() != 3) throw InputError(field + "must be 3 rows of 3 numbers");
    for (int k = 0; k < 3; ++k) {
      const nlohmann::json& v = row.at(static_cast<std::size_t>(k));
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw InputError(field + "row " + std::to_string(i) + ", column " + std::to_string(k) +
                         ": must be a finite number");
      m(i, k) = v.get<double>();
    }
  }
  const cv::Matx33d e = m.t() * m - cv::Matx33d::eye();
  double off = 0.0;
  for (const double v : e.val) off = std::max(off, std::abs(v));
  if (off > 1e-3) throw InputError(field + "not a rotation (its columns are not orthonormal)");
  if (cv::determinant(m) < 0) throw InputError(field + "a reflection (determinant -1), not a rotation");
  const cv::Matx33d body = cv::Matx33d(0, 1, 0, -1, 0, 0, 0, 0, 1) * m;
  const double ax = body(0, 2), ay = body(1, 2), az = body(2, 2);  // the optical axis
  const double yaw = std::atan2(ay, ax);
  if (std::hypot(ax, ay) > 1e-6 && std::abs(yaw) > 1.0 * kDeg)
    throw InputError(field + "the optical axis points " + degrees(std::abs(yaw)) + " deg " +
                     (yaw < 0 ? "right" : "left") +
                     " of the scene's forward (+Y) axis: the camera model looks straight ahead (pitch and roll "
                     "only)");
  Orientation o;
  o.pitch_rad = std::atan2(-az, std::hypot(ax, ay));
  // the optical x axis in the body frame is (-sin a sin r, -cos r, -cos a sin r)
  const double sa = std::sin(o.pitch_rad), ca = std::cos(o.pitch_rad);
  o.roll_rad = std::atan2(-(sa * body(0, 0) + ca * body(2, 0)), -body(1, 0));
  return o;
}

}  // namespace

direct_depth::CameraModel read_json_camera(const nlohmann::json& description, const std::string& file) {
  const auto number = [&](const char* field) { return json_number(description, file, field); };
  direct_depth::CameraModel c;
  c.width = json_pixels(description, file, "camera.width");
  c.height = json_pixels(description, file, "camera.height");
  c.fx = number("camera.fx");
  c.fy = number("camera.fy");
  c.cx = number("camera.cx");
  c.cy = number("camera.cy");
  const auto h = json_optional_number(description, file, "camera.h_m");
  const auto mount_h = json_optional_number(description, file, "camera.mount_height_m");
  if (h && mount_h)
    throw InputError(file + ": camera.h_m: the height is given twice (also as camera.mount_height_m): give one");
  if (!h && !mount_h)
    throw InputError(file +
                     ": camera.h_m: missing (the optical centre's height above the ground, m; a drive's "
                     "description calls it camera.mount_height_m)");
  c.mount_height_m = h ? *h : *mount_h;
  // The orientation: pitch_deg (and roll_deg), or the rotation, or both when they agree.
  const std::optional<Orientation> rot = read_rotation(description, file);
  const auto pitch_deg = json_optional_number(description, file, "camera.pitch_deg");
  const auto roll_deg = json_optional_number(description, file, "camera.roll_deg");
  if (!pitch_deg && !rot)
    throw InputError(file +
                     ": camera.pitch_deg: missing (the optical axis' depression below the horizontal, deg; "
                     "or give camera.R_world_from_camera)");
  constexpr double kAgree = 0.5 * kDeg;
  if (rot && pitch_deg && std::abs(*pitch_deg * kDeg - rot->pitch_rad) > kAgree)
    throw InputError(file + ": camera.pitch_deg: " + degrees(*pitch_deg * kDeg) +
                     " deg, but camera.R_world_from_camera tilts the optical axis " + degrees(rot->pitch_rad) +
                     " deg down: the two disagree");
  if (rot && roll_deg && std::abs(*roll_deg * kDeg - rot->roll_rad) > kAgree)
    throw InputError(file + ": camera.roll_deg: " + degrees(*roll_deg * kDeg) +
                     " deg, but camera.R_world_from_camera rolls the camera " + degrees(rot->roll_rad) +
                     " deg about its axis: the two disagree");
  c.pitch_rad = pitch_deg ? *pitch_deg * kDeg : rot->pitch_rad;
  c.roll_rad = roll_deg ? *roll_deg * kDeg : (rot ? rot->roll_rad : 0.0);
  try {
    c.validate();
  } catch (const FieldError& e) {
    throw InputError(file + ": camera: " + e.what());
  }
  return c;
}

}  // namespace regolith::common
