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

//
// With `overlay` (a .png path) it also draws what was scored, north up over the true terrain
// (hillshade of height.tiff on the map's cells; what no true camera pose saw within 5 m dimmed):
// each rock >= 10 cm that was seen as an ellipse of its true footprint, yellow when a detection
// matched it and red when missed (seen but unmatched; unseen ones thin grey); each detection
// of rocks.csv as a cross, yellow with a line to the rock it matched, magenta for a false alarm,
// grey when it matched a smaller or unseen rock (neither); the true path (white), the corrected
// path (green) and the wheel path (blue); the scores in the title.
/// Throws InputError naming the file when truth or map files are missing or malformed, and
/// std::runtime_error naming the overlay when it cannot be written.
nlohmann::json evaluate_map(const std::filesystem::path& drive_dir, const std::filesystem::path& map_dir,
                            const std::filesystem::path& overlay = {});

}  // namespace regolith::mapping
