#include "regolith/common/grid.hpp"

#include <cmath>
#include <limits>

#include "regolith/core/error.hpp"

namespace regolith::common {

namespace {
// Cells along a side; saturated at INT_MAX so that an absurd length (1e9 m) is "too many cells"
// for validate(), not an int overflow that came out negative and passed it.
int cells(double length_m, double resolution_m) {
  if (!(resolution_m > 0.0)) return 0;
  const double n = length_m / resolution_m;
  if (!(n < static_cast<double>(std::numeric_limits<int>::max()))) return std::numeric_limits<int>::max();
  return static_cast<int>(std::lround(n));
}
}  // namespace

int GridGeometry::size_x() const {
  return cells(length_x_m, resolution_m);
}

int GridGeometry::size_y() const {
  return cells(length_y_m, resolution_m);
}

cv::Point2d GridGeometry::cell_center(int i, int j) const {
  return {center_x_m + 0.5 * length_x_m - (i + 0.5) * resolution_m,
          center_y_m + 0.5 * length_y_m - (j + 0.5) * resolution_m};
}

bool GridGeometry::cell_of(double x, double y, int& i, int& j) const {
  const double fi = (center_x_m + 0.5 * length_x_m - x) / resolution_m;
  const double fj = (center_y_m + 0.5 * length_y_m - y) / resolution_m;
  if (!(fi >= 0 && fj >= 0 && fi < size_x() && fj < size_y())) return false;
  i = static_cast<int>(fi);
  j = static_cast<int>(fj);
  return true;
}

void GridGeometry::validate() const {
  if (!(resolution_m > 0.0) || !std::isfinite(resolution_m))
    throw FieldError("GridGeometry", "resolution_m", "must be > 0");
  if (!(length_x_m >= resolution_m) || !std::isfinite(length_x_m))
    throw FieldError("GridGeometry", "length_x_m", "must be >= resolution_m");
  if (!(length_y_m >= resolution_m) || !std::isfinite(length_y_m))
    throw FieldError("GridGeometry", "length_y_m", "must be >= resolution_m");
  if (!std::isfinite(center_x_m)) throw FieldError("GridGeometry", "center_x_m", "must be finite");
  if (!std::isfinite(center_y_m)) throw FieldError("GridGeometry", "center_y_m", "must be finite");
  if (size_x() > 4096 || size_y() > 4096)
    throw FieldError("GridGeometry", size_x() > 4096 ? "length_x_m" : "length_y_m", "more than 4096 cells per side");
}

}  // namespace regolith::common
