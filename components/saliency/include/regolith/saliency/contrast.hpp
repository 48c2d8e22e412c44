#pragma once
// Intensity-contrast saliency, the "tuned contrast peer" of issue 15:
//   I  = (r + g + b) / 3 in [0,1]          (to_unit_float + intensity_of, as IttiSaliency)
//   C  = |I - G_sigma * I|                  (Gaussian surround, sigma in px)
//   C' = G_smooth * C                       (optional smoothing, smooth_sigma_px > 0)
//   S  = C' / max(C')                       (CV_32F in [0,1] at the input size; a map with
//                                            max(C') <= 1e-6, i.e. a flat image, is all zero)
// Both Gaussians are computed by DecimatedGaussian (at a reduced resolution when sigma
// is large), so the cost does not grow with sigma.
// Bright and dark objects both stand out against their surround. The boxes come from the
// post-processing shared by every method (BoxDetector: Otsu x threshold_scale, opening /
// closing, 8-connected components, minimum area, mean saliency in the box as the 0..1 score);
// contrast_post_processing() gives this method's defaults for it.
#include <opencv2/core.hpp>

#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

struct ContrastParams {
  /// px, standard deviation of the Gaussian surround G_sigma. Chosen by the grouped 5-fold CV
  /// on marsdata_rocks_dev (components/saliency/README.md), as are the defaults below.
  double sigma_px = 64.0;
  /// px, standard deviation of the Gaussian smoothing of |I - G_sigma * I| (0 = none).
  double smooth_sigma_px = 8.0;
  /// Throws FieldError (a std::invalid_argument) naming the field.
  void validate() const;
  bool operator==(const ContrastParams&) const = default;
};

/// Gaussian blur of a CV_32FC1 image with a cost independent of sigma (px): with f the largest
/// power of two such that sigma / f >= 4 and the image is >= 4f px on each side (f = 1 for
/// sigma < 8), the image is reduced by f (area resampling, as cv::INTER_AREA), blurred with
/// sigma_f = sqrt(sigma^2 - f^2 / 4) / f (as cv::GaussianBlur, BORDER_REFLECT_101; f^2/4 is the
/// variance the area reduction, f^2/12, and the bilinear enlargement, f^2/6, add) and enlarged
/// back (bilinear, as cv::INTER_LINEAR). f = 1 is the plain Gaussian. The resampling tables and
/// buffers are made on the first image of a size and sigma: later calls do not allocate.
/// `dst` must not alias `src`.
class DecimatedGaussian {
 public:
  /// Throws std::invalid_argument on an empty / non-CV_32FC1 src or sigma not > 0.
  void apply(const cv::Mat& src, cv::Mat& dst, double sigma);

 private:
  cv::Size size_;
  double sigma_ = 0.0;
  int factor_ = 1;
  ResizeTable down_, up_;
  GaussianBlur32f blur_;
  cv::Mat small_, small_blur_;
};

/// Post-processing defaults of the contrast method (the shared opening / closing radii, its
/// own Otsu scale and minimum area), chosen by the same cross-validation as ContrastParams.
PostProcessParams contrast_post_processing();

/// Reusable contrast saliency; buffers are allocated on the first frame of a given size and type.
class ContrastSaliency {
 public:
  explicit ContrastSaliency(ContrastParams params = {});

  /// `image`: 1, 3 (BGR) or 4 (BGRA) channels, 8U / 16U / 16S / 32F / 64F (floats taken as
  /// [0,1], as IttiSaliency). `saliency` becomes CV_32F in [0,1] of the input size. Throws
  /// std::invalid_argument on empty or unsupported input.
  void compute(const cv::Mat& image, cv::Mat& saliency);
  /// The same from a precomputed intensity I (CV_32FC1, [0,1]), e.g. cached by an evaluation.
  void compute_from_intensity(const cv::Mat& intensity, cv::Mat& saliency);

  const ContrastParams& params() const { return params_; }

 private:
  ContrastParams params_;
  cv::Mat unit_, intensity_, surround_, diff_;
  DecimatedGaussian surround_blur_, smooth_blur_;
};

}  // namespace regolith::saliency
