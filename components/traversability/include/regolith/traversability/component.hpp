#pragma once
// Component wrapper "traversability": DTM (channel "terrain/dtm", from the "sfs" component) +
// camera model -> metric elevation / traversability grid, published on the channel
// "terrain/grid_map" and, when DDS is enabled, as grid_map_msgs/GridMap on topic terrain/grid_map.
#include <cstdint>

#include "regolith/core/time.hpp"
#include "regolith/traversability/traversability.hpp"

namespace regolith::traversability {

/// Name of the grid-map channel (same name as the DDS topic).
inline constexpr const char* kGridMapChannel = "terrain/grid_map";

struct GridMapFrame {
  GridMap map;                 ///< layers allocated once (layer_names() order)
  TimeNs stamp = 0;            ///< capture time of the source camera frame (ns)
  std::uint64_t sequence = 0;  ///< camera frame sequence number
};

/// Registers component type "traversability".
void register_component();

}  // namespace regolith::traversability
