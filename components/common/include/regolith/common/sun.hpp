#pragma once
// The sun as the algorithms see it, in the frame they work in. The deployment has one sun
// (regolith::Sun, core/rover.hpp: compass azimuth in the local-level frame); code converts it into
// these per camera (regolith/common/camera.hpp), never reading them from a file:
//   * the image frame of a camera: sfs::LightDirection (slant from the line of sight, tilt);
//   * the ground frame of a camera (x = its viewing heading, y left, z up): GroundSun below.
namespace regolith::common {

/// Towards the sun in a camera's ground frame: azimuth from x (the viewing heading) towards y
/// (left), elevation above the ground. Default: from the left of the view, 45 deg high.
struct GroundSun {
  double azimuth_rad = 1.5708;
  double elevation_rad = 0.7854;
};

}  // namespace regolith::common
