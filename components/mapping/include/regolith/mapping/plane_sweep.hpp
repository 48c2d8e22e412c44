#pragma once
// Heights from motion parallax by a plane sweep in the keyframe image (metric, per pixel).
//
// Two frames of one camera whose relative motion is known (GroundVisualOdometry: the current
// camera foot in the keyframe's foot frame, and each camera's tilt against the ground) see a
// point at height z above the ground along the keyframe pixel's ray at
//   P(z) = C + (1 - z / h) t_g d,   d = the pixel's ray, t_g its ground intersection (P(0)).
// Projected into the current frame, P(z) moves along the epipolar line; the height whose
// projection looks like the keyframe pixel (sum of squared differences over a window, with the
// fit's brightness change current = gain * key + bias; sub-step parabola) is the pixel's height.
// The sweep works at the camera's own resolution, so far ground (where a pixel covers
// decimetres) is matched as finely as the image allows and no finer: each image row gets its own
// height step, the one that moves its pixels by `step_px` in the current frame.
//
// Per keyframe pixel: height (m above the keyframe camera's ground plane, NaN unknown), the
// point's ground position in the keyframe's foot frame (x forward, y left, m) and a confidence
// (curvature of the cost at its minimum against the image noise, lowered by a poor best match).
// Flat, textureless, occluded or ambiguous pixels (a second cost valley nearly as deep as the
// best: PlaneSweepParams::uniqueness_ratio) get none.
//
// Images with lens distortion are undistorted into pinhole images first (maps built once). A
// camera wider than `max_width_px` is swept at a working scale of 2x2 (4x4, ...) block means:
// the outputs then have the working size (width / scale x height / scale).
// All buffers are allocated in the constructor: set_frame / promote / compute do not allocate.
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/mapping/pose2.hpp"

namespace regolith::mapping {

struct PlaneSweepParams {
  double min_range_m = 0.8;        ///< m, keyframe pixels whose ground point is nearer are not swept
  double max_range_m = 5.0;        ///< m, ... or farther
  double min_baseline_m = 0.20;    ///< m, shorter camera motions are not used (parallax too small)
  double min_height_m = -0.06;     ///< m, sweep from this height ...
  double max_height_m = 0.40;      ///< m, ... to this one above the ground
  double step_px = 1.0;            ///< px, largest image motion between two height hypotheses
  int max_steps = 32;              ///< hypotheses per pixel at most (near rows get coarser steps)
  int max_width_px = 400;          ///< wider cameras are swept on 2x2 (4x4, ...) pixel block means
  int window = 2;                  ///< half-width of the matching window (px): 5 x 5
  double noise_dn = 2.0;           ///< grey levels, image noise for the confidence
  double reference_step_m = 0.02;  ///< m, height step at which a match keeps its full confidence; coarser steps (far
                                   ///< rows, short baselines) scale it by (reference / step)^2
  double min_confidence = 0.001;   ///< pixels below this are unknown
  /// A pixel whose second-deepest cost valley (another bracketed minimum) is below this times the
  /// best plus one noise variance per window sample is ambiguous and unknown (Lowe's ratio test:
  /// best / second > 0.8). 0 = off. Repetitive texture along the epipolar line otherwise lifts a
  /// flat ground 0.2-0.4 m (the mocked rover's rippled near field: see components/mapping/README.md).
  double uniqueness_ratio = 1.25;
  void validate() const;  ///< FieldError("mapping.sweep", ...)
};

class PlaneSweep {
 public:
  /// `depth` must outlive this object (its camera model and mount rotation are used).
  PlaneSweep(const direct_depth::DirectDepth& depth, const PlaneSweepParams& params);

  /// Takes an 8-bit grey frame (camera size, else FieldError naming "gray") as the current frame.
  void set_frame(const cv::Mat& gray);
  /// The current frame becomes the keyframe (buffers swapped).
  void promote();
  bool has_keyframe() const { return has_key_; }

  /// Heights of the keyframe's pixels from the current frame. cur_in_key: the current camera
  /// foot in the keyframe's foot frame; gain, bias: current = gain * key + bias; key_tilt,
  /// cur_tilt: (pitch, roll) of each camera against the ground beyond the mount (rad);
  /// height_ratio: the keyframe camera's height above the ground / the current camera's (the VO
  /// fit's; the keyframe's is the mount height). Returns false (nothing computed) when the
  /// baseline is shorter than min_baseline_m.
  bool compute(const Pose2& cur_in_key, double gain, double bias, const cv::Vec2d& key_tilt = {},
               const cv::Vec2d& cur_tilt = {}, double height_ratio = 1.0);

  /// Per keyframe pixel (CV_32F, working size: camera size / scale()): height above the ground (m, NaN unknown), ground
  /// position in the keyframe's foot frame (m) and confidence (0..1).
  const cv::Mat& height() const { return z_; }
  const cv::Mat& x() const { return x_; }
  const cv::Mat& y() const { return y_; }
  const cv::Mat& confidence() const { return conf_; }
  /// Hypotheses evaluated by the last compute() (pixels x steps), for benchmarks.
  long samples() const { return samples_; }
  /// Working scale (1 = camera pixels).
  int scale() const { return scale_; }

 private:
  /// One compute's hypotheses: a keyframe point at w (height h (1 - w)) is seen by the current
  /// camera at o0 + w o1 (o1 per pixel in ox_/oy_/oz_, its x and y times fx and fy), w from w_lo in
  /// `steps` steps of row_step_.
  struct Sweep {
    cv::Vec3d o0;
    double w_lo = 0.0;
    int steps = 0;
  };
  // compute's stages: each pixel's ground point, o1 and step; the cost of every hypothesis and
  // its bracketed minima; the sub-step height, position and confidence of each pixel.
  Sweep project_rays(const Pose2& cur_in_key, const cv::Vec2d& key_tilt, const cv::Vec2d& cur_tilt,
                     double height_ratio);
  void sweep_costs(const Sweep& sweep, double gain, double bias);
  void read_heights(const Sweep& sweep);
  void load(const cv::Mat& gray, cv::Mat& img, cv::Mat& ok);
  PlaneSweepParams p_;
  const direct_depth::DirectDepth& depth_;
  double h_;
  int scale_ = 1;
  double fx_ = 0, fy_ = 0, cx_ = 0, cy_ = 0;  // pinhole model at the working scale
  bool has_key_ = false;
  long samples_ = 0;
  cv::Mat undist_x_, undist_y_, undist_;            // distortion maps (empty for a pinhole camera)
  cv::Mat nrm_;                                     // CV_32FC3 nominal ray per pixel (body frame, not normalised)
  cv::Mat key_, key_ok_, cur_, cur_ok_, cur_ok4_;   // cur_ok4_: the bilinear footprint at (i, j) usable
  cv::Mat ox_, oy_, oz_, row_step_;                 // per compute: o1 components, step per row
  std::vector<int> row_n_, row_last_, row_last_e_;  // per row: its hypotheses; its last t, of minima and of costs
  cv::Mat proj_u_, proj_v_;                         // one row's projected (u, v) for one hypothesis
  cv::Mat e_, c0_, c1_, c2_, best_, second_, left_, right_, bests_, tmp_;
  cv::Mat z_, x_, y_, conf_;
};

}  // namespace regolith::mapping
