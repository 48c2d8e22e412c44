#pragma once
// Component wrapper "sams": the shared DTM of the "sfs" component (channel "terrain/dtm": grey
// image + SfS height of one camera frame, computed once per frame) -> saliency (SAMS, Itti or an
// OpenCV peer) -> boxes (BoxDetector) -> every box ranged with direct depth -> published on
//   * channel "terrain/rocks"            (RockFrame, below),
//   * channel "terrain/rock_probability" (RockProbabilityFrame: a grid layer in the
//     traversability grid's geometry and index convention, to be merged into the GridMap),
//   * DDS topic terrain/rocks            (regolith_msgs/RockArray) when DDS is enabled.
// Parameters, I/O and numbers: components/saliency/README.md ("Component").
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>

#include "regolith/core/time.hpp"
#include "regolith/saliency/ranging.hpp"

namespace regolith::saliency {

/// Channel (and DDS topic) name of the ranged rocks.
inline constexpr const char* kRocksChannel = "terrain/rocks";
/// Channel of the rock-probability grid layer.
inline constexpr const char* kRockProbabilityChannel = "terrain/rock_probability";
/// Name of the grid-map layer the probability is meant to fill.
inline constexpr const char* kRockProbabilityLayer = "rock_probability";
/// Most rocks one frame can carry (the `max_detections` parameter is capped at this).
inline constexpr std::uint32_t kMaxRocks = 64;

/// The rocks of one camera frame (fixed capacity: copied without allocation).
struct RockFrame {
  std::array<RangedRock, kMaxRocks> rocks{};  ///< [0, count): sorted by descending score
  std::uint32_t count = 0;
  std::uint32_t hazards = 0;    ///< rocks with hazard == true
  int image_width = 0;          ///< px, size of the image the boxes refer to
  int image_height = 0;         ///< px
  TimeNs stamp = 0;             ///< capture time of the source camera frame (ns, process clock)
  std::uint64_t sequence = 0;   ///< camera frame sequence number (DtmFrame::sequence)
};

/// Per-cell rock probability in the traversability grid's geometry (grid_map conventions, see
/// regolith/traversability/traversability.hpp): rows = cells along x (forward), cols = cells along
/// y (left), cell (0, 0) is the +x/+y corner, cell (i, j) centre
///   x = center_x + length_x / 2 - (i + 0.5) * resolution,
///   y = center_y + length_y / 2 - (j + 0.5) * resolution.
/// Value: the saliency map (in [0, 1], max 1 per frame) at the pixel that sees the cell centre on
/// flat ground; NaN where the camera does not see the cell. An uncalibrated score, not a
/// probability estimated from data (see README).
struct RockProbabilityFrame {
  double resolution_m = 0.0;                  ///< m per cell
  double length_x_m = 0.0, length_y_m = 0.0;  ///< m
  double center_x_m = 0.0, center_y_m = 0.0;  ///< m, map centre in the body frame
  cv::Mat probability;  ///< CV_32F, size_x rows x size_y cols, allocated once
  TimeNs stamp = 0;     ///< capture time of the source camera frame (ns)
  std::uint64_t sequence = 0;
};

/// Registers component type "sams".
void register_component();

}  // namespace regolith::saliency
