#pragma once
// Metric elevation + traversability grid ahead of the rover from SfS heights and direct depth.
//
// Grid conventions follow grid_map (frameworks.md 2.5 / 5): the map lies in the rover body frame
// (REP-103: x forward, y left, z up, metres); GridMap::data[k] is a cv::Mat of CV_32F with
// rows = cells along x and cols = cells along y; cell index (0, 0) is the +x/+y corner and indices
// grow towards -x / -y. Cell (i, j) centre:
//   x = center_x + length_x / 2 - (i + 0.5) * resolution
//   y = center_y + length_y / 2 - (j + 0.5) * resolution
// NaN marks unknown cells in every layer (confidence is 0 there).
//
// Two ways from shading to metric heights (README "Two SfS paths"):
//
// Ground-rectified SfS (compute_from_image, the component default): the grey camera image is
// resampled onto the flat-ground plane (a regular grid of rectify_resolution_m cells aligned with
// the map: rows along -x, columns along -y) through the direct-depth projection, and SfS solves
// that top-down image with the sun expressed in the ground frame. Lambertian brightness depends
// only on the surface normal and the sun, not on the viewer, so the rectified image obeys the
// orthographic model the linear solvers assume, and one height unit is one cell: metres =
// height * rectify_resolution_m. Each cell's height z is then placed on its viewing ray
// (x, y) = flat-ground (x, y) * (1 - z / mount_height), as for the image-frame path.
//
// Image-frame SfS (compute_from_sfs; SfS heights in image pixel units; README "Scale recovery"):
// Lambertian shading senses the slope along the sun's horizontal direction. Linear SfS in the
// image frame returns dH/ds = -(dE/E0) / tan(slant) per image pixel along the light's image
// direction, while the ground truth obeys dh/dl = -(dE/E0) * tan(sun elevation above the ground).
// Hence, per pixel,
//   h [m] = H [px units] * tan(slant) * tan(elevation) * L_g
// with L_g the ground length (m) of a one-pixel image step along the light's image direction,
// from the direct-depth footprints (range footprint for the row component, lateral footprint for
// the column component). The SfS height image is first high-pass filtered (a smooth background of
// detrend_sigma_px, three box passes ~ Gaussian, is subtracted: SfS low frequencies are drift).
// Each pixel's point is then placed on its viewing ray at that height: (x, y) = flat-ground
// (range, lateral) * (1 - z / mount_height).
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/common/grid.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/direct_depth/ground_rectifier.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::traversability {

/// Layers on one grid (regolith/common/grid.hpp: geometry, cell indexing and centres).
struct GridMap : common::GridGeometry {
  GridMap() : common::GridGeometry{0.0, 0.0, 0.0, 0.0, 0.0} {}  ///< unset: size 0 x 0
  std::vector<std::string> layers;
  std::vector<cv::Mat> data;  ///< one CV_32F (size_x rows, size_y cols) per layer
  /// Index of a layer; throws std::out_of_range naming it if absent.
  /// (string_view: no temporary std::string, so lookups do not allocate.)
  std::size_t layer_index(std::string_view name) const;
  const cv::Mat& layer(std::string_view name) const { return data[layer_index(name)]; }
};

/// Copies layer `k` into `out` in grid_map's column-major order (index i + j * size_x) — the
/// layout of grid_map_msgs Float32MultiArray data (dim[0] "column_index" = size_y,
/// dim[1] "row_index" = size_x). `out` must hold size_x * size_y floats (else invalid_argument).
void export_column_major(const GridMap& map, std::size_t k, float* out, std::size_t n);
std::vector<float> export_column_major(const GridMap& map, std::size_t k);

struct TraversabilityParams {
  double resolution_m = 0.05;          ///< m per cell
  double length_x_m = 4.0;             ///< m, extent along x
  double length_y_m = 4.0;             ///< m, extent along y
  double center_x_m = 3.0;             ///< m, map centre ahead of the rover (body frame)
  double center_y_m = 0.0;             ///< m
  double detrend_sigma_px = 30.0;      ///< px, smooth background removed from SfS heights (0 = off)
  double height_gain = 1.0;            ///< extra multiplier on the metric SfS heights (calibration)
  double max_range_m = 10.0;           ///< m, pixels beyond this flat-ground range are ignored
  double critical_slope_rad = 0.35;    ///< rad (20 deg), slope at which traversability_slope = 0
  double critical_step_m = 0.12;       ///< m, step height at which traversability_step = 0
  double critical_roughness_m = 0.05;  ///< m, roughness at which traversability_roughness = 0
  double slope_radius_m = 0.10;        ///< m, neighbourhood for the plane fit (slope, roughness)
  double step_radius_m = 0.10;         ///< m, neighbourhood for max - min height (step)
  double weight_slope = 0.4, weight_step = 0.4, weight_roughness = 0.2;  ///< combination weights
  double full_confidence_points = 4.0;                                   ///< points per cell for confidence 1
  /// false: a frame makes only `elevation` and `confidence`, the traversability layers are NaN (for a
  /// consumer that fuses the elevation and derives its own layers, e.g. the drive-long map)
  bool traversability_layers = true;
  // Ground-rectified SfS (compute_from_image).
  double rectify_resolution_m = 0.02;   ///< m per cell of the ground-rectified image
  double ground_detrend_sigma_m = 0.5;  ///< m, smooth background removed from ground SfS heights (0 = off)
  /// Solver for the rectified image. Default Tsai-Shah marching: no heap allocation per frame.
  /// Two Newton iterations per cell (the solver's default is 3): on the development drives the
  /// map's elevation and detail r are equal or higher on all six (320 and 640 px) with 2, for ~4 %
  /// less CPU in this component (README "Ground solve: Newton iterations").
  sfs::SfsParams ground_sfs = default_ground_sfs();
  static sfs::SfsParams default_ground_sfs() {
    sfs::SfsParams s;
    s.method = sfs::Method::kTsaiShah;
    s.tsai_shah_newton_iterations = 2;
    return s;
  }
  void validate() const;  ///< throws std::invalid_argument naming the field

  /// The map's grid (resolution, lengths, centre) as one GridGeometry, and back.
  common::GridGeometry grid() const { return {resolution_m, length_x_m, length_y_m, center_x_m, center_y_m}; }
  void set_grid(const common::GridGeometry& g) {
    resolution_m = g.resolution_m;
    length_x_m = g.length_x_m;
    length_y_m = g.length_y_m;
    center_x_m = g.center_x_m;
    center_y_m = g.center_y_m;
  }
};

/// Layer names, in GridMap::layers order.
inline const std::vector<std::string>& layer_names() {
  static const std::vector<std::string> names{"elevation",           "traversability_slope", "traversability_roughness",
                                              "traversability_step", "traversability",       "confidence"};
  return names;
}

/// The light of the SfS solver in the camera image frame: the same type (sfs::LightDirection:
/// slant from the line of sight back to the camera, tilt from image +x towards +y).
using ImageLight = sfs::LightDirection;

/// Unit vector towards the sun in the body frame (x forward, y left, z up) for a light given in
/// the image frame of `model`.
cv::Vec3d sun_in_body(const direct_depth::CameraModel& model, const ImageLight& light);
/// Inverse of sun_in_body: the image-frame light of a sun given as a vector in the body frame
/// (any length; slant may exceed 90 deg when the sun is ahead of the camera).
ImageLight image_light(const direct_depth::CameraModel& model, const cv::Vec3d& sun_body);
/// Sun elevation above the ground plane (rad) for a light given in the image frame of `model`.
double sun_elevation(const direct_depth::CameraModel& model, const ImageLight& light);
/// The lowest sun elevation (rad) whose shading compute_from_sfs converts to metric heights; below
/// it every cell is unknown.
inline constexpr double kMinSunElevationRad = 0.01;
/// The same sun in the frame of the ground-rectified image (columns = body -y, rows = body -x,
/// third axis up): slant from the vertical, tilt from the columns towards the rows. NaN slant when
/// the sun is at or below the horizon.
ImageLight ground_light(const direct_depth::CameraModel& model, const ImageLight& light);

/// Scratch of compute_layers: per-row prefix sums for the plane fits, running extremes for the
/// step. Sized by the first call for a grid; later calls on a grid of the same size reuse it
/// without allocating (what a rate-group cycle needs).
struct LayerWorkspace {
  cv::Mat prefix;                           ///< CV_64FC(6): per row, running sums over the columns before j
  cv::Mat zmax, zmin;                       ///< CV_32F: highest / lowest elevation over each cell's step disc
  cv::Mat rowmax, rowmin;                   ///< CV_32F: one half-width's running row extremes
  std::vector<float> block_fwd, block_bwd;  ///< block scans of one row (van Herk / Gil-Werman)
  std::vector<float> block_row;             ///< the row padded, NaN cells as the neutral value
  std::vector<int> half;                    ///< half-width of each row of the plane-fit disc
  std::vector<double> plane_sums;           ///< one grid row's plane-fit sums (10 arrays of its columns)
};

class TraversabilityMapper {
 public:
  /// Pre-allocates every buffer for the camera's image size and the grid.
  TraversabilityMapper(const direct_depth::DirectDepth& depth, const TraversabilityParams& params);

  /// SfS heights (CV_32F, pixel units, up positive, image size) + validity (CV_8U, may be empty)
  /// + the light the SfS used -> metric grid. No heap allocation after the first call when `out`
  /// is reused. A light whose sun is at or below the ground horizon (or a non-finite light) gives
  /// an all-unknown map (NaN, confidence 0): shading carries no usable height information.
  void compute_from_sfs(const cv::Mat& height_px, const cv::Mat& valid, const ImageLight& light, GridMap& out);
  /// Ground-rectified SfS: grey camera image (CV_8UC1, camera size) + the light in the image
  /// frame -> metric grid (see the header comment). No heap allocation after the first call with
  /// a Tsai-Shah ground solver when `out` is reused. Sun at or below the ground horizon, or no
  /// visible ground cell: all-unknown map.
  void compute_from_image(const cv::Mat& gray, const ImageLight& light, GridMap& out);
  /// Rectified grey image of the last compute_from_image (CV_8U; 0 outside the view, filled with
  /// the median inside it for the solver) and its validity (CV_8U 255 = seen by the camera).
  const cv::Mat& rectified_image() const { return rect_gray_; }
  const cv::Mat& rectified_valid() const { return rectifier_->valid(); }
  /// The rectification table (grid, seen cells, per-cell support).
  const direct_depth::GroundRectifier& rectifier() const { return *rectifier_; }
  /// Metric heights (CV_32F m, NaN outside the view) of the last compute_from_image, per
  /// rectified cell (before the cells are moved along their rays).
  const cv::Mat& rectified_heights() const { return rect_height_; }
  /// Light used by the last ground solve (rectified frame).
  const ImageLight& last_ground_light() const { return last_ground_light_; }
  /// Metric height above the flat ground per pixel (CV_32F metres, NaN = unknown).
  void compute_from_metric(const cv::Mat& height_m, const cv::Mat& valid, GridMap& out);
  /// Metric per-pixel heights produced by the last compute_from_sfs (scale recovery output).
  const cv::Mat& metric_heights() const { return metric_; }

 private:
  void check_image(const cv::Mat& m, const cv::Mat& valid, const char* what) const;
  void layers_from_elevation(GridMap& out);
  const direct_depth::DirectDepth& depth_;
  TraversabilityParams p_;
  void smooth(const cv::Mat& src, cv::Mat& dst, double sigma_px);  // 3 box passes, no allocation
  // Places each point (flat-ground x, y; height z) on its viewing ray and accumulates it into the
  // grid with weight w (empty = 1): elevation = weighted mean, confidence = sum w / full.
  void bin_points(const cv::Mat& z, const cv::Mat& valid, const cv::Mat& flat_x, const cv::Mat& flat_y,
                  const cv::Mat& weight, GridMap& out);
  void begin_grid(GridMap& out);   // shapes `out`, clears the accumulators
  void finish_grid(GridMap& out);  // accumulators -> elevation, confidence, layers
  // Ground rectification table (built in the constructor) and the per-frame rectified products.
  std::optional<direct_depth::GroundRectifier> rectifier_;
  cv::Mat rect_mask_, rect_gray_, rect_height_, rect_blur_;
  sfs::ShapeFromShading ground_solver_;
  sfs::SfsResult ground_result_;
  ImageLight last_ground_light_{};
  cv::Mat metric_, blur_, tmp_;
  cv::Mat ground_step_x_, ground_step_y_;  // m per px along columns / rows (footprints)
  std::vector<double> line_;               // smooth(): one row
  std::vector<double> column_sums_;        // smooth(): the running sum of every column
  std::vector<double> plane_;              // smooth(): the image as doubles for the column pass
  cv::Mat sum_, count_;
  LayerWorkspace layer_ws_;  // compute_layers' scratch, reused every frame
  int nx_ = 0, ny_ = 0;
};

/// Computes the traversability layers of an existing elevation grid (for tests and other
/// sources of elevation): `map` must contain an "elevation" layer; the other layers are
/// (re)created. Confidence is left as is if present, else 1 where elevation is finite.
/// Slope and roughness: a least-squares plane over the known cells within slope_radius_m of a
/// cell; step: highest minus lowest known elevation within step_radius_m. The cost per cell grows
/// with the radius in cells, not with its square.
void compute_layers(GridMap& map, const TraversabilityParams& params, LayerWorkspace& workspace);
/// The same with a workspace of its own (allocates on every call).
void compute_layers(GridMap& map, const TraversabilityParams& params);

}  // namespace regolith::traversability
