#include "regolith/mapping/wheel_odometry.hpp"

#include <cmath>
#include <string>

#include "regolith/core/error.hpp"

namespace regolith::mapping {

SkidSteerOdometry::SkidSteerOdometry(const std::vector<OdometryWheel>& wheels)
    : wheels_(wheels), last_(wheels.size(), 0.0) {
  double yl = 0.0, yr = 0.0;
  int nl = 0, nr = 0;
  for (std::size_t i = 0; i < wheels_.size(); ++i) {
    const OdometryWheel& w = wheels_[i];
    if (!std::isfinite(w.y_m) || !(w.radius_m > 0.0) || !std::isfinite(w.radius_m))
      throw FieldError("mapping.odometry", "wheels[" + std::to_string(i) + "]", "needs a finite y_m and radius_m > 0");
    if (w.y_m > 0.0) yl += w.y_m, ++nl;
    if (w.y_m < 0.0) yr += w.y_m, ++nr;
  }
  if (nl == 0 || nr == 0)
    throw FieldError("mapping.odometry", "wheels",
                     "needs at least one wheel on each side (y_m > 0 left, y_m < 0 right); got " + std::to_string(nl) +
                         " left, " + std::to_string(nr) + " right");
  track_m_ = yl / nl - yr / nr;
}

void SkidSteerOdometry::reset(std::span<const double> angles, const Pose2& pose, double yaw) {
  for (std::size_t i = 0; i < wheels_.size() && i < angles.size(); ++i) last_[i] = angles[i];
  pose_ = pose;
  last_yaw_ = yaw;
  distance_ = 0.0;
  started_ = true;
}

bool SkidSteerOdometry::rebase(std::span<const double> angles, double yaw) {
  if (angles.size() < wheels_.size()) return false;
  for (std::size_t i = 0; i < wheels_.size(); ++i)
    if (!std::isfinite(angles[i])) return false;
  for (std::size_t i = 0; i < wheels_.size() && i < angles.size(); ++i) last_[i] = angles[i];
  last_yaw_ = yaw;
  return true;
}

bool SkidSteerOdometry::update(std::span<const double> angles, double yaw, double max_step_m) {
  if (angles.size() < wheels_.size()) return false;
  for (std::size_t i = 0; i < wheels_.size(); ++i)
    if (!std::isfinite(angles[i])) return false;
  if (!started_) {
    reset(angles, pose_, yaw);
    return true;
  }
  for (std::size_t i = 0; i < wheels_.size(); ++i)
    if (std::abs(wheels_[i].radius_m * (angles[i] - last_[i])) > max_step_m) {
      rebase(angles, yaw);  // re-anchor where the rover is (the distance driven stays)
      return false;
    }
  double sl = 0.0, sr = 0.0;
  int nl = 0, nr = 0;
  for (std::size_t i = 0; i < wheels_.size(); ++i) {
    const double d = wheels_[i].radius_m * (angles[i] - last_[i]);
    if (wheels_[i].y_m > 0.0) sl += d, ++nl;
    if (wheels_[i].y_m < 0.0) sr += d, ++nr;
    last_[i] = angles[i];
  }
  sl /= nl;
  sr /= nr;
  const double ds = 0.5 * (sl + sr);
  double dyaw = (sr - sl) / track_m_;
  if (std::isfinite(yaw)) {
    if (std::isfinite(last_yaw_)) dyaw = wrap_angle(yaw - last_yaw_);
    last_yaw_ = yaw;
  }
  // Along the arc of curvature dyaw / ds.
  Pose2 step{ds, 0.0, dyaw};
  if (std::abs(dyaw) > 1e-9) {
    const double r = ds / dyaw;
    step.x = r * std::sin(dyaw);
    step.y = r * (1.0 - std::cos(dyaw));
  }
  pose_ = compose(pose_, step);
  distance_ += std::abs(ds);
  return true;
}

SteppedOdometry::SteppedOdometry(const std::vector<OdometryWheel>& wheels, std::int64_t step_ns, double max_speed_mps)
    : odo_(wheels), angles_(wheels.size(), 0.0), step_(step_ns), max_speed_(max_speed_mps) {
  if (step_ns <= 0) throw FieldError("mapping.odometry", "step", "must be > 0 ns");
  if (!(max_speed_mps > 0.0)) throw FieldError("mapping.odometry", "max_speed_mps", "must be > 0");
}

}  // namespace regolith::mapping
