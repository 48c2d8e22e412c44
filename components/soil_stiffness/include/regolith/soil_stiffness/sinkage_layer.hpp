#pragma once
// The `sinkage` layer for the terrain grid map: the measured rut profiles of one estimate as a
// fixed-size struct (no heap: it travels on a runtime channel), positioned in the rover body frame,
// and its rasterisation onto a grid with the traversability component's GridMap convention.
//
// Frames. The estimator works in the rear camera's ground frame G: origin on the ground below the
// optical centre, x_G = range along the camera's horizontal viewing direction, y_G = lateral (left
// +). G sits in the rover body frame B (base_link, REP-103: x forward, y left, z up) at
// (mount_x_m, mount_y_m) with heading mount_yaw_rad (a rear camera: yaw = pi). A profile sample at
// (range r, rut centre lateral l) is at
//     x_B = mount_x + cos(yaw) r - sin(yaw) l,   y_B = mount_y + sin(yaw) r + cos(yaw) l.
// The layer value of a cell is the static sinkage [m] of the rut covering it (cells within half a
// wheel width of the rut centre line, between two consecutive samples), NaN elsewhere: the terrain
// grid keeps NaN as "unknown" and a grid in a world frame must move these body-frame points with
// the odometry at the layer's stamp (the capture time of the rear frame).
#include <array>
#include <cstdint>

#include <opencv2/core.hpp>

#include "regolith/common/payloads.hpp"
#include "regolith/soil_stiffness/track_analysis.hpp"

namespace regolith::soil {

// The layer types live in regolith/common/payloads.hpp (consumers need only regolith::common).
using common::GridGeometry;
using common::kLayerMaxSamples;
using common::kLayerMaxTracks;
using common::LayerPose;
using common::rasterise_sinkage;
using common::SinkageLayer;
using common::SinkageLayerTrack;

/// Fills `out` from an estimate (no allocation). Profiles longer than kLayerMaxSamples are averaged
/// over consecutive groups of samples; tracks beyond kLayerMaxTracks are dropped.
void fill_sinkage_layer(const SoilEstimate& estimate, double wheel_width_m, const LayerPose& pose,
                        std::int64_t stamp_ns, std::uint64_t sequence, SinkageLayer& out);

}  // namespace regolith::soil
