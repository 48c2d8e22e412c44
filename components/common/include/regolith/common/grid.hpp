#pragma once
// One grid geometry for every metric grid layer (grid_map conventions, REP-103 body frame):
// rows i = cells along x (forward), columns j = cells along y (left); cell (0, 0) is the +x/+y
// corner; cell (i, j) has its centre at
//   x = center_x + length_x / 2 - (i + 0.5) * resolution,
//   y = center_y + length_y / 2 - (j + 0.5) * resolution.
// Used by the traversability grid map, the rock-probability layer and the sinkage layer.
#include <cmath>

#include <opencv2/core.hpp>

namespace regolith::common {

struct GridGeometry {
  double resolution_m = 0.05;  ///< m per cell
  double length_x_m = 4.0;     ///< m, extent along x
  double length_y_m = 4.0;     ///< m, extent along y
  double center_x_m = 0.0;     ///< m, map centre in the body frame
  double center_y_m = 0.0;     ///< m

  /// Rows (cells along x) and columns (cells along y); 0 for a resolution <= 0 (unset grid).
  int size_x() const;
  int size_y() const;
  /// Cell centre in the body frame.
  cv::Point2d cell_center(int i, int j) const;
  /// Cell containing (x, y); false if outside.
  bool cell_of(double x, double y, int& i, int& j) const;
  /// Throws FieldError("GridGeometry", field, ...) for a non-positive resolution, lengths below one
  /// cell, non-finite centres, or more than 4096 cells per side.
  void validate() const;
  /// Same cells (to 1 um: lengths are often derived as cells x resolution).
  bool same_as(const GridGeometry& o) const {
    auto eq = [](double a, double b) { return std::abs(a - b) < 1e-6; };
    return eq(resolution_m, o.resolution_m) && eq(length_x_m, o.length_x_m) && eq(length_y_m, o.length_y_m) &&
           eq(center_x_m, o.center_x_m) && eq(center_y_m, o.center_y_m);
  }
};

}  // namespace regolith::common
