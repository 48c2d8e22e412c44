#pragma once
// Ground rectification: resampling a camera frame onto the flat-ground plane (a top-down image).
//
// The rectified grid is aligned like the metric grids (regolith/common/grid.hpp): rows along -x
// (forward), columns along -y (left), cell (i, j) centred at the flat-ground point
//   x = x_far - (i + 0.5) * resolution,  y = y_left - (j + 0.5) * resolution
// in the direct-depth body frame (origin on the ground below the camera). A table of source pixels
// and bilinear weights is built once in the constructor; resampling a frame is a table walk with
// no heap allocation. Used by ground-rectified SfS (traversability) and ground visual odometry
// (mapping): Lambertian brightness does not depend on the viewer, so a rectified frame looks the
// same from every rover pose (up to what stands above the ground).
#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"

namespace regolith::direct_depth {

struct RectifiedGrid {
  double x_far_m = 0.0;       ///< m, +x edge of the grid (forward)
  double y_left_m = 0.0;      ///< m, +y edge of the grid (left)
  double resolution_m = 0.0;  ///< m per cell
  int rows = 0;               ///< cells along -x
  int cols = 0;               ///< cells along -y
  double max_range_m = 1e9;   ///< m, cells farther than this from the camera foot are not seen
  /// Throws FieldError("direct_depth", ...) naming the bad field.
  void validate() const;
  /// Flat-ground centre of cell (i, j).
  cv::Point2d center(int i, int j) const {
    return {x_far_m - (i + 0.5) * resolution_m, y_left_m - (j + 0.5) * resolution_m};
  }
  /// Fractional cell coordinates (row, column) of a flat-ground point (centres at integers).
  cv::Point2d cell(double x, double y) const {
    return {(x_far_m - x) / resolution_m - 0.5, (y_left_m - y) / resolution_m - 0.5};
  }
};

class GroundRectifier {
 public:
  /// Builds the resampling table (the only allocation). `depth` is only read here.
  GroundRectifier(const DirectDepth& depth, const RectifiedGrid& grid);

  const RectifiedGrid& grid() const { return grid_; }
  /// CV_8U, 255 = the camera sees this cell (below the horizon, inside the image and max range).
  const cv::Mat& valid() const { return valid_; }
  /// CV_32F, image pixels per cell (area ratio, clamped to 1): how much the camera resolves a cell.
  const cv::Mat& support() const { return support_; }
  /// CV_32F flat-ground coordinates of each cell centre (body x forward, y left).
  const cv::Mat& x_map() const { return x_; }
  const cv::Mat& y_map() const { return y_; }
  /// Number of seen cells.
  int visible() const { return visible_; }

  /// Bilinear resampling of an 8-bit grey frame (the camera's size, else FieldError naming
  /// `what`). `out` is (re)created as rows x cols of CV_8U or CV_32F (its current type if it is
  /// one of those, else CV_32F); cells the camera does not see get `outside`.
  void resample(const cv::Mat& gray, cv::Mat& out, double outside = 0.0, const char* what = "gray") const;

 private:
  RectifiedGrid grid_;
  cv::Size image_size_;
  cv::Mat src_;   // CV_32SC4 (r0, c0, r1, c1)
  cv::Mat frac_;  // CV_32FC2 (fraction along columns, along rows)
  cv::Mat valid_, support_, x_, y_;
  int visible_ = 0;
};

}  // namespace regolith::direct_depth
