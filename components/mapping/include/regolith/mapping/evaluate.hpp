#pragma once
// Scores a `regolith map` output against a drive's exact truth (the development set's
// truth_poses.csv, height.tiff + grid.json, truth.json), with the metrics of its README:
//   poses: final position error (m, % of the true path) and heading error (deg), corrected and
//          wheel-only; mean over frames as well;
//   map:   coverage of the ground seen within 5 m (flat-ground visibility from the true camera
//          poses, no occlusion test), elevation Pearson r after removing a best-fit plane from
//          both, and "detail" r after a 0.2 m Gaussian high-pass;
//   rocks: observed rocks >= 10 cm, matched one-to-one (greedy by distance) when a detection's
//          centre lies within max(0.6 x the larger footprint extent, 0.10 m): recall, precision,
//          F1, median height error %; detections that match a smaller or unobserved rock are
//          neither hits nor false alarms;
//   hazard: ROC AUC over seen cells, positive = cell centre inside the footprint of a rock >= 10 cm,
//          negative = outside every rock >= 5 cm (footprints: ellipses from truth.json).
#include <filesystem>

#include <nlohmann/json.hpp>

namespace regolith::mapping {

/// Throws InputError naming the file when truth or map files are missing or malformed.
nlohmann::json evaluate_map(const std::filesystem::path& drive_dir, const std::filesystem::path& map_dir);

}  // namespace regolith::mapping
