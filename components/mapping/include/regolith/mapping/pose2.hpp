#pragma once
// Planar poses (SE(2)) with covariance, for odometry in a fixed world frame (REP-105 `odom`:
// x, y in metres, yaw counter-clockwise from +x). Plain structs and Eigen fixed-size matrices:
// nothing here allocates.
#include <cmath>

#include <Eigen/Core>

namespace regolith::mapping {

struct Pose2 {
  double x = 0.0, y = 0.0;  ///< m
  double yaw = 0.0;         ///< rad, counter-clockwise from +x

  bool finite() const { return std::isfinite(x) && std::isfinite(y) && std::isfinite(yaw); }
  /// A point given in this pose's frame, in the parent frame.
  Eigen::Vector2d apply(double px, double py) const {
    const double c = std::cos(yaw), s = std::sin(yaw);
    return {x + c * px - s * py, y + s * px + c * py};
  }
};

using Cov3 = Eigen::Matrix3d;  ///< covariance of (x, y, yaw), m^2 / m rad / rad^2

/// A planar position's 95 % region under its covariance: squared Mahalanobis distance <= this
/// (chi-square, 2 degrees of freedom), the ellipse sqrt(kChi2TwoDof95) = 2.448 standard deviations
/// along the covariance's axes. One constant for the scoring (evaluate), the overview's ellipses and
/// the live page's (runtime/live/web/app.js, which spells it 2.45).
inline constexpr double kChi2TwoDof95 = 5.991;

/// The squared Mahalanobis distance of the error (ex, ey) under the covariance [[cxx, cxy], [cxy,
/// cyy]]; NaN unless that covariance is positive definite.
inline double mahalanobis2(double ex, double ey, double cxx, double cxy, double cyy) {
  const double det = cxx * cyy - cxy * cxy;
  if (!(cxx > 0) || !(cyy > 0) || !(det > 0)) return std::nan("");
  return (cyy * ex * ex - 2 * cxy * ex * ey + cxx * ey * ey) / det;
}

inline double wrap_angle(double a) {
  return std::remainder(a, 2.0 * 3.14159265358979323846);
}

/// a then b (b expressed in a's frame).
inline Pose2 compose(const Pose2& a, const Pose2& b) {
  const Eigen::Vector2d p = a.apply(b.x, b.y);
  return {p.x(), p.y(), wrap_angle(a.yaw + b.yaw)};
}
inline Pose2 inverse(const Pose2& a) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, wrap_angle(-a.yaw)};
}
/// b in a's frame: inverse(a) then b.
inline Pose2 between(const Pose2& a, const Pose2& b) {
  return compose(inverse(a), b);
}

/// Covariance of compose(a, b) for independent a (cov pa) and b (cov pb), first order.
inline Cov3 compose_covariance(const Pose2& a, const Cov3& pa, const Pose2& b, const Cov3& pb) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  Eigen::Matrix3d ja = Eigen::Matrix3d::Identity();
  ja(0, 2) = -s * b.x - c * b.y;
  ja(1, 2) = c * b.x - s * b.y;
  Eigen::Matrix3d jb = Eigen::Matrix3d::Zero();
  jb(0, 0) = c;
  jb(0, 1) = -s;
  jb(1, 0) = s;
  jb(1, 1) = c;
  jb(2, 2) = 1.0;
  return ja * pa * ja.transpose() + jb * pb * jb.transpose();
}

}  // namespace regolith::mapping
