#pragma once
// What the estimator needs to know about one scene (camera, rover, analysis, sun), and the
// reader of a recorded scene's `input.json` for `regolith soil IMAGE --scene input.json`.
// Framework-free (JSON, no YAML): the YAML path for deployments is config.hpp.
#include <filesystem>

#include "regolith/soil_stiffness/rigid_wheel.hpp"
#include "regolith/soil_stiffness/run.hpp"
#include "regolith/soil_stiffness/track_analysis.hpp"

namespace regolith::soil {

struct SoilSetup {
  CameraModel camera;  ///< rear camera (regolith::direct_depth model)
  RoverConfig rover;
  TrackAnalysisParams analysis;
  SunDirection sun;  ///< in the camera's ground frame
};

/// A recorded scene's `input.json` (the development set's tracks format: camera {width, height,
/// fx, fy, cx, cy, h_m, pitch_deg}, sun_azimuth_deg (world, from +Y towards +X) and
/// sun_elevation_deg, wheel_width_b_m, wheel_diameter_D_m, tracks [{load_N, x_nominal_m}]; world
/// X right, Y along the tracks away from the camera) in the estimator's terms: the configured
/// ruts at lateral -x_nominal_m with their loads, the region of interest from what the camera
/// sees. InputError naming the file and the field for anything missing or invalid.
SoilSetup read_soil_scene(const std::filesystem::path& input_json);

/// `regolith soil IMAGE --scene input.json --out DIR`: runs run_soil_analysis with the scene's
/// description. result.json carries the estimator's keys and the scene's: k, n (the joint fit
/// when it holds, else k with n fixed; null without an estimate), k_source, and tracks
/// [{x_m, load_N, y_m: [...], sinkage_m: [...]}] in the scene's world frame (the estimator's
/// per-track block moves to track_details).
SoilAnalysisFiles run_soil_scene(const std::filesystem::path& image, const std::filesystem::path& input_json,
                                 const std::filesystem::path& out_dir);

}  // namespace regolith::soil
