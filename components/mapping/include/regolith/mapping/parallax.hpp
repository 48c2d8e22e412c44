#pragma once
// Heights from motion parallax on the ground plane (plane + parallax, metric).
//
// Two ground-rectified frames (GroundVisualOdometry's keyframe and current frame) aligned by
// their planar motion agree on everything that lies on the ground. A point at height z above
// the ground is seen along its ray where the ray meets the ground, at P = F + (X - F) k with
// k = h / (h - z) (F the camera foot, X the point's ground position, h the camera height). In the
// keyframe's ground frame (its foot at the origin) the current frame therefore sees it displaced
// by d = B (1 - k), B the current foot: every displacement is along the baseline and its length
// gives the height, z = h (1 - 1 / k), k = 1 - d / |B|. So a 1-D search along the baseline per
// cell (sum of squared differences over a window, with the fit's brightness change; sub-step
// parabola) measures a metric height map, independent of albedo and lighting. Each height is
// placed at the point's true ground position X = P / k.
//
// Confidence = curvature of the matching cost at its minimum against the image noise (flat,
// textureless or ambiguous cells get none), so fusion weights well-textured cells.
// The class keeps its own rectification of the keyframe and the current frame (a wider and
// farther window than the odometry's: what is mapped reaches farther than what is tracked).
// All buffers are allocated in the constructor; nothing per frame allocates.
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/common/box.hpp"
#include "regolith/direct_depth/ground_rectifier.hpp"
#include "regolith/mapping/pose2.hpp"

namespace regolith::mapping {

struct ParallaxParams {
  double resolution_m = 0.025;   ///< m, rectified cell
  double min_range_m = 0.5;      ///< m, window from this forward distance ...
  double max_range_m = 5.0;      ///< m, ... to this one
  double half_width_m = 3.5;     ///< m, lateral half-width of the window
  double min_baseline_m = 0.25;  ///< m, shorter baselines are not used (parallax too small)
  double min_height_m = -0.10;   ///< m, search range below ...
  double max_height_m = 0.35;    ///< m, ... and above the ground
  double step_cells = 0.5;       ///< search step along the baseline, in cells
  int window = 2;                ///< half-width of the matching window (cells): 5 x 5
  double noise_dn = 2.0;         ///< grey levels, image noise for the confidence
  double min_confidence = 0.05;  ///< cells below this are unknown
  /// Ambiguous cells (a second cost valley nearly as deep as the best: unique_minimum) are
  /// unknown; 0 = off. As PlaneSweepParams::uniqueness_ratio.
  double uniqueness_ratio = 1.25;
  bool remove_plane = false;  ///< remove each frame's best-fit plane (tilt error); tried: neutral on the dev drives
  void validate() const;      ///< FieldError("mapping.parallax", ...)
};

class GroundParallax {
 public:
  /// `depth` must outlive this object.
  GroundParallax(const direct_depth::DirectDepth& depth, const ParallaxParams& params);

  /// Rectifies an 8-bit grey frame (camera size, else FieldError naming "gray") as the current frame.
  void set_frame(const cv::Mat& gray);
  /// The current frame becomes the keyframe (buffers swapped).
  void promote();
  bool has_keyframe() const { return has_key_; }

  /// Heights of the keyframe's cells from the current frame. cur_in_key: the current camera foot
  /// in the keyframe's foot frame (the VO pose);
  /// gain, bias: current = gain * key + bias; key_tilt / cur_tilt: (pitch, roll) of each camera
  /// against the ground beyond the mount (rad; the VO fit's), whose distortion of the
  /// rectification is undone; height_ratio: the keyframe camera's height above the ground / the
  /// current camera's (the VO fit's). Returns false (nothing computed) when the baseline is
  /// shorter than min_baseline_m.
  bool compute(const Pose2& cur_in_key, double gain, double bias, const cv::Vec2d& key_tilt = {},
               const cv::Vec2d& cur_tilt = {}, double height_ratio = 1.0);
  const direct_depth::RectifiedGrid& grid() const { return grid_; }
  /// The current frame's rectified image (CV_32F) and the cells the camera sees (CV_8U).
  const cv::Mat& current() const { return cur_; }
  const cv::Mat& seen() const { return rect_.valid(); }

  /// Per keyframe cell: height above the ground (m, NaN unknown), its true ground position in the
  /// keyframe's foot frame (m) and the match confidence (0..1).
  const cv::Mat& height() const { return z_; }
  const cv::Mat& x() const { return x_; }
  const cv::Mat& y() const { return y_; }
  const cv::Mat& confidence() const { return conf_; }

 private:
  void remove_plane();
  ParallaxParams p_;
  direct_depth::GroundRectifier rect_;
  direct_depth::RectifiedGrid grid_;
  double h_;
  bool has_key_ = false;
  cv::Mat key_, key_ok_, cur_, cur_ok_, cur_ok4_;
  cv::Mat a_row_, b_row_, a_col_, b_col_;  // per keyframe cell: its current cell = a + d b (+ d^2 c, shared)
  cv::Mat e_, c0_, c1_, c2_, best_, second_, left_, right_, bests_, tmp_;
  cv::Mat z_, x_, y_, conf_;
  std::vector<float> proj_i_, proj_j_;     // one row's current-grid positions for a hypothesis
  std::vector<common::ColumnSpan> spans_;  // per row: first to last + 1 of the keyframe's usable cells (promote)
};

}  // namespace regolith::mapping
