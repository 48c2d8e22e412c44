#pragma once
// Post-processing common to every saliency method (spec 6.3 steps 5-6): 8-bit
// map -> Otsu threshold -> morphological opening / closing -> 8-connected
// components -> minimum area -> bounding boxes, each scored by the mean
// saliency inside its box.
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/saliency/bit_mask.hpp"
#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

struct PostProcessParams {
  double threshold_scale = 1.0;  ///< binary threshold = clamp(scale * Otsu threshold, 0, 254)
  int open_radius = 2;           ///< px, elliptical opening radius (0 = none)
  int close_radius = 2;          ///< px, elliptical closing radius (0 = none)
  int min_area = 100;            ///< px, components with fewer pixels are dropped
  int max_detections = 0;        ///< keep the highest-scoring boxes only (0 = all)
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// One detected salient object. Box in pixels, x/y min inclusive, max exclusive
/// (cv::Rect).
struct Detection {
  cv::Rect box;
  double score = 0.0;  ///< mean saliency in the box, [0,1]
  int area = 0;        ///< px, pixels of the connected component
};

/// Box IoU |A n B| / |A u B| (0 when both are empty).
double iou(const cv::Rect& a, const cv::Rect& b);

/// Otsu (1979) on a 256-bin histogram: T* = argmax w0 w1 (mu0 - mu1)^2, class 0
/// = values <= T*. Returns 0 for a constant histogram.
int otsu_threshold(const std::array<double, 256>& histogram);
/// Otsu threshold of a CV_8U single-channel image (optional CV_8U mask).
int otsu_threshold(const cv::Mat& image8u, const cv::Mat& mask = cv::Mat());

/// A saliency map prepared for detection: its 8-bit form, Otsu threshold and integral image (for
/// the box scores). Detectors at several threshold scales over one map share one preparation
/// (CandidateExtractor). Buffers are allocated on the first map of a given size.
struct PreparedMap {
  cv::Mat map8;  ///< CV_8U 0..255 (to_8bit)
  int otsu = 0;  ///< otsu_threshold(map8)
  /// CV_64F, (rows + 1) x (cols + 1) sums of map8 once `summed` (always sized by prepare()).
  mutable cv::Mat integral;
  mutable bool summed = false;
  /// `sums` false: the integral image is left for sums() (a single detection sums its few boxes
  /// directly, which costs less than the integral of a whole frame).
  void prepare(const cv::Mat& saliency, bool sums = true);
  /// The integral image, made now if prepare() left it.
  const cv::Mat& sums() const;
};

/// Reusable detector; buffers are allocated on the first frame of a given size.
class BoxDetector {
 public:
  explicit BoxDetector(PostProcessParams params = {});

  /// `saliency` CV_32F in [0,1] (or CV_8U 0..255), one channel. Appends
  /// nothing: `out` is cleared and filled, sorted by descending score. Returns
  /// the binary threshold used (0..255).
  int detect(const cv::Mat& saliency, std::vector<Detection>& out);
  /// The same on a prepared map.
  int detect(const PreparedMap& map, std::vector<Detection>& out);

  /// The binary mask of the last call (CV_8U 0/255) after morphology (unpacked from its bits on
  /// the first call after a detect()).
  const cv::Mat& mask() const;
  const PostProcessParams& params() const { return params_; }

 private:
  PostProcessParams params_;
  PreparedMap prepared_;
  // The mask as bits: threshold, opening and closing with elliptical elements, 8-connected runs
  // (the results of cv::morphologyEx and cv::connectedComponentsWithStats, without their
  // per-call allocations, at a fraction of a byte-per-pixel pass's cost).
  BitMask bits_, bits_tmp_;
  std::optional<BinaryMorphology> open_, close_;
  RunComponents components_;
  mutable cv::Mat mask_;
  mutable bool mask_stale_ = true;
};

/// Convenience: float or 8-bit saliency -> CV_8U 0..255 (float clamped to
/// [0,1]).
void to_8bit(const cv::Mat& saliency, cv::Mat& out8);

}  // namespace regolith::saliency
