#pragma once
// Heights from cast shadows (the cue orbital boulder counts use): with the sun known, an object
// of height h throws a shadow of length h / tan(elevation) along the sun's azimuth on the ground.
// In a ground-rectified frame (metres, top-down) that length is measured directly: from each
// shadow cell, walk towards the sun to the first lit cell (the caster's foot); the longest such
// walk over a caster's shadow is its shadow length. Strongest exactly where shading is weakest:
// a low sun. Each caster cell gets h = length x tan(elevation).
//
// Shadow = a seen cell darker than `dark_fraction` x the median brightness of the seen cells.
// Walks that leave the seen area before reaching light are dropped (unknown, not short). A sun
// below `min_elevation_rad` or above `max_elevation_rad` (no usable shadows) gives nothing.
// Buffers are allocated in the constructor; compute() does not allocate.
#include <opencv2/core.hpp>

#include "regolith/direct_depth/ground_rectifier.hpp"

namespace regolith::mapping {

struct ShadowParams {
  double dark_fraction = 0.35;      ///< shadow = darker than this x the median seen brightness
  double min_length_m = 0.04;       ///< m, shorter shadows are ignored (noise, small stones)
  double max_height_m = 0.6;        ///< m, longer walks are clipped to this height
  double min_elevation_rad = 0.05;  ///< rad, sun lower than this: no cue (shadows everywhere)
  double max_elevation_rad = 1.3;   ///< rad, sun higher than this: shadows too short to measure
  void validate() const;            ///< FieldError("mapping.shadow", ...)
};

class ShadowCue {
 public:
  ShadowCue(const direct_depth::RectifiedGrid& grid, const ShadowParams& params);

  /// img: CV_32F rectified grey frame on `grid`; valid: CV_8U (non-zero = seen); sun_body: vector
  /// towards the sun in the grid's frame (x forward, y left, z up). Returns the number of
  /// caster cells found.
  int compute(const cv::Mat& img, const cv::Mat& valid, const cv::Vec3d& sun_body);

  /// Per cell: height of the object whose foot is here (m, NaN elsewhere), its flat-ground
  /// position (m, grid frame), and the shadow mask of the last frame (CV_8U 255 = shadow).
  const cv::Mat& height() const { return h_; }
  const cv::Mat& x() const { return x_; }
  const cv::Mat& y() const { return y_; }
  const cv::Mat& shadow() const { return shadow_; }
  /// Weight of each caster cell (1 where a height was measured): for WorldMap::fuse_points.
  const cv::Mat& weight() const { return w_; }

 private:
  direct_depth::RectifiedGrid grid_;
  ShadowParams p_;
  cv::Mat shadow_, h_, x_, y_, w_;
};

}  // namespace regolith::mapping
