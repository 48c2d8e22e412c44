#pragma once
// The pinhole camera block of a recorded scene's or drive's description (input.json), read one
// way for every tool that takes one: `regolith map` (a drive), `regolith soil --scene` (a track
// scene) and `regolith assess --scene` (a perspective frame).
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "regolith/direct_depth/direct_depth.hpp"

namespace regolith::common {

/// `camera` of `description` (read from `file`): width, height (px), fx, fy, cx, cy (px), the
/// optical centre's height above the ground as `h_m` (the track and SfS scenes) or
/// `mount_height_m` (the drives), `pitch_deg` (optical axis below the horizontal) and an optional
/// `roll_deg`; no distortion. The scenes' `R_world_from_camera` (camera x right, y down, z optical
/// in a world X right, Y forward, Z up), when given, is read too: its pitch and roll stand in for
/// absent `pitch_deg` / `roll_deg` (a scene whose camera is rolled but says so only in the matrix is
/// modelled rolled) and must agree with them within 0.5 deg when both are there; a matrix that is not
/// a rotation, or that turns the camera more than 1 deg sideways, is an error. InputError
/// "FILE: camera.FIELD: why" for a field missing or unusable (both heights given is one of those),
/// "FILE: camera: why" for a model direct_depth rejects.
direct_depth::CameraModel read_json_camera(const nlohmann::json& description, const std::string& file);

}  // namespace regolith::common
