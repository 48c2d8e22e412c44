#pragma once
// Synthetic wheel-track scene with ground truth for the retrospective soil stiffness estimator.
//
// Scene frame (REP-103 style): origin on the ground directly below the rear camera, x along the
// camera's horizontal viewing direction (back along the rover's tracks), y to the left, z up.
// The camera sits at (0, 0, mount_height) and is pitched down by `pitch_rad`.
// Each track is a straight rut along x whose depth is the static sinkage of a rigid wheel
// (Bekker closed form, W = b k sqrt(D) z^((2n+1)/2) (3-n)/3) for the track's load and the soil
// (k, n); the cross-section is a flat floor of the wheel width with walls at `wall_slope_rad`.
// The height field is shaded as a Lambertian surface under a distant sun and ray-cast from the
// camera (pinhole, no lens distortion), with a multiplicative albedo texture and sensor noise.
// Cast shadows and inter-reflections are not modelled (sun elevation above the wall slope keeps
// every wall lit).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::track_scene {

struct CameraModel {
  int width = 640;              ///< [px]
  int height = 480;             ///< [px]
  double fx = 500.0;            ///< [px]
  double fy = 500.0;            ///< [px]
  double cx = 319.5;            ///< [px]
  double cy = 239.5;            ///< [px]
  double mount_height_m = 1.2;  ///< optical centre above the ground [m]
  double pitch_rad = 0.61;      ///< depression of the optical axis below horizontal [rad]
};

/// Sun direction in the scene frame: azimuth from +x towards +y, elevation above the ground.
struct Sun {
  double azimuth_rad = 1.5708;    ///< default: sun on the left of the viewing direction
  double elevation_rad = 0.7854;  ///< 45 deg
};

struct Track {
  double lateral_m = 0.0;  ///< y of the rut centre [m]
  double load_n = 60.0;    ///< vertical wheel load that made this rut [N]
};

struct TrackSceneParams {
  CameraModel camera;
  Sun sun;
  double k = 5.0e5;                ///< Bernstein-Goriatchkin modulus [N/m^(n+2)]
  double n = 1.0;                  ///< sinkage exponent [-]
  double wheel_width_m = 0.10;     ///< b [m]
  double wheel_diameter_m = 0.30;  ///< D [m]
  std::vector<Track> tracks{{0.40, 60.0}, {-0.40, 60.0}};
  double wall_slope_rad = 0.61;  ///< rut wall angle from horizontal (~35 deg, angle of repose)
  /// Along-track soil variability: k(x) = k (1 + a sin(2 pi x / wavelength)).
  double k_variation = 0.0;  ///< a [-], |a| < 0.9
  double variation_wavelength_m = 1.5;
  double x_min_m = 0.3;  ///< height-field extent along x [m]
  double x_max_m = 10.0;
  double y_half_width_m = 4.0;      ///< height field spans y in [-w, w] [m]
  double grid_res_m = 0.004;        ///< height-field cell [m]
  double edge_smoothing_m = 0.006;  ///< Gaussian sigma rounding the rut edges [m]
  double albedo = 0.5;              ///< mean albedo [-]
  double albedo_texture = 0.03;     ///< relative std of the albedo texture [-]
  double texture_scale_m = 0.01;    ///< correlation length of the texture [m]
  double gain_dn = 400.0;           ///< DN per unit radiance (albedo * cos(incidence)) [DN]
  double noise_dn = 1.0;            ///< sensor noise std [DN]
  std::uint32_t seed = 1;

  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

struct TrackTruth {
  double lateral_m = 0.0;
  double load_n = 0.0;
  std::vector<double> x_m;        ///< along-track positions of the profile samples [m]
  std::vector<double> sinkage_m;  ///< true sinkage at x_m [m]
  double mean_sinkage_m = 0.0;    ///< nominal sinkage for k (no variation) [m]
  /// True sinkage at along-track position x [m] (interpolated).
  double sinkage_at(double x) const;
};

struct TrackScene {
  cv::Mat image;   ///< CV_8U rear-camera frame
  cv::Mat height;  ///< CV_32F height field [m]: row i <-> x = x0 + i*res, col j <-> y = y0 + j*res
  double x0_m = 0.0, y0_m = 0.0, res_m = 0.0;
  TrackSceneParams params;
  std::vector<TrackTruth> truth;
  /// Height at (x, y) [m], bilinear; 0 outside the field.
  double height_at(double x, double y) const;
};

/// Static sinkage by the Bekker closed form (independent implementation for the mock).
double rut_depth(double k, double n, double load_n, double width_m, double diameter_m);

/// Generates the scene. Deterministic for a given seed.
TrackScene generate_track_scene(const TrackSceneParams& p);

/// Projects a scene point into the image; false if behind the camera.
bool project(const CameraModel& cam, double x, double y, double z, double& u, double& v);

}  // namespace regolith::track_scene
