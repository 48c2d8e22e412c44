#pragma once
// A camera's tilt against the ground beyond its mount, as GroundVisualOdometry estimates it:
// pitch about the body y axis (left; positive = nose further down) and roll about the body x
// axis (forward). The physical ray of a pixel is tilt_rotation(pitch, roll) x its nominal ray
// (body frame: x forward, y left, z up). Header-only, no allocation.
#include <cmath>

#include <opencv2/core.hpp>

namespace regolith::mapping {

inline cv::Matx33d tilt_rotation(double pitch_rad, double roll_rad) {
  const double cp = std::cos(pitch_rad), sp = std::sin(pitch_rad), cr = std::cos(roll_rad), sr = std::sin(roll_rad);
  const cv::Matx33d rx(1, 0, 0, 0, cr, -sr, 0, sr, cr);
  const cv::Matx33d ry(cp, 0, sp, 0, 1, 0, -sp, 0, cp);
  return rx * ry;
}

}  // namespace regolith::mapping
