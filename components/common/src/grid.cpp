#include "regolith/common/grid.hpp"

#include <cmath>

#include "regolith/core/error.hpp"

namespace regolith::common {

int GridGeometry::size_x() const {
  return resolution_m > 0.0 ? static_cast<int>(std::lround(length_x_m / resolution_m)) : 0;
}

int GridGeometry::size_y() const {
  return resolution_m > 0.0 ? static_cast<int>(std::lround(length_y_m / resolution_m)) : 0;
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
