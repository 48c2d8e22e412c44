#pragma once
// Direct depth: flat-ground ranging from a calibrated, pitched camera (thesis 3.3, spec 3).
//
// Frames: image (c = column, r = row, pixel centres at integer coordinates); camera optical frame
// (x right, y down, z forward); rover body frame per REP-103 (x forward, y LEFT, z up) with its
// origin on the ground directly below the camera. Results:
//   range   = forward horizontal ground distance Y (m, body +x) of the ray's ground intersection
//   lateral = body +y (m, positive to the LEFT; the spec's X is positive to the right = -lateral)
// Pitch alpha > 0 tilts the optical axis DOWN below the horizontal; roll phi rotates the camera
// about its optical axis (positive = clockwise image rotation seen by the camera, i.e. about +z
// optical). With roll = 0 and no distortion the results equal the canonical formulas:
//   beta = atan((r - cy)/fy), Y = h / tan(alpha + beta), valid iff alpha + beta > 0,
//   lateral = -u h / (v cos(alpha) + sin(alpha)), u = (c - cx)/fx, v = (r - cy)/fy.
#include <optional>

#include <opencv2/core.hpp>

namespace regolith::direct_depth {

struct CameraModel {
  double fx = 0.0, fy = 0.0;                                ///< px, focal lengths
  double cx = 0.0, cy = 0.0;                                ///< px, principal point
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;  ///< OpenCV distortion coefficients
  int width = 0, height = 0;                                ///< px, image size
  double mount_height_m = 0.0;                              ///< m, optical centre above the (flat) ground
  double pitch_rad = 0.0;                                   ///< rad, optical axis below the horizontal (down positive)
  double roll_rad = 0.0;                                    ///< rad, about the optical axis
  /// Seconds-free sanity check; throws std::invalid_argument naming the field.
  void validate() const;
  bool has_distortion() const { return k1 != 0.0 || k2 != 0.0 || p1 != 0.0 || p2 != 0.0 || k3 != 0.0; }
};

struct GroundPoint {
  double range_m = 0.0;    ///< m, forward (body +x)
  double lateral_m = 0.0;  ///< m, body +y (left positive)
  double slant_m = 0.0;    ///< m, distance from the optical centre along the ray
  bool valid = false;      ///< false when the ray is at or above the horizon
};

struct ObjectSize {
  double width_m = 0.0;   ///< lateral extent of the bottom edge
  double height_m = 0.0;  ///< height of the box's top ray above the ground at the estimated depth
  double range_m = 0.0;   ///< forward range of the bottom edge (ground contact)
  bool valid = false;
};

class DirectDepth {
 public:
  /// Whether the per-pixel maps are made: kNone for closed-form queries only (ground, project,
  /// object_size, ...), e.g. a reader checking a configuration, where a 16384 x 16384 camera's
  /// maps would be ~10 GB; the map accessors then return empty matrices.
  enum class Maps { kPrecompute, kNone };

  /// Validates the model and precomputes range / lateral / valid maps for the whole image
  /// (the only allocation; per-pixel queries afterwards are lookups or closed-form).
  explicit DirectDepth(const CameraModel& model, Maps maps = Maps::kPrecompute);

  const CameraModel& model() const { return model_; }

  /// Undistorted normalised coordinates (u, v) of a pixel (x right, y down, z = 1).
  cv::Point2d normalised(double c, double r) const;
  /// Ground intersection for an arbitrary (sub)pixel, computed in closed form.
  GroundPoint ground(double c, double r) const;
  /// Angle of the optical ray through row r (column cx) below the horizon: alpha + beta (rad).
  double depression(double r) const;

  /// Precomputed maps (CV_32F, NaN where invalid; CV_8U 255 = valid). Size = model width x height
  /// (empty when constructed with Maps::kNone, as are the footprint maps).
  const cv::Mat& range_map() const { return range_; }
  const cv::Mat& lateral_map() const { return lateral_; }
  const cv::Mat& valid_map() const { return valid_; }
  /// Metric ground footprint of one pixel: |d lateral / d column| and |d range / d row| (m/px,
  /// NaN where invalid). Used by traversability for scale recovery.
  const cv::Mat& footprint_lateral_map() const { return foot_lat_; }
  const cv::Mat& footprint_range_map() const { return foot_rng_; }
  /// Rotation from the optical frame (x right, y down, z along the axis) to the body frame
  /// (x forward, y left, z up) for the mount's pitch and roll.
  const cv::Matx33d& body_from_optical() const { return r_body_from_optical_; }
  /// Row of the horizon at column cx (may be outside the image); rows below it are valid.
  double horizon_row() const;

  /// Size of an object whose bounding box (pixels, inclusive-exclusive cv::Rect) touches the
  /// ground with its bottom edge. assumed_depth_m: horizontal depth of the object behind its
  /// ground contact point; the top ray is evaluated at range_bottom + assumed_depth_m / 2.
  /// 0 = a vertical face at the contact range (spec formula h - Y_b tan(alpha + beta_top)).
  /// Negative = assume a round footprint (depth = measured width).
  ObjectSize object_size(const cv::Rect& box, double assumed_depth_m = -1.0) const;

  /// Range error (m) caused by `rows` pixels of row error at row r: exact finite difference
  /// |Y(r + rows) - Y(r)| (NaN when either is invalid).
  double range_error_exact(double r, double rows = 1.0) const;
  /// Linearised: dY = (h^2 + Y^2) / h * d(beta), d(beta) = rows * fy / (fy^2 + (r - cy)^2).
  double range_error_linear(double r, double rows = 1.0) const;

  /// Pixel (c, r) that sees ground point (range, lateral) (distortion applied); nullopt if the
  /// point is behind the camera.
  std::optional<cv::Point2d> project(double range_m, double lateral_m, double z_m = 0.0) const;

 private:
  CameraModel model_;
  cv::Matx33d r_body_from_optical_;  // rotation optical -> body (pitch, roll)
  cv::Mat range_, lateral_, valid_, foot_lat_, foot_rng_;
};

/// Canonical formula (spec 8): Y = h / tan(alpha + beta). Returns NaN when alpha + beta <= 0.
double canonical_range(double h, double alpha, double beta);

}  // namespace regolith::direct_depth
