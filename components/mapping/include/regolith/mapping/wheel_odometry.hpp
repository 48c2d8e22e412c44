#pragma once
// Planar wheel odometry of a skid-steered (or differential) rover from its wheel encoder angles:
// each wheel's rolled distance r * (angle change); the left wheels (contact point y > 0) and the
// right wheels (y < 0) are averaged per side; forward step = the mean of both sides, heading
// change = (right - left) / track width (track width = mean left y - mean right y), or the change
// of an absolute heading given by an IMU. Each step is integrated along a circular arc (exact for
// constant curvature). Framework-free; nothing allocates after construction.
#include <limits>
#include <span>
#include <vector>

#include "regolith/mapping/pose2.hpp"

namespace regolith::mapping {

struct OdometryWheel {
  double y_m = 0.0;       ///< m, contact point left of the body origin (REP-103: y left)
  double radius_m = 0.0;  ///< m
};

class SkidSteerOdometry {
 public:
  /// Needs at least one wheel on each side (y > 0 and y < 0; wheels on y = 0 are ignored) and
  /// positive radii: FieldError("mapping.odometry", "wheels", ...) otherwise.
  explicit SkidSteerOdometry(const std::vector<OdometryWheel>& wheels);

  std::size_t wheel_count() const { return wheels_.size(); }
  double track_width() const { return track_m_; }  ///< m
  bool started() const { return started_; }

  /// Starts at `pose` with the wheels at `angles` (rad, one per wheel, in construction order) and,
  /// when given (finite), the IMU heading `yaw` (rad) at that moment.
  void reset(std::span<const double> angles, const Pose2& pose = {},
             double yaw = std::numeric_limits<double>::quiet_NaN());
  /// Advances to the wheel angles `angles`; with a finite `yaw` the heading change is the IMU's
  /// (yaw - the previous yaw), else the wheels'. A non-finite angle leaves the pose unchanged
  /// and returns false (the next good reading spans the gap). A wheel rolling farther than
  /// `max_step_m` in this step (an impossible jump: a corrupt reading the odometry started from)
  /// re-anchors on these angles without moving and returns false. Not started: reset() is done.
  bool update(std::span<const double> angles, double yaw = std::numeric_limits<double>::quiet_NaN(),
              double max_step_m = std::numeric_limits<double>::infinity());
  const Pose2& pose() const { return pose_; }
  /// Distance driven (m, sum of |forward steps|).
  double distance() const { return distance_; }

 private:
  std::vector<OdometryWheel> wheels_;
  std::vector<double> last_;
  double track_m_ = 0.0;
  double last_yaw_ = std::numeric_limits<double>::quiet_NaN();
  bool started_ = false;
  Pose2 pose_;
  double distance_ = 0.0;
};

}  // namespace regolith::mapping
