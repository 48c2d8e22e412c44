#pragma once
// Ranging of detected rocks on a flat ground plane. Decoupled from the
// direct-depth library: the caller supplies a GroundRanger (e.g. an adapter
// around regolith::direct_depth) that maps a pixel to a point on the ground in
// the rover frame (REP-103: x forward, y left).
#include <functional>
#include <optional>

#include <opencv2/core.hpp>

#include "regolith/saliency/detect.hpp"

namespace regolith::saliency {

/// Ground point of a pixel in the rover frame.
struct GroundPoint {
  double forward_m = 0.0;  ///< m, x (range along the ground)
  double left_m = 0.0;     ///< m, y (lateral offset, positive to the left)
};

/// Maps pixel (u = column, v = row, px, continuous coordinates, pixel centres
/// at +0.5) to the ground; std::nullopt when the ray does not hit the ground
/// (above the horizon).
using GroundRanger = std::function<std::optional<GroundPoint>(double u_px, double v_px)>;

struct RangingParams {
  double hazard_size_m = 0.15;  ///< m, a rock whose width or height exceeds this is a hazard
  void validate() const;        ///< throws std::invalid_argument naming the field
};

struct RangedRock {
  Detection detection;
  bool ranged = false;     ///< false: the box's base is above the horizon (no ground range)
  double range_m = 0.0;    ///< m, ground range (forward) of the bottom-centre of the box
  double lateral_m = 0.0;  ///< m, lateral offset of the bottom-centre (positive left)
  double width_m = 0.0;    ///< m, ground distance between the bottom corners of the box
  double height_m = 0.0;   ///< m, box height scaled by the metres-per-pixel of its base row
  bool hazard = false;     ///< width_m or height_m > hazard_size_m
};

/// The base of a rock touches the ground: its bottom edge (row ymax) is ranged.
/// Width is the ground distance between the bottom-left and bottom-right
/// corners; height assumes the rock's face is at the range of its base and uses
/// the same metres-per-pixel as the width (height_m = box.height * width_m /
/// box.width). Throws std::invalid_argument if `ranger` is empty.
RangedRock range_rock(const Detection& d, const GroundRanger& ranger, const RangingParams& p = {});

}  // namespace regolith::saliency
