#pragma once
// A scripted drive over a generated terrain tile: the exact rover path (a straight line or a
// constant-curvature arc at constant speed, then standing still), the wheel rotations a rigid
// skid-steered body makes on it (with optional slip), and the tile the path needs (rocks and
// craters along the path, cast shadows from the sun). The truth of the `synthetic_drive` mock
// backends (camera, encoders, IMU) and of the tests that check the terrain_map component.
//
// Frames: the scene world is the local-level frame at start (x = the heading at start, y left,
// z up); the rover starts at (start_x, start_y, start_yaw). Body frame REP-103 (x forward, y
// left, z up, origin on the ground below the body centre).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/terrain_scene/terrain_scene.hpp"

namespace regolith::terrain_scene {

struct DrivePose {
  double x_m = 0.0, y_m = 0.0;  ///< body origin in the world
  double yaw_rad = 0.0;         ///< heading, counter-clockwise from world +x
};

struct DrivePath {
  double start_x_m = 0.0, start_y_m = 0.0, start_yaw_rad = 0.0;
  double speed_m_s = 0.1;      ///< m/s of the body origin while driving
  double turn_radius_m = 0.0;  ///< m, 0 = straight; > 0 turns left (counter-clockwise), < 0 right
  double duration_s = 30.0;    ///< s of driving; afterwards the rover stands still
  /// Throws std::invalid_argument naming the field.
  void validate() const;

  double yaw_rate() const { return turn_radius_m == 0.0 ? 0.0 : speed_m_s / turn_radius_m; }  ///< rad/s
  /// Driving time elapsed at t (clamped to [0, duration]).
  double driven_time(double t_s) const;
  /// Exact body pose at t seconds after start.
  DrivePose pose_at(double t_s) const;
  /// Body velocity at t: forward speed (m/s) and yaw rate (rad/s); zero when standing.
  cv::Vec2d velocity_at(double t_s) const;
  /// Distance rolled at t by a wheel whose contact point is `y_m` left of the body origin: the
  /// longitudinal component of the body velocity there, v - w y (the lateral part skids).
  double wheel_distance(double y_m, double t_s) const;
  /// World bounding box of the body path (x_min, y_min, x_max, y_max).
  cv::Vec4d bounds() const;
};

/// The terrain tile a drive needs: the path's bounding box plus `margin_m` on every side (what
/// the camera sees ahead and beside), with rocks and craters placed around the path (never under
/// the start pose) and `rocks_per_m2` / `craters` of them.
struct DriveTileParams {
  std::uint64_t seed = 1;
  double resolution_m = 0.02;
  double fractal_rms_m = 0.005;
  double fractal_beta = 2.9;
  double margin_m = 6.0;
  double rocks_per_m2 = 0.15;
  double rock_radius_min_m = 0.05, rock_radius_max_m = 0.18;
  int craters = 2;
  double crater_radius_min_m = 0.4, crater_radius_max_m = 0.9;
  double keep_clear_m = 0.8;  ///< no rock or crater this close to the path (the wheels drive over flat ground)
};

/// Generates the tile (deterministic for `tile.seed`). Throws std::invalid_argument.
Terrain make_drive_tile(const DrivePath& path, const DriveTileParams& tile);

}  // namespace regolith::terrain_scene
