#pragma once
// Component "terrain_map": the drive-long map as a running component. A camera (rover.cameras.
// <camera>), the wheel encoders (rover.wheels, skid-steer odometry) and, when the rover has one,
// the IMU heading feed DriveMapper::add_frame once per new frame. Outputs: channel `odom`
// (TerrainMapState, below), DDS `odom` and `odom/wheel` (nav_msgs/Odometry) and
// `terrain/world_map` (grid_map_msgs/GridMap, frame `odom`) and `terrain/world_rocks`
// (vision_msgs/Detection3DArray, frame `odom`). See components/mapping/README.md.
#include <cstdint>

#include "regolith/core/time.hpp"
#include "regolith/mapping/drive_mapper.hpp"
#include "regolith/mapping/pose2.hpp"

namespace regolith::mapping {

/// Channel name of TerrainMapState (the component's result, one per mapped frame).
inline constexpr const char* kOdometryChannel = "odom";

/// What the terrain_map component knows after each mapped frame. Its counters are as of that
/// frame; the component's diagnostics read those of frames that never reach the map live.
struct TerrainMapState {
  TimeNs stamp = 0;            ///< capture time of the frame
  std::uint64_t sequence = 0;  ///< camera frame sequence
  Pose2 pose;                  ///< corrected body pose (odom frame)
  Cov3 covariance = Cov3::Zero();
  Pose2 wheel_pose;  ///< wheel (+ IMU heading) odometry alone
  VoStatus vo = VoStatus::kNoKeyframe;
  bool keyframe = false;
  int vo_inliers = 0;
  DriveCounters counters;         ///< the mapper's: frames, vo_ok, vo_failed, odometry_jumps, keyframes
  long frames_rejected = 0;       ///< frames never given to the mapper (corrupt, wrong size / type, mapper error)
  long odometry_unavailable = 0;  ///< frames without encoder angles at their capture time
  long odometry_reanchored =
      0;  ///< odometry sub-steps whose wheel reading was implausible (re-anchored, distance lost)
  long frames_out_of_order =
      0;                 ///< frames stamped at or before the last one taken, by less than the input timeout (skipped)
  long clock_steps = 0;  ///< stamps further back than the input timeout: mapping went on from there
  long cells_known = 0;  ///< map cells with an elevation (at the last map update)
  long rocks = 0;        ///< rocks the map reports (WorldMap::rocks, at the last map update)
  long map_updates = 0;  ///< times the derived layers were recomputed (and published)
  double distance_m = 0.0;  ///< wheel odometry distance driven
};

/// Registers "terrain_map" with the runtime's component registry.
void register_component();

}  // namespace regolith::mapping
