#pragma once
// A rendered scene's description as the development sets write it (`input.json` beside each image
// of ../shared/data/synthetic_dev/sfs/), read for a single-image tool (`regolith assess IMAGE
// --scene input.json`): the orthographic patch's pixel size, sun and flat field, or the perspective
// camera and the sun in its image frame. The perspective sun is given in the world (X right,
// Y forward, Z up; azimuth from +Y towards +X), which is the rover description's compass azimuth,
// so it goes into the image frame by camera_light (camera.hpp), the conversion --rover uses.
#include <optional>
#include <string>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::common {

struct SceneDescription {
  std::optional<direct_depth::CameraModel> camera;  ///< perspective scenes; none: an orthographic patch
  double pixel_size_m = 0.0;                        ///< orthographic: ground size of a pixel (m)
  sfs::LightDirection light;                        ///< the sun in the image frame
  bool sun_in_view = true;                          ///< false: the sun is ahead of the camera (slant >= 90 deg)
  std::string flat_field;                           ///< orthographic: the flat-field image beside the file; empty: none
};

/// `file` for an image of `width` x `height` px. "projection" is
///  * "orthographic": gsd_m (> 0), sun_slant_deg / sun_tilt_deg (image frame, the sun above the
///    patch), optional width / height (the image's), flat_field (null or a file name, relative to
///    the description's folder);
///  * "perspective": camera {width, height (the image's), fx, fy, cx, cy, h_m, pitch_deg
///    [, roll_deg]}, sun_elevation_deg (-90..90) and sun_azimuth_deg.
/// InputError "FILE: FIELD: why" for anything missing, invalid or of another image size; a recorded
/// drive's input.json (frames_csv, no projection) is named as such, with what to use instead.
SceneDescription read_scene_description(const std::string& file, int width, int height);

}  // namespace regolith::common
