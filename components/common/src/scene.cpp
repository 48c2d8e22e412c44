#include "regolith/common/scene.hpp"

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "regolith/common/camera.hpp"
#include "regolith/common/json_camera.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/json_file.hpp"
#include "regolith/core/rover.hpp"

namespace regolith::common {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// The orthographic patch: pixel size, image-frame sun, flat field.
void read_orthographic(const nlohmann::json& j, const std::string& file, SceneDescription& d) {
  d.pixel_size_m = json_number(j, file, "gsd_m");
  if (!(d.pixel_size_m > 0.0))
    throw InputError(file + ": gsd_m: must be > 0 m (got " + number_text(d.pixel_size_m) + ")");
  d.light =
      sfs::LightDirection{json_number(j, file, "sun_slant_deg") * kDeg, json_number(j, file, "sun_tilt_deg") * kDeg};
  try {
    d.light.validate("sun");
  } catch (const std::invalid_argument& e) {
    throw InputError(file + ": sun_slant_deg: " + e.what() + " (an orthographic patch needs the sun above it)");
  }
  const auto ff = j.find("flat_field");
  if (ff == j.end() || ff->is_null()) return;
  if (!ff->is_string() || ff->get<std::string>().empty())
    throw InputError(file + ": flat_field: must be null or the name of a flat-field image");
  const std::filesystem::path rel(ff->get<std::string>());
  d.flat_field = (rel.is_absolute() ? rel : std::filesystem::path(file).parent_path() / rel).string();
}

// The perspective camera (a level rover's) and the world sun in its image frame.
void read_perspective(const nlohmann::json& j, const std::string& file, SceneDescription& d) {
  d.camera = read_json_camera(j, file);
  const auto number = [&](const char* field) { return json_number(j, file, field); };
  // The sun goes into the image frame through the camera's mount, as --rover's does.
  RoverCamera rc;
  rc.mount.z_m = d.camera->mount_height_m;
  rc.mount.pitch_rad = d.camera->pitch_rad;
  rc.mount.roll_rad = d.camera->roll_rad;
  const double el = number("sun_elevation_deg");
  if (!(el >= -90.0 && el <= 90.0))
    throw InputError(file + ": sun_elevation_deg: must be in -90..90 deg (got " + number_text(el) + ")");
  const Sun sun{.azimuth_rad = number("sun_azimuth_deg") * kDeg, .elevation_rad = el * kDeg};
  const CameraLight cl = camera_light(sun, rc);
  d.light = cl.light;
  d.sun_in_view = cl.in_view;
}

}  // namespace

SceneDescription read_scene_description(const std::string& file, int width, int height) {
  const nlohmann::json j = read_json_file(file, "scene description (input.json)");
  const auto size_check = [&](const char* w_key, const char* h_key) {
    const int w = json_pixels(j, file, w_key), h = json_pixels(j, file, h_key);
    if (w != width || h != height)
      throw InputError(file + ": " + w_key + " x " + h_key + " is " + std::to_string(w) + "x" + std::to_string(h) +
                       " px, but the image is " + std::to_string(width) + "x" + std::to_string(height) +
                       ": not this image's scene");
  };
  const auto p = j.is_object() ? j.find("projection") : j.end();
  const std::string projection = p != j.end() && p->is_string() ? p->get<std::string>() : std::string();
  SceneDescription d;
  if (projection == "orthographic") {
    if (j.contains("width") || j.contains("height")) size_check("width", "height");
    read_orthographic(j, file, d);
  } else if (projection == "perspective") {
    size_check("camera.width", "camera.height");
    read_perspective(j, file, d);
  } else if (projection.empty() && j.is_object() && j.contains("frames_csv")) {
    // A recorded drive's description (../shared/data/synthetic_dev/traverse/): its sun is in the
    // world frame and each frame has its own heading, so it does not describe one image.
    throw InputError(file + ": a recorded drive's description (frames_csv), not one image's scene: `regolith map " +
                     "DIR` maps the drive; for one of its frames give --camera fx,fy,cx,cy --height --pitch and " +
                     "--sun-slant / --sun-tilt");
  } else {
    throw InputError(file + ": projection: must be \"orthographic\" or \"perspective\"" +
                     (projection.empty() ? std::string(" (missing)") : " (got \"" + projection + "\")"));
  }
  return d;
}

}  // namespace regolith::common
