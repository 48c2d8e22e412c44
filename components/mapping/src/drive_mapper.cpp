#include "regolith/mapping/drive_mapper.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/LU>

#include "regolith/core/error.hpp"

namespace regolith::mapping {
namespace {

[[noreturn]] void fail(const char* owner, const std::string& field, const std::string& why) {
  throw FieldError(owner, field, why);
}

// The wheel step of the body, seen by the camera foot: mount^-1 * step * mount, with covariance.
void foot_step(const Pose2& mount, const Pose2& step, const Cov3& q, Pose2& out, Cov3& out_cov) {
  const Pose2 sm = compose(step, mount);
  const Cov3 c1 = compose_covariance(step, q, mount, Cov3::Zero());
  const Pose2 im = inverse(mount);
  out = compose(im, sm);
  out_cov = compose_covariance(im, Cov3::Zero(), sm, c1);
}

}  // namespace

void WheelNoise::validate() const {
  auto nonneg = [](double v, const char* f) {
    if (!std::isfinite(v) || v < 0) fail("mapping.wheel", f, "must be >= 0");
  };
  if (!std::isfinite(slip) || slip < 0 || slip > 0.5) fail("mapping.wheel", "slip", "must be in [0, 0.5]");
  nonneg(along_fraction, "along_fraction");
  nonneg(lateral_fraction, "lateral_fraction");
  nonneg(yaw_per_m_rad, "yaw_per_m_rad");
  nonneg(yaw_fraction, "yaw_fraction");
  for (auto [v, f] : {std::pair{floor_m, "floor_m"},
                      {floor_rad, "floor_rad"},
                      {max_step_m, "max_step_m"},
                      {max_step_rad, "max_step_rad"},
                      {max_speed_mps, "max_speed_mps"},
                      {max_yaw_rate_rps, "max_yaw_rate_rps"}})
    if (!std::isfinite(v) || v <= 0) fail("mapping.wheel", f, "must be > 0");
}

Cov3 WheelNoise::covariance(const Pose2& step) const {
  const double d = std::hypot(step.x, step.y);
  const double sa = along_fraction * d + floor_m, sl = lateral_fraction * d + floor_m;
  const double sy = yaw_per_m_rad * d + yaw_fraction * std::abs(step.yaw) + floor_rad;
  // Along / across the direction of travel, rotated into the step's frame.
  const double h = d > 1e-9 ? std::atan2(step.y, step.x) : 0.0, c = std::cos(h), s = std::sin(h);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  const Eigen::Matrix2d t = r * Eigen::Vector2d(sa * sa, sl * sl).asDiagonal() * r.transpose();
  Cov3 q = Cov3::Zero();
  q.topLeftCorner<2, 2>() = t;
  q(2, 2) = sy * sy;
  return q;
}

bool WheelNoise::plausible(const Pose2& step, double dt_s) const {
  const bool timed = std::isfinite(dt_s) && dt_s > 0;
  const double max_m = timed ? std::max(max_step_m, max_speed_mps * dt_s) : max_step_m;
  const double max_rad = timed ? std::max(max_step_rad, max_yaw_rate_rps * dt_s) : max_step_rad;
  return step.finite() && std::hypot(step.x, step.y) <= max_m && std::abs(step.yaw) <= max_rad;
}

void DriveMapperParams::validate() const {
  vo.validate();
  wheel.validate();
  map.validate();
  terrain.validate();
  parallax.validate();
  sweep.validate();
  sightings.validate();
  tracks.validate();
  shadow.validate();
  if (sighting_tilt_window < 1 || sighting_tilt_window > 64) fail("mapping", "sighting_tilt_window", "must be 1..64");
  if (!std::isfinite(sighting_tilt_noise_rad) || sighting_tilt_noise_rad < 0)
    fail("mapping", "sighting_tilt_noise_rad", "must be >= 0");
  if (object_margin_px < 0 || object_margin_px > 64) fail("mapping", "object_margin_px", "must be 0..64");
  if (!std::isfinite(keyframe_distance_m) || keyframe_distance_m <= 0)
    fail("mapping", "keyframe_distance_m", "must be > 0");
  if (!std::isfinite(keyframe_yaw_rad) || keyframe_yaw_rad <= 0) fail("mapping", "keyframe_yaw_rad", "must be > 0");
  if (!std::isfinite(parallax_spacing_m) || parallax_spacing_m < 0)
    fail("mapping", "parallax_spacing_m", "must be >= 0");
  if (!(keyframe_min_inlier_fraction >= 0 && keyframe_min_inlier_fraction <= 1))
    fail("mapping", "keyframe_min_inlier_fraction", "must be in [0, 1]");
  if (!(vo_lateral_bias >= 0 && vo_lateral_bias <= 1)) fail("mapping", "vo_lateral_bias", "must be in [0, 1]");
  if (!(vo_yaw_bias_rad >= 0 && vo_yaw_bias_rad <= 0.5)) fail("mapping", "vo_yaw_bias_rad", "must be in [0, 0.5]");
}

namespace {
// The pixel parameters are given for a 320 px wide frame (RockSightingParams::kReferenceWidthPx):
// the camera's own are these grown with its width, so that another resolution sees the same rocks.
DriveMapperParams for_camera(const DriveMapperParams& params, const direct_depth::CameraModel& camera) {
  params.validate();
  DriveMapperParams p = params;
  p.sightings = params.sightings.scaled_to_width(camera.width);
  const double s = static_cast<double>(camera.width) / RockSightingParams::kReferenceWidthPx;
  p.object_margin_px = std::clamp(static_cast<int>(std::lround(params.object_margin_px * s)), 0, 64);
  return p;
}
}  // namespace

DriveMapper::DriveMapper(const direct_depth::CameraModel& camera, const CameraMount& mount, const cv::Vec3d& sun_world,
                         const DriveMapperParams& params, const cv::Point2d& map_center)
    : p_(for_camera(params, camera)),
      depth_(camera),
      mount_(mount),
      sun_world_(sun_world),
      vo_(depth_, p_.vo),
      terrain_mapper_(depth_, p_.terrain),
      parallax_(depth_, p_.parallax),
      sweep_(depth_, p_.sweep),
      sightings_(depth_, p_.sightings),
      tracker_(p_.tracks, p_.sightings.max_sightings),
      shadow_(parallax_.grid(), p_.shadow),
      map_(p_.map, map_center.x, map_center.y) {
  objects_.create(camera.height, camera.width, CV_8U);
  if (!std::isfinite(mount.x_m) || !std::isfinite(mount.y_m) || !std::isfinite(mount.yaw_rad))
    fail("mapping", "mount", "must be finite");
  if (!(cv::norm(sun_world) > 0) || !std::isfinite(cv::norm(sun_world)))
    fail("mapping", "sun", "must be a finite non-zero vector");
}

cv::Vec2d DriveMapper::sighting_tilt() const {
  // Median of the last VO tilts (each axis), shrunk towards the mount's attitude: one fit's tilt
  // is poorly observed and pulled by rocks; the rover's tilt against the ground changes slowly.
  const int n = std::min(n_tilts_, p_.sighting_tilt_window);
  if (n == 0) return {};
  const double prior2 = p_.vo.attitude_prior_rad * p_.vo.attitude_prior_rad;
  const double noise2 = p_.sighting_tilt_noise_rad * p_.sighting_tilt_noise_rad;
  const double k = prior2 + noise2 > 0 ? prior2 / (prior2 + noise2) : 1.0;
  cv::Vec2d out;
  std::array<double, kMaxTiltWindow> v{};
  for (int axis = 0; axis < 2; ++axis) {
    for (int i = 0; i < n; ++i)
      v[static_cast<std::size_t>(i)] = tilts_[static_cast<std::size_t>((n_tilts_ - 1 - i) % kMaxTiltWindow)][axis];
    std::nth_element(v.begin(), v.begin() + n / 2, v.begin() + n);
    double med = v[static_cast<std::size_t>(n / 2)];
    if (n % 2 == 0) med = 0.5 * (med + *std::max_element(v.begin(), v.begin() + n / 2));
    out[axis] = k * med;
  }
  return out;
}

const FrameReport& DriveMapper::add_frame(const cv::Mat& gray, const Pose2& wheel, double t_s) {
  const double prev_t = last_t_;
  if (std::isfinite(t_s)) last_t_ = t_s;
  begin_report(wheel);
  ++counters_.frames;
  const Located here = started_ ? track(gray, wheel, t_s - prev_t) : start(gray, wheel);
  // Terrain of this frame, placed with the corrected pose (never with a frame vision rejects as
  // unusable: black or saturated frames carry no shading).
  const bool usable = here.foot.finite() && report_.vo != VoStatus::kTooFewPoints;
  const double c = std::cos(here.foot.yaw), s = std::sin(here.foot.yaw);
  const cv::Vec3d sun_foot(sun_world_[0] * c + sun_world_[1] * s, -sun_world_[0] * s + sun_world_[1] * c,
                           sun_world_[2]);
  if (use_parallax() && p_.fuse_shadows && usable) fuse_shadows(here.foot, sun_foot);
  // Rocks sighted in this frame, before it can become the keyframe: what they cover is left out
  // of the VO's tilt refit against it (GroundVisualOdometry::exclude).
  const bool sight = p_.fuse_terrain && p_.fuse_sightings && usable;
  if (sight) sight_rocks(gray);
  if (here.promote) promote(here);
  if (sight) track_rocks(here.foot);
  if (p_.fuse_terrain && p_.fuse_shading && here.foot.finite()) fuse_shading(gray, here.foot, sun_foot);
  counters_.parallax_frames += report_.parallax ? 1 : 0;
  counters_.shadow_frames += report_.shadow_casters > 0 ? 1 : 0;
  counters_.rock_sightings += report_.rock_sightings;
  counters_.rock_tracks = tracker_.opened();
  map_.recenter(report_.pose.x, report_.pose.y, p_.map.max_range_m + 1.0);
  return report_;
}

void DriveMapper::begin_report(const Pose2& wheel) {
  report_.wheel_pose = wheel;
  report_.odometry_jump = false;
  report_.keyframe = false;
  report_.cells_fused = 0;
  report_.parallax = false;
  report_.shadow_casters = 0;
  report_.rock_sightings = 0;
  report_.rock_tracks = 0;
}

DriveMapper::Located DriveMapper::start(const cv::Mat& gray, const Pose2& wheel) {
  report_.odometry_jump = !wheel.finite();
  report_.pose = wheel.finite() ? wheel : Pose2{};
  report_.covariance = Cov3::Zero();
  last_wheel_ = report_.pose;
  const VoMeasurement& m = vo_.track(gray, Pose2{});
  report_.vo = m.status;
  report_.vo_inliers = 0;
  tilt_ = cv::Vec2d();
  if (use_parallax()) parallax_.set_frame(gray);
  if (use_sweep()) sweep_.set_frame(gray);
  started_ = true;
  return {.foot = compose(report_.pose, mount_.pose()), .covariance = Cov3::Zero(), .promote = true};
}

DriveMapper::Located DriveMapper::track(const cv::Mat& gray, const Pose2& wheel, double dt_s) {
  const Pose2 mount = mount_.pose();
  Cov3 q;
  const Pose2 step = wheel_step(wheel, dt_s, q);
  Pose2 fs;
  Cov3 fq;
  foot_step(mount, step, q, fs, fq);
  // Wheel prediction of this frame's camera foot in the keyframe frame.
  const Pose2 pred = compose(wheel_since_key_, fs);
  const Cov3 pred_cov = compose_covariance(wheel_since_key_, wheel_since_key_cov_, fs, fq);
  const VoMeasurement& m = vo_.track(gray, pred);
  if (use_parallax()) parallax_.set_frame(gray);
  if (use_sweep()) sweep_.set_frame(gray);
  report_.vo = m.status;
  report_.vo_inliers = m.inliers;
  // Rocks are ranged with the tilt fitted without the keyframe's objects (the motion fit's
  // where there was no refit).
  tilt_ = m.ok() ? cv::Vec2d(m.ground_pitch_rad, m.ground_roll_rad) : cv::Vec2d();
  if (m.ok()) tilts_[static_cast<std::size_t>(n_tilts_++ % kMaxTiltWindow)] = tilt_;
  fuse_motion(m, pred, pred_cov);
  fuse_parallax(m);
  const Pose2& rel = wheel_since_key_;
  Located here{.foot = compose(key_foot_, rel),
               .covariance = compose_covariance(key_foot_, key_cov_, rel, wheel_since_key_cov_)};
  report_.pose = compose(here.foot, inverse(mount));
  report_.covariance = compose_covariance(here.foot, here.covariance, inverse(mount), Cov3::Zero());
  report_.covariance += consider_ + segment_consider();
  // A new keyframe when the view has moved on, the fit thinned out, or vision failed on a
  // frame that itself is good (a black or saturated frame never becomes the keyframe).
  const bool frame_good = m.frame_cells >= 4 * p_.vo.min_points;
  const bool moved = std::hypot(rel.x, rel.y) > p_.keyframe_distance_m || std::abs(rel.yaw) > p_.keyframe_yaw_rad;
  const bool thin = m.ok() && m.points > 0 &&
                    static_cast<double>(m.inliers) < p_.keyframe_min_inlier_fraction * static_cast<double>(m.points);
  here.promote = frame_good && (moved || thin || !m.ok());
  return here;
}

Pose2 DriveMapper::wheel_step(const Pose2& wheel, double dt_s, Cov3& q) {
  // Wheel step in the body frame; an implausible one is ignored (and counted).
  Pose2 step = wheel.finite() ? between(last_wheel_, wheel) : Pose2{};
  if (!wheel.finite() || !p_.wheel.plausible(step, dt_s)) {
    report_.odometry_jump = true;
    ++counters_.odometry_jumps;
    step = Pose2{};
    q = Cov3::Zero();
    q(0, 0) = q(1, 1) = p_.wheel.max_step_m * p_.wheel.max_step_m;
    q(2, 2) = p_.wheel.max_step_rad * p_.wheel.max_step_rad;
  } else {
    step = p_.wheel.ground_step(step);
    q = p_.wheel.covariance(step);
  }
  if (wheel.finite()) last_wheel_ = wheel;
  return step;
}

void DriveMapper::fuse_motion(const VoMeasurement& m, const Pose2& pred, const Cov3& pred_cov) {
  Pose2 rel = pred;
  Cov3 rel_cov = pred_cov;
  if (m.ok() && p_.use_vision) {
    // The motion's length from the fit without the objects (scale_from_ground), where it ran.
    Pose2 vo = m.pose;
    const double joint = std::hypot(vo.x, vo.y);
    if (p_.scale_from_ground && m.ground_tilt && m.ground_distance_m > 0 && joint > 1e-9) {
      const double k = m.ground_distance_m / joint;
      vo.x *= k;
      vo.y *= k;
    }
    // Information-weighted mean of the two relative estimates (linearised at the VO pose).
    const Eigen::Matrix3d iv = m.covariance.inverse(), iw = pred_cov.inverse();
    const Eigen::Matrix3d s = (iv + iw).inverse();
    const Eigen::Vector3d d(pred.x - vo.x, pred.y - vo.y, wrap_angle(pred.yaw - vo.yaw));
    const Eigen::Vector3d corr = s * (iw * d);
    if (corr.allFinite() && s.allFinite()) {
      rel = {vo.x + corr[0], vo.y + corr[1], wrap_angle(vo.yaw + corr[2])};
      rel_cov = s;
    }
    ++counters_.vo_ok;
  } else if (p_.use_vision) {
    ++counters_.vo_failed;
    if (m.status == VoStatus::kUncertain) ++counters_.vo_uncertain;
  }
  wheel_since_key_ = rel;
  wheel_since_key_cov_ = rel_cov;
  segment_vision_ = segment_vision_ || (m.ok() && p_.use_vision);
}

Cov3 DriveMapper::segment_consider() const {
  // Across the segment's direction (keyframe foot to here, world frame), std = bias x its length;
  // heading: the segment's yaw bias.
  Cov3 c = Cov3::Zero();
  if (!segment_vision_) return c;
  c(2, 2) = p_.vo_yaw_bias_rad * p_.vo_yaw_bias_rad;
  const Pose2& rel = wheel_since_key_;
  const double length = std::hypot(rel.x, rel.y);
  if (!(length > 0)) return c;
  const double heading = key_foot_.yaw + std::atan2(rel.y, rel.x);
  const double nx = -std::sin(heading), ny = std::cos(heading), v = std::pow(p_.vo_lateral_bias * length, 2);
  c(0, 0) = v * nx * nx;
  c(0, 1) = c(1, 0) = v * nx * ny;
  c(1, 1) = v * ny * ny;
  return c;
}

void DriveMapper::fuse_parallax(const VoMeasurement& m) {
  // Heights from the parallax against the keyframe, placed with the keyframe's corrected pose.
  const double base = std::hypot(m.pose.x, m.pose.y);
  if (!m.ok() || base - last_parallax_base_ < p_.parallax_spacing_m) return;
  last_parallax_base_ = base;
  const cv::Vec2d key_tilt(m.key_pitch_rad, m.key_roll_rad), tilt(m.pitch_rad, m.roll_rad);
  if (use_sweep() && sweep_.compute(m.pose, m.gain, m.bias_dn, key_tilt, tilt, m.height_ratio)) {
    report_.cells_fused += map_.fuse_points(sweep_.x(), sweep_.y(), sweep_.height(), sweep_.confidence(), key_foot_);
    report_.parallax = true;
  }
  if (use_parallax() && p_.parallax_mode != ParallaxMode::kSweep &&
      parallax_.compute(m.pose, m.gain, m.bias_dn, key_tilt, tilt, m.height_ratio)) {
    report_.cells_fused +=
        map_.fuse_points(parallax_.x(), parallax_.y(), parallax_.height(), parallax_.confidence(), key_foot_);
    report_.parallax = true;
  }
}

void DriveMapper::fuse_shadows(const Pose2& foot, const cv::Vec3d& sun_foot) {
  report_.shadow_casters = shadow_.compute(parallax_.current(), parallax_.seen(), sun_foot);
  if (report_.shadow_casters > 0) map_.fuse_casters(shadow_.x(), shadow_.y(), shadow_.height(), shadow_.weight(), foot);
}

void DriveMapper::sight_rocks(const cv::Mat& gray) {
  report_.rock_sightings = sightings_.compute(gray, sighting_tilt());
  if (p_.ground_tilt) {
    sightings_.object_mask(objects_, p_.object_margin_px);
    vo_.exclude(objects_);
  }
}

void DriveMapper::promote(const Located& here) {
  consider_ += segment_consider();  // the closed segment's bias is the pose's for good
  segment_vision_ = false;
  vo_.promote_last();
  if (use_parallax()) parallax_.promote();
  if (use_sweep()) sweep_.promote();
  last_parallax_base_ = 0.0;
  key_foot_ = here.foot;
  key_cov_ = here.covariance;
  wheel_since_key_ = Pose2{};
  wheel_since_key_cov_ = Cov3::Zero();
  report_.keyframe = true;
  ++counters_.keyframes;
}

void DriveMapper::track_rocks(const Pose2& foot) {
  tracker_.update(sightings_.table(), foot, depth_.model().mount_height_m);
  map_.fuse_rock_tracks(tracker_.closed(), tracker_.closed_count(), tracker_.table(), tracker_.count());
  report_.rock_tracks = tracker_.count();
}

void DriveMapper::fuse_shading(const cv::Mat& gray, const Pose2& foot, const cv::Vec3d& sun_foot) {
  terrain_mapper_.compute_from_image(gray, traversability::image_light(depth_.model(), sun_foot), terrain_);
  if (vo_.rectified().data && report_.vo != VoStatus::kTooFewPoints)
    report_.cells_fused += map_.fuse(terrain_, foot, p_.shading_weight);
}

}  // namespace regolith::mapping
