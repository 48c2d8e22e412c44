#include "regolith/common/json_camera.hpp"

#include <nlohmann/json.hpp>

#include "regolith/core/error.hpp"
#include "regolith/core/json_file.hpp"

namespace regolith::common {

direct_depth::CameraModel read_json_camera(const nlohmann::json& description, const std::string& file) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
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
  c.pitch_rad = number("camera.pitch_deg") * kDeg;
  c.roll_rad = json_optional_number(description, file, "camera.roll_deg").value_or(0.0) * kDeg;
  try {
    c.validate();
  } catch (const FieldError& e) {
    throw InputError(file + ": camera: " + e.what());
  }
  return c;
}

}  // namespace regolith::common
