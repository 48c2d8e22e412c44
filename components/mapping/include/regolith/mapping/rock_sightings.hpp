#pragma once
// Rocks sighted in one camera frame and ranged on the ground (the thesis' "ranged rock boxes",
// made to work from a moving rover): far rocks are a few pixels of parallax but many pixels of
// image, so where motion parallax is too weak the image itself says where a rock stands.
//
//  0. A camera wider than `max_width_px` is measured in a working frame: its frame halved (means of
//     2x2 pixels) until it is at most that wide, with a DirectDepth of its own; the boxes and the
//     object mask are given back in camera pixels.
//  1. Contrast against the local ground: d = I - B (B = the frame blurred over
//     `background_sigma_px`, three box passes; then again leaving out the pixels the first pass
//     found, so a bright rock does not lift the ground around it), |d| smoothed over
//     `smooth_sigma_px`. Ground texture gives a small |d|; a rock's lit and shaded faces and its
//     shadow a large one.
//  2. Blobs: 8-connected pixels with smoothed |d| above `threshold` x the median over the seen
//     ground (per row, averaged over the rows within `row_band_px`: texture contrast grows towards the horizon), with
//     at least `min_pixels`, not touching the image's sides or bottom. A blob cut by the top edge
//     is kept (`keep_top_cut`): a pitched camera first sees far rocks there, with their ground
//     contact in view and their top cut off, so its height is a lower bound.
//  3. Ranging (direct depth with the camera's tilt against the ground): the blob's lowest row is
//     its contact with the ground -> ground point g; width = the ground distance between its
//     leftmost and rightmost columns at that range; centre = g pushed back by half the width
//     (round footprint); height = where the ray through the blob's top meets the vertical
//     through the centre. Blobs ranged outside [min_range, max_range] or shorter than
//     `min_height_m` are dropped.
// Output: up to `max_sightings` per frame, one column each of a CV_32F table (rows below; NaN
// after count()), the layout WorldMap::fuse_sightings takes: centre x, y in the camera foot frame,
// height, width, score (mean contrast over the threshold - 1, 0.05..1), the centre's standard
// deviation along the viewing ray and across it (a row of error plus a tilt error of
// `tilt_sigma_rad` move a far contact by (h^2 + Y^2) / h x the angle), the blob's image box
// (for overlays and single-image reports), the contact's ground point and the top ray's slope
// (for RockTracker, which triangulates the contact across frames). Everything is allocated in the constructor.
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"

namespace regolith::mapping {

struct RockSightingParams {
  double background_sigma_px = 16.0;  ///< px, scale of the local ground brightness
  double smooth_sigma_px = 0.0;       ///< px, smoothing of |I - background| (0: none; smoothing moves the contact row)
  double threshold = 3.0;             ///< x the median smoothed contrast of the seen ground in the same rows
  int row_band_px = 8;                ///< px, rows within this of a row share its threshold
  int min_pixels = 12;                ///< px, smaller blobs are texture
  int max_pixels = 4000;              ///< px, larger blobs are near rocks (parallax sees them) or lighting
  double min_range_m = 1.0;           ///< m, ground range of a blob's contact point, from ...
  double max_range_m = 5.0;           ///< m, ... to
  double min_height_m = 0.07;         ///< m, lower sightings are not reported (most are ground texture)
  double max_height_m = 0.6;          ///< m, taller ones are not rocks (a far wall, a crater's far rim)
  int max_sightings = 64;             ///< per frame
  double footprint_per_height = 1.0;  ///< footprint radius at least this x the height (the blob misses a dome's flanks)
  bool merge_halves = false;          ///< side-by-side blobs (a side-lit rock's bright and dark halves) are one rock
  int merge_gap_px = 2;               ///< px, column gap two halves may leave between them
  bool keep_top_cut = true;           ///< blobs cut by the image's top edge are kept (their height is a lower bound)
  double tilt_sigma_rad = 0.01;       ///< rad, error of the camera's tilt against the far ground (ranging)
  /// With the sun known (compute's `sun`): where it leaves a rock's far flank darker than the ground,
  /// the blob reaches the rock's silhouette, whose top ray grazes that flank beyond the apex; the
  /// height is then that of a half-ellipsoid of the footprint radius a the ray is tangent to,
  /// sqrt(h_ray^2 - (a tan alpha)^2) (alpha: the ray's depression), at least `silhouette_floor` x
  /// h_ray cos alpha (a dome's value; a footprint measured too wide would take it to 0).
  bool silhouette_height = true;
  double silhouette_floor = 0.75;
  /// px, frames wider than this are measured at a half, a quarter, ... of their size (means of 2x2
  /// pixels) so that they are at most this wide (0: always at full size). The blobs are then
  /// those of a frame of about the reference width whatever the camera, at a quarter of the work
  /// per halving; the pixel parameters above are in pixels of that working frame.
  int max_width_px = 480;
  void validate() const;  ///< FieldError("mapping.sightings", ...)

  /// The factor a frame `width_px` wide is reduced by before it is measured: 1 (full size), 2, 4, ...
  int reduction(int width_px) const;

  /// The image widths the pixel parameters above are given for: 320 px.
  static constexpr int kReferenceWidthPx = 320;
  /// The same parameters for a camera `width_px` wide, i.e. for its working frame (`max_width_px`)
  /// w = width_px / reduction(width_px) px wide: lengths (background and smoothing scales, row
  /// band) grow by s = w / kReferenceWidthPx, areas (min / max pixels) by s^2, the merge gap by
  /// max(1, s); clamped to what validate() accepts. A rock then makes the same blob whatever the
  /// camera's resolution (a 640 px camera with the 320 px scales takes its texture for rocks).
  RockSightingParams scaled_to_width(int width_px) const;
};

/// Rows of RockSightings::table().
enum SightingRow {
  kSightX,
  kSightY,
  kSightHeight,
  kSightWidth,
  kSightScore,
  kSightSigmaRange,
  kSightSigmaLateral,
  kSightCol0,  ///< the blob's image box: first column, first row, last column, last row (px of the
  kSightRow0,  ///< camera frame, inclusive; first row 0 = cut by the top edge: the height is then a lower bound)
  kSightCol1,
  kSightRow1,
  kSightContactX,  ///< the contact's ground point (camera foot frame, on the ground plane): the ray
  kSightContactY,  ///< through it is what RockTracker triangulates across frames
  kSightTopSlope,  ///< tan of the top ray's angle above the horizontal (negative below it)
  kSightRows
};

class RockSightings {
 public:
  /// `depth` (the camera's) must outlive this object. A camera wider than `max_width_px` gets a
  /// working frame and its own DirectDepth for it, made here.
  RockSightings(const direct_depth::DirectDepth& depth, const RockSightingParams& params);

  /// One 8-bit grey frame (camera size, else FieldError naming "gray"); tilt = the camera's
  /// (pitch, roll) against the ground beyond the mount (rad); sun = the direction towards the sun
  /// in the camera's ground frame (x forward, y left, z up; any length; zero = unknown: heights
  /// from the top ray alone). Returns the number of sightings.
  int compute(const cv::Mat& gray, const cv::Vec2d& tilt = {}, const cv::Vec3d& sun = {});

  int count() const { return count_; }
  const cv::Mat& table() const { return table_; }
  const cv::Mat& x() const { return x_; }
  const cv::Mat& y() const { return y_; }
  const cv::Mat& height() const { return h_; }
  const cv::Mat& width() const { return w_; }
  const cv::Mat& score() const { return s_; }
  /// Row `row` (SightingRow) of the table: one value per sighting, NaN after count().
  cv::Mat row(SightingRow r) const { return table_.row(r); }
  /// The last frame's blob mask (CV_8U, 255 = above the threshold) in the working frame
  /// (reduction() times smaller than the camera's), for overlays.
  const cv::Mat& mask() const { return mask_; }
  /// The factor between the camera frame and the working frame (1: measured at full size).
  int reduction() const { return f_; }
  /// What stands on the ground in the last frame, for GroundVisualOdometry::exclude: the blob
  /// mask plus each sighting's image box grown by `margin_px` (a rock's inside can match the
  /// ground's brightness; its far side and top are seen over the ground behind it). `out` must be CV_8U of the camera's
  /// size (else FieldError naming "objects"); no allocation.
  void object_mask(cv::Mat& out, int margin_px) const;

 private:
  void blur(cv::Mat& m, double sigma);
  /// Ranges the blob (contact column cb on its lowest row rmax, top row rmin, side columns) into
  /// table column k; false (column untouched) when it is out of range or height.
  bool measure(int k, double cb, int rmin, int rmax, int cmin, int cmax, double score);
  void merge_halves();
  /// `gray` halved until it is the working frame (itself when f_ = 1).
  const cv::Mat& reduce(const cv::Mat& gray);
  cv::Vec3d ray(double col, double row) const;
  /// The rock's height from its top ray's height h_ray over the centre (seen along the horizontal
  /// unit `view`, depression tan_alpha), footprint radius `radius`: see silhouette_height.
  double silhouette(double h_ray, double tan_alpha, const cv::Vec2d& view, double radius) const;
  cv::Vec3d sun_;  // of the current frame (zero: unknown)
  RockSightingParams p_;
  const direct_depth::DirectDepth& camera_;          // the camera's (object_mask's size)
  int f_ = 1;                                        // camera frame / working frame
  std::unique_ptr<direct_depth::DirectDepth> work_;  // the working frame's when f_ > 1
  const direct_depth::DirectDepth& depth_;           // the working frame's: *work_ or camera_
  std::vector<cv::Mat> halves_;                      // the camera frame halved once, twice, ...
  cv::Matx33d rot_;                                  // body from optical, with the tilt of the current frame
  void contrast_and_thresholds();
  cv::Mat gray_f_, img_, bg_, wimg_, wsum_, tmp_, tmp2_, mask_, label_, row_thr_, row_med_, acc_;
  std::vector<float> values_;
  std::vector<std::uint16_t> levels_;
  std::vector<int> stack_;
  int count_ = 0;
  cv::Mat table_;
  cv::Mat x_, y_, h_, w_, s_, sr_, sl_;  // row views of table_
};

}  // namespace regolith::mapping
