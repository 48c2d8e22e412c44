#pragma once
// The one YAML reader of a grid's geometry: keys resolution_m, length_x_m, length_y_m, center_x_m,
// center_y_m (units m, body frame), shared by every component that writes a grid layer so the
// layers of one map can be configured identically.
#include <string_view>

#include "regolith/common/grid.hpp"
#include "regolith/core/params.hpp"

namespace regolith::common {

/// Reads the five keys of `p` (defaults from `defaults`), validates, and reports problems as
/// located ConfigErrors. `role` completes each key's documentation ("rock_probability grid").
GridGeometry read_grid_geometry(Params& p, const GridGeometry& defaults, std::string_view role);

/// Whether `p` sets any of those keys (else a caller may choose the geometry itself).
bool has_grid_geometry(const Params& p);

}  // namespace regolith::common
