#pragma once
// Synthetic Lambertian terrain with exact ground truth (mock camera + test oracle).
//
// World frame (REP-103): x forward, y left, z up, metres. The height field is a grid
// H(row, col) with row 0 / col 0 at the +x/+y corner (grid_map buffer convention):
//   x = x_max - row * resolution,  y = y_max - col * resolution.
// Orthographic top-down rendering maps grid (row, col) to image (row, col); its image frame is
// x = columns = world -y, y = rows = world -x, third axis = world +z (towards the viewer).
// The perspective camera follows regolith::direct_depth conventions (pitch down positive, roll
// about the optical axis, position = optical centre in world coordinates).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::terrain_scene {

struct Rock {
  double x_m = 0.0, y_m = 0.0;  ///< centre (world)
  double radius_x_m = 0.0;      ///< half-axis along world x
  double radius_y_m = 0.0;      ///< half-axis along world y
  double height_m = 0.0;        ///< height of the half-ellipsoid above the local terrain
  double base_z_m = 0.0;        ///< terrain height under the centre before the rock
};

struct Crater {
  double x_m = 0.0, y_m = 0.0;
  double radius_m = 0.0;  ///< rim radius
  double depth_m = 0.0;   ///< bowl depth below the surrounding terrain at the centre
};

struct SceneParams {
  std::uint64_t seed = 1;
  double resolution_m = 0.02;  ///< grid cell size (m)
  double x_min_m = -1.0;       ///< extent along world x (forward)
  double x_max_m = 11.0;
  double y_min_m = -6.0;  ///< extent along world y (left)
  double y_max_m = 6.0;
  double fractal_rms_m = 0.02;             ///< RMS of the fractal component (m); 0 = flat
  double fractal_beta = 3.2;               ///< power-spectrum exponent P(f) ~ f^-beta (2 < beta < 4)
  double fractal_min_wavelength_m = 0.08;  ///< spectrum cut below this wavelength (smoothness)
  int num_rocks = 12;
  double rock_radius_min_m = 0.05, rock_radius_max_m = 0.20;
  double rock_height_ratio_min = 0.4, rock_height_ratio_max = 0.8;  ///< height / mean radius
  int num_craters = 3;
  double crater_radius_min_m = 0.3, crater_radius_max_m = 1.0;
  double crater_depth_ratio = 0.15;  ///< depth / radius
  /// Objects are placed with x in [place_x_min, place_x_max] and |y| <= place_y_abs_max.
  double place_x_min_m = 1.0, place_x_max_m = 8.0, place_y_abs_max_m = 3.0;
  /// Objects whose footprint (rim radius, rock half-axis) comes within `keep_clear_m` of any of
  /// these points are drawn again (up to 100 times, then left out); empty = no constraint (the
  /// random draws are then exactly those of a scene without it).
  std::vector<cv::Point2d> keep_clear_points;
  double keep_clear_m = 0.0;
  void validate() const;
};

/// Direction TOWARDS the sun in the world frame.
struct Sun {
  double azimuth_rad = 0.0;    ///< from world +x towards +y (counter-clockwise seen from above)
  double elevation_rad = 0.7;  ///< above the horizon (> 0)
  cv::Vec3d vector() const;    ///< unit vector towards the sun (world)
};

class Terrain {
 public:
  /// Generates the scene deterministically from params.seed. Throws std::invalid_argument.
  explicit Terrain(const SceneParams& params);
  /// Wraps an existing height field (CV_32F, metres) with the given geometry (no rocks listed).
  Terrain(const cv::Mat& height_m, double resolution_m, double x_max_m, double y_max_m);

  const cv::Mat& height() const { return height_; }  ///< CV_32F, metres
  const std::vector<Rock>& rocks() const { return rocks_; }
  const std::vector<Crater>& craters() const { return craters_; }
  double resolution() const { return res_; }
  double x_max() const { return x_max_; }
  double y_max() const { return y_max_; }
  double x_min() const { return x_max_ - (height_.rows - 1) * res_; }
  double y_min() const { return y_max_ - (height_.cols - 1) * res_; }
  double max_height() const { return h_max_; }
  /// Bilinear height at world (x, y); NaN outside the grid.
  double height_at(double x, double y) const;
  /// Upward unit normal at (x, y) (central differences, bilinear).
  cv::Vec3d normal_at(double x, double y) const;

 private:
  void finish();
  cv::Mat height_;
  std::vector<Rock> rocks_;
  std::vector<Crater> craters_;
  double res_ = 0.0, x_max_ = 0.0, y_max_ = 0.0, h_max_ = 0.0;
};

struct RenderOptions {
  double albedo = 0.8;
  double noise_sigma = 0.0;  ///< std dev of additive Gaussian noise, normalised units (0..1)
  std::uint64_t noise_seed = 7;
  bool vignetting = false;              ///< multiply by V(r) = 1 + a2 r^2 + a4 r^4 + a6 r^6
  double a2 = 0.0, a4 = 0.0, a6 = 0.0;  ///< r normalised to the half-diagonal from the centre
  bool cast_shadows = false;            ///< march towards the sun and darken occluded points (slower)
};

struct OrthoImage {
  cv::Mat image;      ///< CV_32F 0..1
  cv::Mat height_px;  ///< CV_32F true height in pixel units (metres / resolution), UP positive
  double light_slant_rad = 0.0, light_tilt_rad = 0.0;  ///< sun in the image frame (sfs convention)
};

/// Top-down orthographic rendering of the whole grid (one pixel per cell).
OrthoImage render_ortho(const Terrain& t, const Sun& sun, const RenderOptions& opt = {});
/// Same for a synthetic height field in pixel units with a light given in the image frame.
cv::Mat render_ortho_height(const cv::Mat& height_px, double slant_rad, double tilt_rad, const RenderOptions& opt = {});

struct CameraPose {
  double fx = 400.0, fy = 400.0, cx = 319.5, cy = 239.5;  ///< px
  int width = 640, height = 480;                          ///< px
  double x_m = 0.0, y_m = 0.0;                            ///< optical centre in the world
  double height_m = 0.5;                                  ///< optical centre above z = 0 (m)
  double pitch_rad = 0.35;                                ///< down positive
  double roll_rad = 0.0;
  double yaw_rad = 0.0;  ///< heading from +x towards +y
  void validate() const;
  /// Rotation from the optical frame to the world frame.
  cv::Matx33d world_from_optical() const;
};

struct PixelBox {
  int rock_index = -1;
  cv::Rect box;  ///< pixel bounding box of the rock's projected surface
  bool fully_inside = false;
};

struct CameraImage {
  cv::Mat image;                     ///< CV_32F 0..1 (0 where the ray misses the terrain)
  cv::Mat range_m;                   ///< CV_32F forward horizontal distance from the camera (NaN = miss)
  cv::Mat lateral_m;                 ///< CV_32F left offset in the camera's heading frame (NaN = miss)
  cv::Mat hit_z_m;                   ///< CV_32F world z of the hit point (NaN = miss)
  cv::Mat rock_id;                   ///< CV_32S index of the rock seen at the pixel, -1 = none
  std::vector<PixelBox> rock_boxes;  ///< boxes of rocks visible (at least one pixel)
  double light_slant_rad = 0.0, light_tilt_rad = 0.0;  ///< sun in the image frame (sfs convention)
};

/// Ray-cast rendering from a rover camera (pinhole, no distortion).
CameraImage render_camera(const Terrain& t, const CameraPose& cam, const Sun& sun, const RenderOptions& opt = {});

/// Sun direction in the image frame of `cam` in the sfs LightDirection convention:
/// S_img = (s_x, s_y, -s_z) of the optical-frame sun vector. Returns (slant, tilt).
cv::Vec2d camera_light(const CameraPose& cam, const Sun& sun);

/// Sun in the orthographic image frame.
cv::Vec2d ortho_light(const Sun& sun);

/// Camera image converted to CV_8U (clamped, rounded).
cv::Mat to_u8(const cv::Mat& image01);

}  // namespace regolith::terrain_scene
