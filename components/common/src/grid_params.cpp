#include "regolith/common/grid_params.hpp"

#include <string>

namespace regolith::common {
namespace {
constexpr std::string_view kKeys[] = {"resolution_m", "length_x_m", "length_y_m", "center_x_m", "center_y_m"};
}  // namespace

bool has_grid_geometry(const Params& p) {
  for (std::string_view k : kKeys)
    if (p.has(k)) return true;
  return false;
}

GridGeometry read_grid_geometry(Params& p, const GridGeometry& d, std::string_view role) {
  const std::string r(role);
  const std::string docs[5] = {r + ": cell size", r + ": extent along x (forward)", r + ": extent along y (left)",
                               r + ": centre ahead of the rover (body frame)", r + ": centre, left positive"};
  GridGeometry g;
  g.resolution_m =
      p.get<double>(kKeys[0], d.resolution_m, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = docs[0]});
  g.length_x_m =
      p.get<double>(kKeys[1], d.length_x_m, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = docs[1]});
  g.length_y_m =
      p.get<double>(kKeys[2], d.length_y_m, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = docs[2]});
  g.center_x_m = p.get<double>(kKeys[3], d.center_x_m, {.unit = "m", .doc = docs[3]});
  g.center_y_m = p.get<double>(kKeys[4], d.center_y_m, {.unit = "m", .doc = docs[4]});
  try {
    g.validate();
  } catch (const FieldError& e) {
    p.fail(e);
  }
  return g;
}

}  // namespace regolith::common
