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

#include "regolith/soil_stiffness/track_analysis.hpp"

namespace regolith::soil {

inline constexpr std::size_t kLayerMaxTracks = 8;     ///< tracks carried by one layer
inline constexpr std::size_t kLayerMaxSamples = 512;  ///< samples per track (longer profiles are averaged down)

/// Where the camera's ground frame sits in the rover body frame.
struct LayerPose {
  double mount_x_m = -0.5;       ///< [m] body x of the point below the rear camera
  double mount_y_m = 0.0;        ///< [m] body y
  double mount_yaw_rad = 3.14159265358979323846;  ///< [rad] heading of the camera's view (pi = backwards)
};

struct SinkageLayerTrack {
  double lateral_m = 0.0;        ///< rut centre in the camera ground frame [m]
  double width_m = 0.0;          ///< rut width = wheel width b [m]
  double load_n = 0.0;           ///< wheel load used for the fit [N]
  double mean_sinkage_m = 0.0;   ///< [m]
  std::uint32_t count = 0;       ///< valid entries in the arrays below
  std::array<float, kLayerMaxSamples> range_m{};    ///< along-track position, camera frame [m]
  std::array<float, kLayerMaxSamples> x_m{};        ///< rut centre, body frame [m]
  std::array<float, kLayerMaxSamples> y_m{};        ///< rut centre, body frame [m]
  std::array<float, kLayerMaxSamples> sinkage_m{};  ///< static sinkage [m], NaN = not measured
};

/// One estimate's sinkage layer (channel "terrain/sinkage_layer").
struct SinkageLayer {
  std::int64_t stamp_ns = 0;     ///< capture time of the rear frame [ns, process clock]
  std::uint64_t sequence = 0;    ///< camera frame sequence number
  bool valid = false;            ///< false: no estimate for this frame (no tracks measured)
  LayerPose pose;                ///< camera ground frame in the body frame
  std::uint32_t track_count = 0;
  std::array<SinkageLayerTrack, kLayerMaxTracks> tracks{};
};

/// Fills `out` from an estimate (no allocation). Profiles longer than kLayerMaxSamples are averaged
/// over consecutive groups of samples; tracks beyond kLayerMaxTracks are dropped.
void fill_sinkage_layer(const SoilEstimate& estimate, double wheel_width_m, const LayerPose& pose,
                        std::int64_t stamp_ns, std::uint64_t sequence, SinkageLayer& out);

/// Grid geometry, the traversability component's GridMap convention: cell (i, j) has its centre
/// at x = center_x + length_x/2 - (i + 1/2) res, y = center_y + length_y/2 - (j + 1/2) res
/// (row 0 = +x edge, column 0 = +y edge, as grid_map).
struct GridGeometry {
  double resolution_m = 0.05;  ///< [m]
  double length_x_m = 4.0;     ///< [m]
  double length_y_m = 4.0;     ///< [m]
  double center_x_m = 0.0;     ///< [m] body frame
  double center_y_m = 0.0;     ///< [m]
  int size_x() const;          ///< rows
  int size_y() const;          ///< columns
};

/// Writes the layer onto `out` (CV_32F, size_x rows x size_y cols; created when its size or type
/// differ, otherwise written in place): sinkage [m] where a rut covers the cell centre, NaN
/// elsewhere. Returns the number of cells set. Throws std::invalid_argument for a bad geometry.
int rasterise_sinkage(const SinkageLayer& layer, const GridGeometry& grid, cv::Mat& out);

}  // namespace regolith::soil
