#pragma once
// Planar wheel odometry of a skid-steered (or differential) rover from its wheel encoder angles:
// each wheel's rolled distance r * (angle change); the left wheels (contact point y > 0) and the
// right wheels (y < 0) are averaged per side; forward step = the mean of both sides, heading
// change = (right - left) / track width (track width = mean left y - mean right y), or the change
// of an absolute heading given by an IMU. Each step is integrated along a circular arc (exact for
// constant curvature). Framework-free; nothing allocates after construction.
#include <algorithm>
#include <cstdint>
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
  /// Takes `angles` (and `yaw`) as the new reference without moving: the pose and the distance
  /// stay (a reading after a time base changed, whose angle change since the last is meaningless).
  /// A non-finite angle changes nothing and returns false.
  bool rebase(std::span<const double> angles, double yaw = std::numeric_limits<double>::quiet_NaN());
  /// Advances to the wheel angles `angles`; with a finite `yaw` the heading change is the IMU's
  /// (yaw - the previous yaw), else the wheels'. A non-finite angle leaves the pose unchanged
  /// and returns false (the next good reading spans the gap). A wheel rolling farther than
  /// `max_step_m` in this step (an impossible jump: a corrupt reading the odometry started from)
  /// re-anchors on these angles without moving (rebase(): the distance driven stays) and returns
  /// false. Not started: reset() is done.
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

/// SkidSteerOdometry advanced to a time in sub-steps of at most `step_ns`, each reading the wheel
/// angles (and the IMU heading) at the sub-step's time: one integration for the terrain_map
/// component (HAL devices) and `regolith map REC.mcap` (recorded samples), so both place a frame
/// at the same pose. A wheel rolling faster than `max_speed_mps` (+ 5 cm) in a sub-step is a
/// corrupt reading: the odometry re-anchors there (SkidSteerOdometry::update) and counts it.
/// Nothing allocates after construction.
class SteppedOdometry {
 public:
  static constexpr std::int64_t kMaxSubsteps = 64;  ///< per advance_to() (a long gap: longer steps)

  /// FieldError as SkidSteerOdometry's on bad wheels; step_ns > 0, max_speed_mps > 0.
  SteppedOdometry(const std::vector<OdometryWheel>& wheels, std::int64_t step_ns, double max_speed_mps);

  /// Advances to `t_ns`. `read(t_ns, angles, yaw)` fills `angles` (std::span<double>, one per
  /// wheel in construction order) and `yaw` (rad; NaN: the wheels give the heading change) at that
  /// time, and returns false when the inputs have nothing there: the pose then stays where the
  /// last good reading left it and advance_to() returns false. The first successful read starts
  /// the odometry at the origin. A time before the last one reached changes nothing (true only
  /// when equal).
  template <class Read>
  bool advance_to(std::int64_t t_ns, Read&& read);
  /// The clock the times come from stepped back: the next advance_to() reads the inputs at its
  /// time and continues from the current pose on them (SkidSteerOdometry::rebase), whatever that
  /// time is; nothing is integrated across the step.
  void clock_stepped_back() { rebase_ = odo_.started(); }

  bool started() const { return odo_.started(); }
  const Pose2& pose() const { return odo_.pose(); }
  double distance() const { return odo_.distance(); }  ///< m driven
  std::int64_t time_ns() const { return time_; }       ///< the last time reached
  long reanchored() const { return reanchored_; }      ///< implausible sub-steps met
  std::size_t wheel_count() const { return odo_.wheel_count(); }

 private:
  SkidSteerOdometry odo_;
  std::vector<double> angles_;
  std::int64_t step_ = 0, time_ = 0;
  double max_speed_ = 0.0;
  long reanchored_ = 0;
  bool rebase_ = false;
};

template <class Read>
bool SteppedOdometry::advance_to(std::int64_t t, Read&& read) {
  double yaw = std::numeric_limits<double>::quiet_NaN();
  if (!odo_.started()) {
    if (!read(t, std::span<double>(angles_), yaw)) return false;
    odo_.reset(angles_, Pose2{}, yaw);
    time_ = t;
    return true;
  }
  if (rebase_) {
    if (!read(t, std::span<double>(angles_), yaw) || !odo_.rebase(angles_, yaw)) return false;
    rebase_ = false;
    time_ = t;
    return true;
  }
  if (t <= time_) return t == time_;
  const std::int64_t span = t - time_;
  const std::int64_t n = std::clamp<std::int64_t>((span + step_ - 1) / step_, 1, kMaxSubsteps);
  const std::int64_t from = time_;
  for (std::int64_t k = 1; k <= n; ++k) {
    const auto tk =
        from + static_cast<std::int64_t>(static_cast<double>(span) * static_cast<double>(k) / static_cast<double>(n));
    if (!read(tk, std::span<double>(angles_), yaw)) return false;
    const double max_step = max_speed_ * static_cast<double>(tk - time_) * 1e-9 + 0.05;
    if (!odo_.update(angles_, yaw, max_step)) ++reanchored_;
    time_ = tk;
  }
  return true;
}

}  // namespace regolith::mapping
