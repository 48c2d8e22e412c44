#pragma once
// The drive-long terrain map: wheel + visual odometry fused into a corrected pose, and each
// frame's terrain (ground-rectified SfS via traversability) fused into a world-frame map.
//
// Per frame: the wheel odometry increment predicts the pose; ground visual odometry measures the
// camera's motion since the keyframe; the two relative estimates are combined by their
// information (inverse covariances), so the wheels carry the motion when vision cannot (too
// little ground, no texture, black or saturated frame, divergence) and the pose covariance then
// grows with the wheel model. The map is placed with the corrected pose.
// Framework-free: the `terrain_map` component and `regolith map` both drive this class.
#include <array>
#include <limits>
#include <optional>

#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/mapping/ground_vo.hpp"
#include "regolith/mapping/parallax.hpp"
#include "regolith/mapping/plane_sweep.hpp"
#include "regolith/mapping/pose2.hpp"
#include "regolith/mapping/rock_sightings.hpp"
#include "regolith/mapping/rock_tracker.hpp"
#include "regolith/mapping/shadow.hpp"
#include "regolith/mapping/world_map.hpp"
#include "regolith/traversability/traversability.hpp"

namespace regolith::mapping {

/// Wheel odometry error model: standard deviations per step, grown with the distance driven.
struct WheelNoise {
  /// Expected slip: the fraction by which the wheels' distance exceeds the ground covered (wheels
  /// on loose soil turn more than they roll). The fusion shortens each wheel step by it before
  /// predicting with it; the wheel-only odometry published beside the fused one stays raw.
  double slip = 0.005;
  double along_fraction = 0.02;    ///< std of the distance, fraction of the step
  double lateral_fraction = 0.01;  ///< std across the heading, fraction of the step
  double yaw_per_m_rad = 0.01;     ///< rad of yaw std per m driven
  double yaw_fraction = 0.05;      ///< std of the yaw change, fraction of it
  double floor_m = 0.001;          ///< m, std floor per step
  double floor_rad = 0.0005;       ///< rad, std floor per step
  double max_step_m = 0.5;         ///< m, a larger step between two frames is an odometry jump ...
  double max_step_rad = 0.5;       ///< rad
  double max_speed_mps = 0.3;      ///< m/s ... unless the frames are far apart in time (a gap): speed x dt
  double max_yaw_rate_rps = 0.3;   ///< rad/s
  void validate() const;           ///< FieldError("mapping.wheel", ...)
  Cov3 covariance(const Pose2& step) const;
  /// False for an odometry jump: a non-finite step, or one longer or turning more than the limits
  /// above allow in `dt_s` (NaN or <= 0: no time, the per-step limits alone).
  bool plausible(const Pose2& step, double dt_s) const;
  /// `step` (body frame) with its translation shortened by the expected slip; yaw unchanged.
  Pose2 ground_step(const Pose2& step) const { return {step.x * (1.0 - slip), step.y * (1.0 - slip), step.yaw}; }
};

/// Parallax heights: the plane sweep in the image (accurate near), the search in the
/// ground-rectified frame (denser, coarser), or both fused.
enum class ParallaxMode { kSweep, kRectified, kBoth };

struct DriveMapperParams {
  GroundVoParams vo;
  WheelNoise wheel;
  WorldMapParams map;
  ParallaxParams parallax;
  PlaneSweepParams sweep;
  RockSightingParams sightings;
  RockTrackerParams tracks;
  ShadowParams shadow;
  traversability::TraversabilityParams terrain = default_terrain();  ///< per-frame terrain grid (body frame)
  int sighting_tilt_window = 9;  ///< frames: rocks are ranged with the median of the last this many VO tilts ...
  double sighting_tilt_noise_rad =
      0.015;                ///< rad ... shrunk towards the mount by vo.attitude_prior_rad^2 / (prior^2 + this^2)
                            ///< (one VO tilt is off by 0.01-0.05 rad on rock-strewn ground: worse than none)
  bool ground_tilt = true;  ///< rocks are ranged with the VO tilt refitted without the keyframe's sighted objects
  /// The VO motion fused with the wheels takes its length from that refit (direction and heading
  /// from the joint fit): the objects' parallax biases the joint fit's tilt, and the tilt scales
  /// the rectified ground, so the motion's length.
  bool scale_from_ground = true;
  int object_margin_px = 3;  ///< px around each sighted rock's image box left out of that refit
  /// Fraction of each keyframe segment's length by which the visual odometry may run sideways
  /// unseen by its own fit: a tilt against the ground that differs between keyframe and frame
  /// (roll 0.02 rad under a 0.6-0.7 m camera) turns the motion's direction by about as much, the same
  /// way over the whole segment. At 0.01 the published covariance covers the error: squared
  /// Mahalanobis distance 1.5 / 1.0 / 0.8 on the dev drives, every frame inside the 95 % ellipse
  /// (without: 6.9 / 9.4 / 1.7, 44 / 36 / 100 %); rendered drives 1.3, 97 % (without: 9.2, 39 %).
  /// Enters the published covariance only, as a consider term (std = this x the segment's length,
  /// across its direction; segments independent), never the fusion's weights: there it cost the
  /// pose accuracy (components/mapping/README.md, "Is the pose covariance honest?"). 0 = the fit's
  /// covariance alone.
  double vo_lateral_bias = 0.01;
  /// rad: the heading error a keyframe segment's VO may carry (the same tilt error, or the ground
  /// points' spread, turns the relative yaw), unseen by the fit; like vo_lateral_bias a consider
  /// term of the published covariance only: its square per segment in which vision carried the
  /// motion, closed segments adding up. Heading error / published sigma, rms (honest: 1), dev drives
  /// 0 / 1 / 2: 1.55 / 1.37 / 1.11 without, 0.96 / 0.76 / 0.80 at 0.0015 (0.001: 1.18 / 0.97 / 0.93;
  /// 0.002: 0.79 / 0.62 / 0.70); the tests' rendered drives (seeds 11-18) 5.9 -> 2.3 (they would need
  /// 0.004). 0 = the fit's heading variance alone.
  double vo_yaw_bias_rad = 0.0015;
  double keyframe_distance_m = 0.70;          ///< m of camera motion after which the current frame becomes the keyframe
  double keyframe_yaw_rad = 0.12;             ///< rad
  double keyframe_min_inlier_fraction = 0.5;  ///< a fit with fewer inliers also makes a new keyframe
  bool use_vision = true;                     ///< false: wheel odometry only (for comparison)
  bool fuse_terrain = true;                   ///< false: odometry only (no terrain in the map)
  bool fuse_parallax = true;                  ///< heights from motion parallax against the keyframe
  ParallaxMode parallax_mode = ParallaxMode::kBoth;  ///< which parallax search(es) give heights
  double parallax_spacing_m = 0.0;  ///< m, a parallax search runs when the baseline grew this much since the last one
                                    ///< (0: every frame; the terrain_map component uses 0.15 for its time budget)
  bool fuse_shadows = true;     ///< object heights from cast shadows (needs fuse_parallax: its rectification); on the
                                ///< dev drives hazard AUC +0.014 / -0.004 / +0.015, no rock gained or lost
  bool fuse_sightings = true;   ///< rocks sighted in each frame, followed across frames (RockTracker; far rocks)
  bool fuse_shading = true;     ///< heights from ground-rectified SfS (weak from a grazing view, but it fills the
                                ///< cells parallax cannot reach; ~5 ms per frame, on in the terrain_map component
                                ///< too since 2026-12-06)
  double shading_weight = 0.1;  ///< x the SfS grid's confidence when fused (components/mapping/README.md: the sweep)
  static traversability::TraversabilityParams default_terrain() {
    traversability::TraversabilityParams t;
    t.center_x_m = 2.75;
    t.length_x_m = 4.5;
    t.length_y_m = 6.0;
    t.resolution_m = 0.04;
    t.max_range_m = 5.0;
    t.traversability_layers = false;  // the map fuses the elevation and makes its own layers
    return t;
  }
  void validate() const;
};

/// Where the camera sits on the rover: its ground frame (camera foot, heading) in the body frame.
struct CameraMount {
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;
  Pose2 pose() const { return {x_m, y_m, yaw_rad}; }
};

struct FrameReport {
  VoStatus vo = VoStatus::kNoKeyframe;
  bool odometry_jump = false;  ///< the wheel step was implausible and was ignored
  bool keyframe = false;       ///< this frame became the keyframe
  int vo_inliers = 0;
  int cells_fused = 0;
  bool parallax = false;   ///< heights from parallax were fused
  int shadow_casters = 0;  ///< objects measured from their shadows in this frame
  int rock_sightings = 0;  ///< rocks sighted and ranged in this frame
  int rock_tracks = 0;     ///< rocks followed across frames (live tracks) after this frame
  Pose2 pose;              ///< corrected rover pose (world)
  Cov3 covariance;         ///< of `pose`
  Pose2 wheel_pose;        ///< wheel odometry as given
};

struct DriveCounters {
  long frames = 0, vo_ok = 0, vo_failed = 0, odometry_jumps = 0, keyframes = 0;
  /// Of vo_failed (frames whose visual motion was not used): those whose fit settled but fixed the
  /// motion too loosely (VoStatus::kUncertain: the keyframe's reach ended; not a loss of tracking).
  long vo_uncertain = 0;
  long parallax_frames = 0;  ///< frames whose parallax heights were fused (none while the rover stands still)
  long shadow_frames = 0;    ///< frames with cast-shadow casters fused
  long rock_sightings = 0;   ///< rocks sighted and fused, over all frames
  long rock_tracks = 0;      ///< rock tracks opened (one per rock when tracking holds), over all frames
};

class DriveMapper {
 public:
  /// `camera` is copied; `sun_world` = unit vector towards the sun in the world frame (x, y, z up).
  /// The map window is centred on `map_center` (world).
  DriveMapper(const direct_depth::CameraModel& camera, const CameraMount& mount, const cv::Vec3d& sun_world,
              const DriveMapperParams& params, const cv::Point2d& map_center);

  /// One frame: 8-bit grey image (camera size, else FieldError naming "gray") and the wheel
  /// odometry reading at its capture time (world frame; the first reading sets the origin pose).
  /// t_s: capture time (s; NaN = unknown): a gap between frames allows a proportionally longer
  /// wheel step before it counts as a jump. A non-finite reading is treated as an odometry jump.
  /// No heap allocation once running.
  const FrameReport& add_frame(const cv::Mat& gray, const Pose2& wheel_odometry,
                               double t_s = std::numeric_limits<double>::quiet_NaN());

  const Pose2& pose() const { return report_.pose; }
  const Cov3& covariance() const { return report_.covariance; }
  const DriveCounters& counters() const { return counters_; }
  WorldMap& map() { return map_; }
  const WorldMap& map() const { return map_; }
  const traversability::GridMap& last_terrain() const { return terrain_; }
  const GroundVisualOdometry& vo() const { return vo_; }

 private:
  /// Where this frame's camera foot is (world) and whether the frame becomes the keyframe.
  struct Located {
    Pose2 foot;
    Cov3 covariance = Cov3::Zero();
    bool promote = false;
  };
  // add_frame's stages, in the order it runs them.
  void begin_report(const Pose2& wheel);
  Located start(const cv::Mat& gray, const Pose2& wheel);               // the first frame: the origin keyframe
  Located track(const cv::Mat& gray, const Pose2& wheel, double dt_s);  // wheels + VO + parallax
  Pose2 wheel_step(const Pose2& wheel, double dt_s, Cov3& q);           // body-frame step; jumps ignored
  void fuse_motion(const VoMeasurement& m, const Pose2& pred, const Cov3& pred_cov);
  void fuse_parallax(const VoMeasurement& m);
  void fuse_shadows(const Pose2& foot, const cv::Vec3d& sun_foot);
  void sight_rocks(const cv::Mat& gray);
  void promote(const Located& here);
  void track_rocks(const Pose2& foot);
  void fuse_shading(const cv::Mat& gray, const Pose2& foot, const cv::Vec3d& sun_foot);
  bool use_parallax() const { return p_.fuse_terrain && p_.fuse_parallax; }
  bool use_sweep() const { return use_parallax() && p_.parallax_mode != ParallaxMode::kRectified; }
  DriveMapperParams p_;
  direct_depth::DirectDepth depth_;
  CameraMount mount_;
  cv::Vec3d sun_world_;
  GroundVisualOdometry vo_;
  traversability::TraversabilityMapper terrain_mapper_;
  GroundParallax parallax_;
  PlaneSweep sweep_;
  RockSightings sightings_;
  RockTracker tracker_;
  ShadowCue shadow_;
  traversability::GridMap terrain_;
  WorldMap map_;
  FrameReport report_;
  DriveCounters counters_;
  bool started_ = false;
  Pose2 last_wheel_;
  double last_t_ = std::numeric_limits<double>::quiet_NaN();
  double last_parallax_base_ = 0.0;  // baseline of the last parallax search against this keyframe
  cv::Vec2d tilt_;                   // this frame's camera tilt against the ground (VO; 0 without)
  cv::Mat objects_;                  // CV_8U camera-size: this frame's sighted objects (VO exclusion)
  cv::Vec2d sighting_tilt() const;   // the filtered tilt rocks are ranged with
  static constexpr int kMaxTiltWindow = 64;
  std::array<cv::Vec2d, kMaxTiltWindow> tilts_{};  // the last VO tilts (ring)
  int n_tilts_ = 0;
  Pose2 key_foot_;                // keyframe camera foot in the world
  Cov3 key_cov_ = Cov3::Zero();   // its covariance
  Cov3 consider_ = Cov3::Zero();  // world position covariance of the closed segments' lateral VO bias
  bool segment_vision_ = false;   // the VO carried motion in the segment since the keyframe
  /// The lateral VO bias of the segment since the keyframe (world frame, position block).
  Cov3 segment_consider() const;
  Pose2 wheel_since_key_;  // wheel-predicted camera foot in the keyframe frame
  Cov3 wheel_since_key_cov_ = Cov3::Zero();
};

}  // namespace regolith::mapping
