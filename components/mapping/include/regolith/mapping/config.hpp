#pragma once
// The drive mapper's parameters read by name from YAML: one reader for the `terrain_map`
// component (its `params:` block) and `regolith map` (`--config FILE`, `--set key=value`), so a
// key means the same in both. Keys, units and defaults: components/mapping/README.md
// ("Parameters"); `regolith config check` lists them for a deployment.
#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/mapping/drive_mapper.hpp"

namespace regolith::mapping {

/// The DriveMapperParams keys of `p`, each defaulting to `defaults`' value (located ConfigError
/// on a bad value; unknown keys are the caller's p.finish()).
DriveMapperParams read_drive_mapper_params(Params& p, DriveMapperParams defaults = {});

/// How the terrain_map integrates its wheel odometry between frames (SteppedOdometry), read from
/// the component's `params:` by the component and by `regolith map REC.mcap` alike.
struct OdometrySettings {
  bool imu_heading = false;  ///< heading_source imu: heading changes from rover.imu, else the wheels
  TimeNs step = 0;           ///< odometry_step_s: the longest integration sub-step
};
/// heading_source (default imu when the rover has one) and odometry_step_s; located ConfigError
/// when heading_source is imu and the rover has none.
OdometrySettings read_odometry_settings(Params& p, const RoverDescription& rover);

/// input_timeout_s (default 2 frame periods + 1 s at `rate_hz`): the camera input is stale after
/// this long, and a frame stamped further back than this before the last mapped one is a clock
/// step (FrameOrder). The terrain_map component's key, read here for `regolith map REC.mcap` too.
TimeNs read_input_timeout(Params& p, double rate_hz);

}  // namespace regolith::mapping
