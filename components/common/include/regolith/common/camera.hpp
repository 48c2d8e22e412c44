#pragma once
// The rover description (regolith/core/rover.hpp) in the algorithms' terms: one camera model per
// camera device, and the one deployment sun in each camera's frames. Every component that needs
// a camera's geometry or the sun gets it here, so no component repeats intrinsics, mounts or suns.
#include "regolith/common/sun.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::common {

/// direct_depth's model of a described camera: K and plumb_bob D, mount height z_m, pitch and
/// roll of the mount (its x, y and yaw place the camera's ground frame in the body frame).
direct_depth::CameraModel camera_model_of(const RoverCamera& camera);
/// The model of the camera that delivers `width` x `height` px frames, for a component reading
/// it: a calibration of another size is a ConfigError at `key` of `p`, a model direct_depth
/// rejects a ConfigError at the calibration's declaration.
direct_depth::CameraModel camera_model_for_frames(const RoverCamera& camera, int width, int height, Params& p,
                                                  std::string_view key);

/// The sun in a camera's image frame (regolith::sfs conventions).
struct CameraLight {
  sfs::LightDirection light;  ///< slant / tilt; slant may be >= pi/2 (see `in_view`)
  /// false when the sun is at or ahead of the image plane (slant >= 90 deg): normal for a camera
  /// facing the sun. Image-frame SfS has no shading to invert then; the ground-frame path
  /// (traversability sfs_frame ground) still uses the sun.
  bool in_view = false;
};
CameraLight camera_light(const Sun& sun, const RoverCamera& camera, const Attitude& attitude = {});

/// The sun in a camera's ground frame (sun.hpp): the frame of the soil track analysis.
GroundSun ground_sun(const Sun& sun, const RoverCamera& camera, const Attitude& attitude = {});

}  // namespace regolith::common
