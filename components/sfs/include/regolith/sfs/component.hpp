#pragma once
// Component wrapper "sfs": one camera frame per cycle -> grey -> vignetting correction -> SfS ->
// shared DTM on channel "terrain/dtm" (consumed by traversability and, later, SAMS: the DTM is
// computed once per frame). Parameters and I/O: components/sfs/README.md.
#include <opencv2/core.hpp>

#include <cstdint>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::sfs {

/// Name of the shared DTM channel.
inline constexpr const char* kDtmChannel = "terrain/dtm";

/// One DTM per camera frame. All Mats are allocated once (configure) and reused.
struct DtmFrame {
  cv::Mat gray;    ///< CV_8UC1 grey image as captured (before vignetting correction)
  cv::Mat height;  ///< CV_32FC1 relative height, UP positive, pixel units (sfs.hpp conventions)
  cv::Mat valid;   ///< CV_8UC1, 255 = usable pixel
  /// false when no image-frame SfS was run (the sun is ahead of the camera, slant >= 90 deg):
  /// height is NaN and valid 0, gray and light are set (traversability's ground path uses them).
  bool solved = true;
  LightDirection light;          ///< light used (camera image frame); slant >= pi/2 when !solved
  bool light_estimated = false;  ///< true when estimated from the image
  double light_confidence = 1.0; ///< 1 when given, estimator confidence otherwise
  int iterations = 0;            ///< SfS iterations used
  double final_mean_update = 0.0;  ///< px, mean |dZ| of the last iteration
  TimeNs stamp = 0;              ///< capture time of the source frame (ns, process clock)
  std::uint64_t sequence = 0;    ///< camera frame sequence number
  /// Camera geometry of the frame (rover.cameras.<camera>; null with an estimated light and no
  /// description of the camera).
  /// Points into the producing component; valid for the lifetime of the deployment.
  const direct_depth::CameraModel* camera = nullptr;
};

/// Reads a `camera_model` mapping (fx, fy, cx, cy, k1, k2, p1, p2, k3, mount_height_m, pitch_rad,
/// roll_rad) for an image of width x height px; cx/cy default to the image centre and fy to fx.
/// Throws ConfigError naming the field (also for a model direct_depth rejects).
direct_depth::CameraModel read_camera_model(Params p, int width, int height);

/// Registers component type "sfs".
void register_component();

}  // namespace regolith::sfs
