#pragma once
// Ground-plane visual odometry from one navigation camera (direct, dense, robust).
//
// Each frame is resampled onto the flat ground in front of the camera (direct_depth's
// GroundRectifier: a top-down image in metres). Lambertian ground looks the same from every pose,
// so two rectified frames differ, on the ground, only by the planar motion of the camera between
// them (x, y, yaw) and by exposure. The motion is found by dense Gauss-Newton alignment of the
// current frame to a keyframe over a two-level pyramid, with an affine brightness term and Tukey
// weights on robustly scaled residuals: what stands above the ground (rocks, their far sides) and
// what clips (saturation, black) does not fit a ground motion and is weighted out. The camera's
// known height and pitch make the result metric; no feature detector, no scale ambiguity.
//
// Frames: the camera's ground frame of direct_depth (origin on the ground below the camera, x the
// camera's heading, y left). A measurement is the pose of the current frame's camera foot in the
// keyframe's camera foot frame, with a covariance from the fit (Gauss-Newton information scaled
// by the residual variance and `covariance_inflation` for correlated neighbouring cells).
// Everything is allocated in the constructor: track() does not touch the heap.
#include <array>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/direct_depth/ground_rectifier.hpp"
#include "regolith/mapping/pose2.hpp"

namespace regolith::mapping {

struct GroundVoParams {
  double resolution_m = 0.02;         ///< m, finest rectified cell
  double min_range_m = 0.5;           ///< m, ground used from this forward distance ...
  double max_range_m = 3.0;           ///< m, ... to this one (farther cells are blurred by the view)
  double half_width_m = 2.0;          ///< m, lateral half-width of the rectified window
  int levels = 2;                     ///< pyramid levels (each halves the resolution)
  int iterations = 15;                ///< Gauss-Newton iterations per level (stops earlier on convergence)
  int stride = 2;                     ///< template cells used every `stride` cells (finest level)
  double min_support = 0.2;           ///< image pixels per cell below which a cell is too blurred to use
  double tukey_c = 4.685;             ///< Tukey constant in robust standard deviations
  int min_points = 300;               ///< inlier cells needed for a measurement
  double max_sigma_m = 0.01;          ///< m, a fit whose translation std exceeds this is kUncertain (not used)
  double max_correction_m = 0.15;     ///< m, farther from the prior than this = diverged
  double max_correction_rad = 0.15;   ///< rad
  double covariance_inflation = 8.0;  ///< x the Gauss-Newton covariance (neighbouring cells are correlated)
  double scale_uncertainty = 0.05;    ///< std of the motion's scale beyond the fit (height / tilt model error)
  double attitude_prior_rad = 0.015;  ///< rad, std of a camera's tilt against the ground around the mount
  double height_change_prior = 0.01;  ///< std of the ratio of the two cameras' heights above the ground, minus 1
  int min_ground_points = 300;        ///< object-free keyframe cells needed to refit the tilt without objects
  /// Throws FieldError("mapping.vo", field, ...) naming the bad field.
  void validate() const;
};

/// Why a frame's fit gave no motion (kOk: it did). kUncertain: the fit settled on enough ground,
/// but the motion it fixes is looser than max_sigma_m (typically the keyframe's ground seen far
/// and oblique, late in a keyframe's reach); the frame then becomes the keyframe.
enum class VoStatus { kOk, kNoKeyframe, kTooFewPoints, kNoTexture, kUncertain, kDiverged };
const char* to_string(VoStatus s);

struct VoMeasurement {
  VoStatus status = VoStatus::kNoKeyframe;
  bool ok() const { return status == VoStatus::kOk; }
  Pose2 pose;                                      ///< current camera foot in the keyframe's camera foot frame
  Cov3 covariance = Cov3::Identity();              ///< of `pose`
  int points = 0;                                  ///< template cells compared at the finest level
  int inliers = 0;                                 ///< of those, with a non-zero robust weight
  int frame_cells = 0;                             ///< usable (textured, unclipped) cells of the current frame
  double residual_dn = 0.0;                        ///< robust residual standard deviation (grey levels)
  double gain = 1.0, bias_dn = 0.0;                ///< brightness change current = gain * keyframe + bias
  double pitch_rad = 0.0, roll_rad = 0.0;          ///< the current camera's tilt against the ground, beyond the mount
  double height_ratio = 1.0;                       ///< keyframe camera's height above the ground / the current camera's
  double key_pitch_rad = 0.0, key_roll_rad = 0.0;  ///< the keyframe camera's, estimated in the same fit
  /// The current camera's tilt fitted again from the same solution without the keyframe cells
  /// marked by exclude() (objects standing on the ground): `ground_tilt` says whether that refit
  /// ran (the keyframe had an exclusion mask and min_ground_points cells outside it); otherwise
  /// these equal pitch_rad / roll_rad.
  bool ground_tilt = false;
  double ground_pitch_rad = 0.0, ground_roll_rad = 0.0;
  /// The motion's length (keyframe metres) in the refit without the objects (0 when it did not
  /// run); `pose` is the joint fit's, consistent with its tilts (what the parallax searches need).
  double ground_distance_m = 0.0;
};

class GroundVisualOdometry {
 public:
  /// Builds the rectification table and every buffer. `depth` must outlive this object.
  GroundVisualOdometry(const direct_depth::DirectDepth& depth, const GroundVoParams& params);

  const GroundVoParams& params() const { return p_; }
  /// Forgets the keyframe: the next tracked frame can only be promoted.
  void reset() { has_keyframe_ = false; }
  bool has_keyframe() const { return has_keyframe_; }

  /// Aligns an 8-bit grey frame (the camera's size, else FieldError) to the keyframe, starting
  /// from `prior` (this frame's camera foot in the keyframe's frame, e.g. from wheel odometry).
  /// Without a keyframe: status kNoKeyframe. No heap allocation.
  const VoMeasurement& track(const cv::Mat& gray, const Pose2& prior);
  /// Marks what stands on the ground in the last tracked frame: `objects` is an 8-bit image of
  /// the camera's size (else FieldError naming "objects"), non-zero = an object's pixel (a rock,
  /// its shadow). Once that frame is the keyframe, track() fits the tilt a second time without
  /// the cells that show them (VoMeasurement::ground_pitch_rad). Why: a rock's image covers the
  /// rectified ground from its foot to well beyond it (its top is seen where its ray would meet
  /// the ground), and that smear moves faster than the ground as the camera advances; the joint
  /// fit explains part of it with a nose-down tilt. Marks are forgotten when the next frame is
  /// tracked. No heap allocation.
  void exclude(const cv::Mat& objects);
  /// The last tracked frame becomes the keyframe (buffers are swapped, not copied).
  void promote_last();
  /// The last tracked frame's rectified image at the finest level (CV_32F grey, 0 unseen) and
  /// its usable cells (CV_8U, non-zero = seen, unclipped); the same for the keyframe.
  const cv::Mat& rectified() const { return cur_.levels[0].img; }
  const cv::Mat& rectified_usable() const { return cur_.levels[0].usable; }
  const cv::Mat& keyframe_rectified() const { return key_.levels[0].img; }
  const cv::Mat& keyframe_usable() const { return key_.levels[0].usable; }
  /// Usable (textured, unclipped) cells of the last tracked frame.
  int last_frame_cells() const { return frame_cells_; }
  /// The finest rectified grid (camera foot frame).
  const direct_depth::RectifiedGrid& grid() const { return cur_.levels[0].grid; }

 private:
  struct Level {
    direct_depth::RectifiedGrid grid;
    cv::Mat img, usable, gx, gy, support;  // CV_32F; usable CV_8U; gx, gy per metre along body x, y
  };
  struct Frame {
    std::vector<Level> levels;
  };
  struct Point {
    float x, y, value, weight;
  };
  void build_frame(const cv::Mat& gray, Frame& f);
  // One level of Gauss-Newton; returns false when the normal equations are singular.
  // Unknowns: the planar transform taking keyframe ground points into the current frame, both
  // cameras' tilts against the ground (pitch, roll beyond the mount) and the brightness change.
  enum Param { kX, kY, kYaw, kKeyPitch, kKeyRoll, kPitch, kRoll, kGain, kBias, kScale, kParams };
  using Params = std::array<double, kParams>;
  // One level over the template `pts`; `record` keeps the fit's statistics (the finest level of
  // the motion fit).
  bool align_level(int level, const std::vector<Point>& pts, Params& theta, bool record);
  // align_level's parts: residuals, Jacobians and the residual histogram at `theta` (returns the
  // points in view); the Tukey cost with the tilt and height priors at the first iteration's
  // scale; one Gauss-Newton step with those priors (kFailed when it cannot be solved).
  struct CostScale {
    double cut = 0.0, lam = 0.0, lam_h = 0.0;
  };
  enum class Step { kFailed, kMoved, kConverged };
  int linearise(const Level& level, const std::vector<Point>& pts, const Params& theta);
  double robust_cost(const std::vector<Point>& pts, const Params& theta, const CostScale& ref) const;
  Step gauss_newton_step(const std::vector<Point>& pts, double cut, double sigma, int n, Params& theta, bool record);

  GroundVoParams p_;
  direct_depth::GroundRectifier rectifier_;
  Frame key_, cur_;
  bool has_keyframe_ = false;
  cv::Mat raw_, tmp_;
  std::vector<std::vector<Point>> templates_;  // per level, from the keyframe (capacity fixed)
  std::vector<Point> ground_template_;         // finest level without the excluded cells (empty: no refit)
  cv::Mat excluded_cur_, excluded_key_;        // CV_8U on the finest grid, non-zero = excluded
  // last_.ground_*: the tilt refitted from the motion fit's solution `th` over ground_template_.
  void refit_ground_tilt(const Params& th);
  bool cur_excluded_ = false, key_excluded_ = false;
  std::vector<float> residuals_;
  std::vector<std::array<float, kParams>> jacobians_;
  std::array<int, 512> histogram_{};
  VoMeasurement last_;
  // Fit statistics of the last align_level on the finest level.
  Eigen::Matrix<double, kParams, kParams> info_ = Eigen::Matrix<double, kParams, kParams>::Zero();
  double sigma2_ = 0.0;
  int used_ = 0, inl_ = 0;
  int frame_cells_ = 0;
  double mount_height_ = 0.0;
};

}  // namespace regolith::mapping
