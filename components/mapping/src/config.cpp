#include "regolith/mapping/config.hpp"

#include <algorithm>
#include <string>

#include "regolith/runtime/input_timeout.hpp"

namespace regolith::mapping {

namespace {

// The wheel odometry's noise model (`wheel_*`).
void read_wheel_noise(Params& p, WheelNoise& wheel) {
  wheel.slip = p.get<double>(
      "wheel_slip", wheel.slip,
      {.min = 0.0,
       .max = 0.5,
       .doc = "expected fraction by which the wheels' distance exceeds the ground covered; the fusion shortens "
              "each wheel step by it"});
  wheel.along_fraction =
      p.get<double>("wheel_along_fraction", wheel.along_fraction,
                    {.min = 0.0, .max = 1.0, .doc = "std of the wheel distance, fraction of the step"});
  wheel.lateral_fraction =
      p.get<double>("wheel_lateral_fraction", wheel.lateral_fraction,
                    {.min = 0.0, .max = 1.0, .doc = "std across the heading, fraction of the step"});
  wheel.yaw_per_m_rad = p.get<double>("wheel_yaw_per_m_rad", wheel.yaw_per_m_rad,
                                      {.unit = "rad/m", .min = 0.0, .max = 1.0, .doc = "heading std per m driven"});
  wheel.max_speed_mps =
      p.get<double>("wheel_max_speed_mps", wheel.max_speed_mps,
                    {.unit = "m/s",
                     .min = 0.0,
                     .max = 20.0,
                     .min_exclusive = true,
                     .doc = "faster wheel steps between frames are odometry jumps (ignored, counted)"});
}

// The errors the published pose covariance carries beyond the fit's (`vo_*_bias*`).
void read_consider_terms(Params& p, DriveMapperParams& mp) {
  mp.vo_lateral_bias = p.get<double>(
      "vo_lateral_bias", mp.vo_lateral_bias,
      {.min = 0.0,
       .max = 1.0,
       .doc = "fraction of each keyframe segment's length the visual odometry may run sideways (a tilt error); added "
              "to the published pose covariance only, across the segment (0: the fit's covariance alone)"});
  mp.vo_yaw_bias_rad = p.get<double>(
      "vo_yaw_bias_rad", mp.vo_yaw_bias_rad,
      {.min = 0.0,
       .max = 0.5,
       .doc = "heading error (rad) a keyframe segment's visual odometry may carry; added to the published "
              "pose covariance only, per segment (0: the fit's heading variance alone)"});
}

// How rocks are sighted and ranged, and what of them the VO's tilt refit leaves out.
void read_sighting_settings(Params& p, DriveMapperParams& mp) {
  mp.sighting_tilt_window = p.get<int>(
      "sighting_tilt_window", mp.sighting_tilt_window,
      {.min = 1,
       .max = 64,
       .doc = "rocks are ranged with the median camera tilt (VO) of this many frames, shrunk towards the mount"});
  mp.sighting_tilt_noise_rad = p.get<double>("sighting_tilt_noise_rad", mp.sighting_tilt_noise_rad,
                                             {.unit = "rad",
                                              .min = 0.0,
                                              .max = 0.5,
                                              .doc = "error of one VO tilt: the ranging tilt is shrunk towards the "
                                                     "mount by prior^2 / (prior^2 + this^2) (0: not shrunk)"});
  mp.ground_tilt = p.get<bool>("ground_tilt", mp.ground_tilt,
                               {.doc = "range rocks with the VO tilt refitted without the keyframe's sighted objects "
                                       "(rocks pull the joint fit nose-down)"});
  mp.object_margin_px =
      p.get<int>("object_margin_px", mp.object_margin_px,
                 {.min = 0, .max = 64, .doc = "pixels around each sighted rock's box left out of that refit"});
  mp.sightings.max_width_px = p.get<int>(
      "sighting_max_width_px", mp.sightings.max_width_px,
      {.unit = "px",
       .min = 0,
       .max = 16384,
       .doc = "a wider camera's frames are halved until at most this wide before rocks are sighted (0: full size)"});
  if (mp.sightings.max_width_px > 0 && mp.sightings.max_width_px < 16)
    p.fail("sighting_max_width_px", "must be 0 (full size) or at least 16 px");
}

// The shading cue: its weight and the ground-rectified solve's integration memory and detrend.
void read_shading_settings(Params& p, DriveMapperParams& mp) {
  mp.shading_weight = p.get<double>(
      "shading_weight", mp.shading_weight,
      {.min = 0.0,
       .max = 10.0,
       .doc = "weight of the ground-rectified SfS heights against parallax (x the SfS grid's confidence)"});
  mp.terrain.ground_sfs.tsai_shah_leak_px =
      p.get<double>("shading_leak_px", mp.terrain.ground_sfs.tsai_shah_leak_px,
                    {.unit = "px",
                     .min = 0.0,
                     .max = 1e6,
                     .doc = "memory of the shading cue's Tsai-Shah integration, in rectified cells (0 = none)"});
  mp.terrain.ground_detrend_sigma_m = p.get<double>(
      "shading_detrend_m", mp.terrain.ground_detrend_sigma_m,
      {.unit = "m", .min = 0.0, .max = 100.0, .doc = "smooth background removed from the shading heights"});
}

}  // namespace

DriveMapperParams read_drive_mapper_params(Params& p, DriveMapperParams mp) {
  mp.use_vision = p.get<bool>("use_vision", mp.use_vision, {.doc = "false: wheel odometry only (comparison)"});
  mp.fuse_terrain = p.get<bool>("fuse_terrain", mp.fuse_terrain, {.doc = "false: odometry only, no map"});
  mp.fuse_parallax = p.get<bool>("fuse_parallax", mp.fuse_parallax, {.doc = "heights from motion parallax"});
  mp.fuse_shadows = p.get<bool>("fuse_shadows", mp.fuse_shadows, {.doc = "object heights from cast shadows"});
  mp.fuse_shading = p.get<bool>("fuse_shading", mp.fuse_shading, {.doc = "heights from ground-rectified SfS"});
  mp.fuse_sightings = p.get<bool>("fuse_sightings", mp.fuse_sightings,
                                  {.doc = "rocks sighted in each frame, followed across frames (far rocks)"});
  read_shading_settings(p, mp);
  mp.tracks.enabled = p.get<bool>(
      "track_rocks", mp.tracks.enabled,
      {.doc = "follow sighted rocks across frames and triangulate their ground contact (false: each sighting alone, "
              "ranged on the ground plane)"});
  mp.tracks.report_tilt_sigma_rad = p.get<double>(
      "rock_report_tilt_sigma_rad", mp.tracks.report_tilt_sigma_rad,
      {.unit = "rad",
       .min = 0.0,
       .max = 0.5,
       .doc = "error of the camera's tilt against the far ground shared by a rock's frames: enters the reported rock "
              "covariance (rocks.csv, terrain/world_rocks) only"});
  mp.tracks.ground_sigma_m = p.get<double>(
      "rock_ground_sigma_m", mp.tracks.ground_sigma_m,
      {.unit = "m",
       .min = 0.0,
       .max = 1.0,
       .min_exclusive = true,
       .doc = "std of a rock contact's height about the ground plane under the camera (the triangulation's prior)"});
  const bool min_frames_given = p.has("rock_min_frames");
  mp.map.rock_min_frames = p.get<int>("rock_min_frames", mp.map.rock_min_frames,
                                      {.min = 1,
                                       .max = 1000,
                                       .doc = "frames a tracked rock must be sighted in to be reported (1 with "
                                              "track_rocks: false, where every sighting is "
                                              "a track of one frame)"});
  if (!mp.tracks.enabled) {
    // Untracked, no rock is ever seen in more than one frame: a larger minimum reports nothing.
    if (min_frames_given && mp.map.rock_min_frames > 1)
      p.fail("rock_min_frames",
             "must be 1 with track_rocks: false (every sighting is then a track of one frame, so no rock would be "
             "reported)");
    mp.map.rock_min_frames = 1;
  }
  mp.map.rock_merge_m = p.get<double>(
      "rock_merge_m", mp.map.rock_merge_m,
      {.unit = "m", .min = 0.0, .max = 5.0, .doc = "reported rocks closer than this are one rock (the stronger kept)"});
  read_sighting_settings(p, mp);
  read_consider_terms(p, mp);
  mp.parallax_spacing_m = p.get<double>("parallax_spacing_m", mp.parallax_spacing_m,
                                        {.unit = "m",
                                         .min = 0.0,
                                         .max = 5.0,
                                         .doc = "a parallax search runs when the baseline grew this much since the "
                                                "last (0 = every frame: denser map, ~3x the time)"});
  {
    const std::string mode = p.get<std::string>(
        "parallax", "both",
        {.choices = {"sweep", "rectified", "both"},
         .doc = "parallax heights: plane sweep in the image, search in the ground-rectified frame, or both"});
    mp.parallax_mode = mode == "sweep"       ? ParallaxMode::kSweep
                       : mode == "rectified" ? ParallaxMode::kRectified
                                             : ParallaxMode::kBoth;
  }
  mp.keyframe_distance_m = p.get<double>("keyframe_distance_m", mp.keyframe_distance_m,
                                         {.unit = "m",
                                          .min = 0.0,
                                          .max = 10.0,
                                          .min_exclusive = true,
                                          .doc = "camera motion after which the frame becomes the keyframe"});
  mp.keyframe_yaw_rad = p.get<double>("keyframe_yaw_rad", mp.keyframe_yaw_rad,
                                      {.unit = "rad",
                                       .min = 0.0,
                                       .max = 3.14,
                                       .min_exclusive = true,
                                       .doc = "turn after which the frame becomes the keyframe"});
  mp.vo.attitude_prior_rad = p.get<double>(
      "vo_attitude_prior_rad", mp.vo.attitude_prior_rad,
      {.unit = "rad",
       .min = 0.0,
       .max = 0.5,
       .min_exclusive = true,
       .doc = "std of the camera's tilt against the ground ahead, around the mount (visual odometry prior)"});
  mp.vo.height_change_prior = p.get<double>(
      "vo_height_change_prior", mp.vo.height_change_prior,
      {.min = 0.0,
       .max = 0.5,
       .min_exclusive = true,
       .doc = "std of the change of the camera's height above the ground between keyframe and frame, as a fraction"});
  mp.scale_from_ground = p.get<bool>(
      "vo_scale_from_ground", mp.scale_from_ground,
      {.doc = "the visual odometry's motion length from its fit over the ground without the sighted rocks (their "
              "parallax biases the tilt, which scales the motion); direction and heading from the fit over all"});
  mp.map.resolution_m = p.get<double>("map_resolution_m", mp.map.resolution_m,
                                      {.unit = "m", .min = 0.005, .max = 1.0, .doc = "map cell size"});
  const double length = p.get<double>(
      "map_length_m", mp.map.length_x_m,
      {.unit = "m", .min = 2.0, .max = 200.0, .doc = "side of the square map window that follows the rover"});
  mp.map.length_x_m = mp.map.length_y_m = length;
  mp.map.max_range_m =
      p.get<double>("max_range_m", mp.map.max_range_m,
                    {.unit = "m", .min = 0.5, .max = 50.0, .doc = "terrain farther than this is not fused"});
  mp.map.hazard_height_m = p.get<double>("hazard_height_m", mp.map.hazard_height_m,
                                         {.unit = "m",
                                          .min = 0.0,
                                          .max = 5.0,
                                          .min_exclusive = true,
                                          .doc = "obstacle height the hazard layer is the probability of"});
  mp.map.hazard_relief_weight = p.get<double>(
      "hazard_relief_weight", mp.map.hazard_relief_weight,
      {.min = 0.0, .max = 1.0, .doc = "probability the parallax relief alone gives a cell at full height"});
  mp.map.hazard_evidence_scale =
      p.get<double>("hazard_evidence_scale", mp.map.hazard_evidence_scale,
                    {.min = 0.0,
                     .max = 100.0,
                     .min_exclusive = true,
                     .doc = "summed sighting scores at which a sighted rock's probability is 1 - 1/e"});
  mp.map.fill_radius_m = p.get<double>(
      "map_fill_radius_m", mp.map.fill_radius_m,
      {.unit = "m",
       .min = 0.0,
       .max = 1.0,
       .doc = "holes in the elevation this close to seen cells (behind rocks, between looks) take the smoothed local "
              "ground there, with a lowered confidence and no relief or hazard of their own (0 = off)"});
  mp.map.elevation_median_m = p.get<double>(
      "map_elevation_median_m", mp.map.elevation_median_m,
      {.unit = "m",
       .min = 0.0,
       .max = 0.5,
       .doc = "each known cell's elevation is the median of the known cells within this half-side "
              "(whole cells, at most 3 however fine the map; 0 = off): one mismatched look does not stand out"});
  mp.map.hazard_blur_m = p.get<double>(
      "map_hazard_blur_m", mp.map.hazard_blur_m,
      {.unit = "m",
       .min = 0.0,
       .max = 1.0,
       .doc = "standard deviation of the Gaussian over which the known cells' hazard is averaged (at most 4 "
              "cells however fine the map; 0 = off): where a cue put an obstacle is uncertain by about a cell"});
  read_wheel_noise(p, mp.wheel);
  return mp;
}

OdometrySettings read_odometry_settings(Params& p, const RoverDescription& rover) {
  OdometrySettings o;
  const std::string heading = p.get<std::string>(
      "heading_source", rover.imu.empty() ? "wheels" : "imu",
      {.choices = {"imu", "wheels"},
       .doc = "heading change from the IMU (rover.imu; default when the rover has one) or from the wheel speeds"});
  o.imu_heading = heading == "imu";
  if (o.imu_heading && rover.imu.empty())
    p.fail("heading_source", "`imu` needs an IMU in the rover description (rover.imu: <device>)");
  o.step = from_seconds(p.get<double>("odometry_step_s", 0.05,
                                      {.unit = "s",
                                       .min = 0.001,
                                       .max = 10.0,
                                       .doc = "wheel odometry is integrated in steps of at most this between frames"}));
  return o;
}

TimeNs read_input_timeout(Params& p, double rate_hz) {
  return runtime::read_input_timeout(p, rate_hz, 1.0);
}

}  // namespace regolith::mapping
