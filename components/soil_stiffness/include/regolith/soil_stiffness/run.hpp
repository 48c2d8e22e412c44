#pragma once
// One-call analysis for the CLI (`regolith soil IMAGE --config ROVER.yaml --out DIR`): estimate,
// then write the track DTM, the sinkage profiles and the p-z curves as PNG plots plus a JSON result.
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "regolith/soil_stiffness/track_analysis.hpp"

namespace regolith::soil {

struct SoilAnalysisFiles {
  SoilEstimate estimate;
  std::filesystem::path json;          ///< result.json (always written)
  std::filesystem::path dtm_png;       ///< track_dtm.png (empty path when no DTM was computed)
  std::filesystem::path profiles_png;  ///< sinkage_profiles.png
  std::filesystem::path pz_png;        ///< pz_curves.png (estimate + mission table)
  std::filesystem::path overlay_png;   ///< tracks_overlay.png: the image with ruts, shadows, cross-sections (when ok)
};

/// The frame `regolith soil` analyses, read as 8-bit grey (16-bit samples scaled by the bits they
/// use: regolith::read_image_8bit). Throws InputError naming the file when it is missing or cannot
/// be decoded (truncated, not an image, too large).
cv::Mat read_soil_frame(const std::filesystem::path& image_path);

/// The camera image with each measured rut drawn (floor edges at the floor's depth, wall tops),
/// the shadowed ground tinted blue and labelled cross-sections every ~0.25 m (CV_8UC3).
cv::Mat render_track_overlay(const cv::Mat& image, const CameraModel& camera, const RoverConfig& rover,
                             const TrackAnalysisParams& params, const SoilEstimate& e);

/// JSON text of an estimate (k, n, uncertainties, class, per-track profiles, rover).
std::string estimate_to_json(const SoilEstimate& e, const RoverConfig& rover, int indent = 2);

/// Runs SoilStiffnessEstimator on `image` and writes the files into `out_dir` (created if
/// missing). Throws std::invalid_argument for bad configuration/image and std::runtime_error when
/// a file cannot be written; a frame without usable tracks gives estimate.ok == false and a
/// result.json saying why.
SoilAnalysisFiles run_soil_analysis(const cv::Mat& image, const CameraModel& camera, const RoverConfig& rover,
                                    const TrackAnalysisParams& params, const SunDirection& sun,
                                    const std::filesystem::path& out_dir);

}  // namespace regolith::soil
