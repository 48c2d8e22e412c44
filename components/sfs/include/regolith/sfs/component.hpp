#pragma once
// Component wrapper "sfs": one camera frame per cycle -> grey -> vignetting correction -> SfS ->
// shared DTM on channel "terrain/dtm" (consumed by traversability and, later, SAMS: the DTM is
// computed once per frame). Parameters and I/O: components/sfs/README.md.
#include <cstdint>

#include <opencv2/core.hpp>

#include "regolith/common/payloads.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::sfs {

// The DTM payload lives in regolith/common/payloads.hpp (consumers need only regolith::common).
using common::DtmFrame;
using common::kDtmChannel;

/// Reads a `camera_model` mapping (fx, fy, cx, cy, k1, k2, p1, p2, k3, mount_height_m, pitch_rad,
/// roll_rad) for an image of width x height px; cx/cy default to the image centre and fy to fx.
/// Throws ConfigError naming the field (also for a model direct_depth rejects).
direct_depth::CameraModel read_camera_model(Params p, int width, int height);

/// Registers component type "sfs".
void register_component();

}  // namespace regolith::sfs
