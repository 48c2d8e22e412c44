#pragma once
// Component wrapper "sams": the shared DTM of the "sfs" component (channel "terrain/dtm": grey
// image + SfS height of one camera frame, computed once per frame) -> saliency (SAMS, Itti or an
// OpenCV peer) -> boxes (BoxDetector) -> every box ranged with direct depth -> published on
//   * channel "terrain/rocks"            (RockFrame, below),
//   * channel "terrain/rock_probability" (RockProbabilityFrame: a grid layer in the
//     traversability grid's geometry and index convention, to be merged into the GridMap),
//   * DDS topic terrain/rocks            (regolith_msgs/RockArray) when DDS is enabled.
// Parameters, I/O and numbers: components/saliency/README.md ("Component").
#include <array>
#include <cstdint>

#include <opencv2/core.hpp>

#include "regolith/common/payloads.hpp"
#include "regolith/core/time.hpp"
#include "regolith/saliency/ranging.hpp"

namespace regolith::saliency {

/// Channel (and DDS topic) name of the ranged rocks.
inline constexpr const char* kRocksChannel = "terrain/rocks";
/// The rock-probability grid layer (payload in regolith/common/payloads.hpp).
using common::kRockProbabilityChannel;
using common::kRockProbabilityLayer;
using common::RockProbabilityFrame;
/// Most rocks one frame can carry (the `max_detections` parameter is capped at this).
inline constexpr std::uint32_t kMaxRocks = 64;

/// The rocks of one camera frame (fixed capacity: copied without allocation).
struct RockFrame {
  std::array<RangedRock, kMaxRocks> rocks{};  ///< [0, count): sorted by descending score
  std::uint32_t count = 0;
  std::uint32_t hazards = 0;   ///< rocks with hazard == true
  int image_width = 0;         ///< px, size of the image the boxes refer to
  int image_height = 0;        ///< px
  TimeNs stamp = 0;            ///< capture time of the source camera frame (ns, process clock)
  std::uint64_t sequence = 0;  ///< camera frame sequence number (DtmFrame::sequence)
};

/// Registers component type "sams".
void register_component();

}  // namespace regolith::saliency
