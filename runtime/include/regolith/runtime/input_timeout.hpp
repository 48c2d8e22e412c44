#pragma once
// The camera input timeout of a component that processes camera frames: one key and one default
// rule for every such component (sfs, wheel_sinkage, terrain_map and `regolith map REC.mcap`).
#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"

namespace regolith::runtime {

/// The `input_timeout_s` parameter of a component fed by a camera delivering `rate_hz` frames per
/// second (declared on `p`): the camera input is stale after this long, and a frame stamped further
/// back than this before the last one taken is a clock step (`regolith::FrameOrder`). Default two
/// frame periods + `slack_s` (rates below 0.1 Hz count as 0.1 Hz; an unknown rate, 0, as 1 Hz).
TimeNs read_input_timeout(Params& p, double rate_hz, double slack_s);

}  // namespace regolith::runtime
