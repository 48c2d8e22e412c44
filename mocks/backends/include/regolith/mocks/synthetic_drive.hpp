#pragma once
// The exact truth of the `synthetic_drive` mock devices (camera, wheel encoders, IMU): every
// device built by these backends implements DriveTruth, so a test can ask the device store for
// it (`dynamic_cast<const mocks::DriveTruth*>(ctx.find<hal::Camera>("front"))`; a deployment's
// cameras are read through hal::StampCheckedCamera: cast its `inner()`).
#include <cmath>

#include "regolith/core/time.hpp"
#include "regolith/terrain_scene/drive.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

namespace regolith::mocks {

class DriveTruth {
 public:
  virtual ~DriveTruth() = default;
  /// The scripted path (world = the scene; the odometry frame is the start pose's frame).
  virtual const terrain_scene::DrivePath& drive_path() const = 0;
  /// The terrain tile (height field, rocks, craters); null for devices that do not render.
  virtual const terrain_scene::Terrain* drive_terrain() const = 0;
  /// Process-clock time of the device's start() (0 before): path time t = (stamp - start) / 1e9.
  virtual TimeNs drive_start_time() const = 0;
  /// Exact body pose at a process-clock stamp, in the odometry frame (start pose = origin).
  terrain_scene::DrivePose odom_pose_at(TimeNs stamp) const {
    const terrain_scene::DrivePath& p = drive_path();
    const terrain_scene::DrivePose w = p.pose_at(to_seconds(stamp - drive_start_time()));
    const double c = std::cos(p.start_yaw_rad), s = std::sin(p.start_yaw_rad);
    const double dx = w.x_m - p.start_x_m, dy = w.y_m - p.start_y_m;
    return {c * dx + s * dy, -s * dx + c * dy, w.yaw_rad - p.start_yaw_rad};
  }
};

}  // namespace regolith::mocks
