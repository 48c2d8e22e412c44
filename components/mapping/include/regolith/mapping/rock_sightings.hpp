#pragma once
// Rocks sighted in one camera frame and ranged on the ground (the thesis' "ranged rock boxes",
// made to work from a moving rover): far rocks are a few pixels of parallax but many pixels of
// image, so where motion parallax is too weak the image itself says where a rock stands.
//
//  1. Contrast against the local ground: d = I - B (B = the frame blurred over
//     `background_sigma_px`, three box passes), |d| smoothed over `smooth_sigma_px`. Ground
//     texture gives a small |d|; a rock's lit and shaded faces and its shadow a large one.
//  2. Blobs: 8-connected pixels with smoothed |d| above `threshold` x the median over the seen
//     ground, with at least `min_pixels`, not touching the image border.
//  3. Ranging (direct depth with the camera's tilt against the ground): the blob's lowest row is
//     its contact with the ground -> ground point g; width = the ground distance between its
//     leftmost and rightmost columns at that range; centre = g pushed back by half the width
//     (round footprint); height = where the ray through the blob's top meets the vertical
//     through the centre. Blobs ranged outside [min_range, max_range] or shorter than
//     `min_height_m` are dropped.
// Output: up to `max_sightings` per frame (x, y in the camera foot frame, height, width, score
// = mean smoothed contrast over the threshold), as 1 x max_sightings CV_32F rows, NaN after
// count(), the layout WorldMap::fuse_casters takes. Everything is allocated in the constructor.
#include <opencv2/core.hpp>

#include <vector>

#include "regolith/direct_depth/direct_depth.hpp"

namespace regolith::mapping {

struct RockSightingParams {
  double background_sigma_px = 16.0; ///< px, scale of the local ground brightness
  double smooth_sigma_px = 0.0;      ///< px, smoothing of |I - background| (0: none; smoothing moves the contact row)
  double threshold = 3.0;            ///< x the median smoothed contrast of the seen ground
  int min_pixels = 12;               ///< px, smaller blobs are texture
  int max_pixels = 4000;             ///< px, larger blobs are near rocks (parallax sees them) or lighting
  double min_range_m = 1.0;          ///< m, ground range of a blob's contact point, from ...
  double max_range_m = 5.0;          ///< m, ... to
  double min_height_m = 0.05;        ///< m, lower objects are not reported
  double max_height_m = 0.6;         ///< m, taller ones are not rocks (a far wall, a crater's far rim)
  int max_sightings = 64;            ///< per frame
  void validate() const;             ///< FieldError("mapping.sightings", ...)
};

class RockSightings {
 public:
  /// `depth` must outlive this object.
  RockSightings(const direct_depth::DirectDepth& depth, const RockSightingParams& params);

  /// One 8-bit grey frame (camera size, else FieldError naming "gray"); tilt = the camera's
  /// (pitch, roll) against the ground beyond the mount (rad). Returns the number of sightings.
  int compute(const cv::Mat& gray, const cv::Vec2d& tilt = {});

  int count() const { return count_; }
  const cv::Mat& x() const { return x_; }
  const cv::Mat& y() const { return y_; }
  const cv::Mat& height() const { return h_; }
  const cv::Mat& width() const { return w_; }
  const cv::Mat& score() const { return s_; }
  /// The last frame's blob mask (CV_8U, 255 = above the threshold), for overlays.
  const cv::Mat& mask() const { return mask_; }

 private:
  void blur(cv::Mat& m, double sigma);
  cv::Vec3d ray(double col, double row) const;
  RockSightingParams p_;
  const direct_depth::DirectDepth& depth_;
  cv::Matx33d rot_;  // body from optical, with the tilt of the current frame
  cv::Mat img_, bg_, tmp_, tmp2_, mask_, label_;
  std::vector<float> values_;
  std::vector<int> stack_;
  int count_ = 0;
  cv::Mat x_, y_, h_, w_, s_;
};

}  // namespace regolith::mapping
