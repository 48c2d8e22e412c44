#pragma once
// The payload types that travel on channels between components, with their channel names. A
// consumer includes this header and links regolith::common; it never needs its producer's library.
// Every type is allocated once (configure) and reused: nothing here allocates per cycle.
#include <array>
#include <cstddef>
#include <cstdint>

#include <opencv2/core.hpp>

#include "regolith/common/grid.hpp"
#include "regolith/core/time.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::common {

// ---- terrain/dtm: produced by sfs, consumed by traversability and sams -----------------------

inline constexpr const char* kDtmChannel = "terrain/dtm";

/// One DTM per camera frame.
/// The part of a DtmFrame that costs a full-frame SfS solve: consumers that read `height` / `valid`
/// declare it in configure (ctx.want(kDtmChannel, kDtmHeight)); when nobody does, the sfs component
/// publishes the grey image and the sun only (solved = false), as for a sun ahead of the camera.
inline constexpr const char* kDtmHeight = "height";
/// The heights at a quarter of the frame's resolution are enough (SAMS's structure channel uses
/// pyramid levels >= 2 only): when no consumer wants kDtmHeight, the sfs component solves on the
/// frame reduced 4x (16x fewer pixels) and publishes that solution as it is, in height4 / valid4
/// (DtmFrame::height_level 2): no full-frame copy is made for a reader that would shrink it again.
inline constexpr const char* kDtmHeightQuarter = "height/4";

struct DtmFrame {
  cv::Mat gray;    ///< CV_8UC1 grey image as captured (before vignetting correction)
  cv::Mat height;  ///< CV_32FC1 relative height, UP positive, pixel units (sfs.hpp conventions)
  cv::Mat valid;   ///< CV_8UC1, 255 = usable pixel
  /// height_level 2: the solve on the frame reduced 4x (each side floor(frame / 4), block k
  /// covering frame pixels 4k..4k+3), heights in the frame's pixel units; height / valid are then
  /// not written (NaN / 0).
  cv::Mat height4, valid4;
  /// false when no image-frame SfS was run (the sun is ahead of the camera, slant >= 90 deg, or no
  /// consumer reads the heights): height is NaN and valid 0, gray and light are set
  /// (traversability's ground path uses them).
  bool solved = true;
  /// 0: solved on the full frame (height / valid); 2: solved on the frame reduced 4x (only
  /// quarter-resolution readers, kDtmHeightQuarter: height4 / valid4).
  int height_level = 0;
  sfs::LightDirection light;       ///< light used (camera image frame); slant >= pi/2 when !solved
  bool light_estimated = false;    ///< true when estimated from the image
  double light_confidence = 1.0;   ///< 1 when given, estimator confidence otherwise
  int iterations = 0;              ///< SfS iterations used
  double final_mean_update = 0.0;  ///< px, mean |dZ| of the last iteration
  TimeNs stamp = 0;                ///< capture time of the source frame (ns, process clock)
  std::uint64_t sequence = 0;      ///< camera frame sequence number
  /// Camera geometry of the frame (rover.cameras.<camera>; null with an estimated light and no
  /// description of the camera).
  /// Points into the producing component; valid for the lifetime of the deployment.
  const direct_depth::CameraModel* camera = nullptr;
};

// ---- terrain/rock_probability: produced by sams, merged by traversability ----------------------

inline constexpr const char* kRockProbabilityChannel = "terrain/rock_probability";
/// Name of the grid-map layer the probability fills.
inline constexpr const char* kRockProbabilityLayer = "rock_probability";

/// Per-cell rock score in a grid's geometry (the traversability grid's, see grid.hpp): the
/// saliency map (in [0, 1], max 1 per frame) at the pixel that sees the cell centre on flat ground;
/// NaN where the camera does not see the cell. An uncalibrated score (saliency/README.md).
struct RockProbabilityFrame : GridGeometry {
  cv::Mat probability;  ///< CV_32F, size_x rows x size_y cols, allocated once
  TimeNs stamp = 0;     ///< capture time of the source camera frame (ns)
  std::uint64_t sequence = 0;
};

// ---- terrain/sinkage_layer: produced by soil_stiffness, merged by traversability -------------
//
// The measured rut profiles of one soil estimate as a fixed-size struct (no heap), positioned in
// the rover body frame.
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

inline constexpr const char* kSinkageLayerChannel = "terrain/sinkage_layer";
inline constexpr std::size_t kLayerMaxTracks = 8;     ///< tracks carried by one layer
inline constexpr std::size_t kLayerMaxSamples = 512;  ///< samples per track (longer profiles are averaged down)

/// Where the camera's ground frame sits in the rover body frame.
struct LayerPose {
  double mount_x_m = -0.5;                        ///< [m] body x of the point below the rear camera
  double mount_y_m = 0.0;                         ///< [m] body y
  double mount_yaw_rad = 3.14159265358979323846;  ///< [rad] heading of the camera's view (pi = backwards)
};

struct SinkageLayerTrack {
  double lateral_m = 0.0;                           ///< rut centre in the camera ground frame [m]
  double width_m = 0.0;                             ///< rut width = wheel width b [m]
  double load_n = 0.0;                              ///< wheel load used for the fit [N]
  double mean_sinkage_m = 0.0;                      ///< [m]
  std::uint32_t count = 0;                          ///< valid entries in the arrays below
  std::array<float, kLayerMaxSamples> range_m{};    ///< along-track position, camera frame [m]
  std::array<float, kLayerMaxSamples> x_m{};        ///< rut centre, body frame [m]
  std::array<float, kLayerMaxSamples> y_m{};        ///< rut centre, body frame [m]
  std::array<float, kLayerMaxSamples> sinkage_m{};  ///< static sinkage [m], NaN = not measured
};

/// One estimate's sinkage layer (channel "terrain/sinkage_layer").
struct SinkageLayer {
  std::int64_t stamp_ns = 0;   ///< capture time of the rear frame [ns, process clock]
  std::uint64_t sequence = 0;  ///< camera frame sequence number
  bool valid = false;          ///< false: no estimate for this frame (no tracks measured)
  LayerPose pose;              ///< camera ground frame in the body frame
  std::uint32_t track_count = 0;
  std::array<SinkageLayerTrack, kLayerMaxTracks> tracks{};
};

/// Writes the layer onto `out` (CV_32F, size_x rows x size_y cols; created when its size or type
/// differ, otherwise written in place): sinkage [m] where a rut covers the cell centre, NaN
/// elsewhere. Returns the number of cells set. Throws FieldError for a bad geometry.
int rasterise_sinkage(const SinkageLayer& layer, const GridGeometry& grid, cv::Mat& out);

}  // namespace regolith::common
