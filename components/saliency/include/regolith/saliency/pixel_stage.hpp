#pragma once
// The trained rock detector's pixel stage (issue 15, the pixel map's max F): the candidates'
// painted and guided map says which boxes hold rock, but not which of a box's pixels are rock and
// which are its shadow or the ground between two rocks. A second random forest, trained on the
// rock masks pixel by pixel, reads at each cell of a coarse grid (a quarter of the model's working
// width) the guided map around the cell at four scales and the image there (normalised intensity,
// its contrast to three surrounds, gradient, texture, image row) and gives the cell's rock
// fraction; that grid, brought back to the image's size and through the guided filter of the map
// (so that it follows the image's edges), is the published map. Trained on out-of-fold maps of the
// inner grouped CV (the maps a model gives images it never saw), so it learns to correct the first
// stage's errors on new images rather than to trust its in-sample confidence. Grouped CV on the
// dev images: max F 0.781 -> 0.802, every fold up (components/saliency/README.md, "The pixel
// stage").
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

inline constexpr int kPixelFeatureCount = 13;
/// Names of the pixel features, in order (kPixelFeatureCount entries).
const std::vector<std::string>& pixel_feature_names();

/// The grid is this many times coarser than the model's working width.
inline constexpr int kPixelGridDivisor = 4;

/// The grid of a map of `map_size`: working_width_px / kPixelGridDivisor cells across (the map's
/// own width / kPixelGridDivisor when working_width_px is 0), the map's aspect kept, at least 1 x 1
/// and never finer than the map.
cv::Size pixel_grid_size(cv::Size map_size, int working_width_px);

/// The pixel stage's features and buffers. Allocation-free from the second map of the same sizes on.
class PixelStage {
 public:
  /// One row of kPixelFeatureCount features per cell of `grid` (cells row-major) from the guided
  /// pixel map `map` (CV_32FC1) and the image's intensity (CV_32FC1 in [0, 1] or CV_8UC1, the
  /// map's size). Throws std::invalid_argument on other types or sizes.
  void compute(const cv::Mat& intensity, const cv::Mat& map, cv::Size grid);
  /// grid.area() x kPixelFeatureCount, CV_32F (compute()'s).
  const cv::Mat& features() const { return features_; }
  cv::Size grid() const { return grid_; }
  /// Per-cell values (set by the caller, grid-sized CV_32FC1).
  cv::Mat& cells() { return cells_; }
  /// Scratch of grid.area() doubles for the caller's per-cell sums.
  double* sums() { return sums_.data(); }
  /// cells() brought to `map`'s size (bilinear, as cv::resize INTER_LINEAR), clamped to [0, 1],
  /// then through `guide` (when not null) with `intensity` (compute()'s) as the guide, so that the
  /// coarse grid's steps follow the image's edges.
  void upsample(const cv::Mat& intensity, cv::Mat& map, GuidedFilter* guide);

 private:
  cv::Size map_size_{}, grid_{};
  ResizeTable down_, up_;
  GaussianBlur32f blur1_, blur2_, blur4_, blur8_, blur16_;
  cv::Mat unit_;  // an 8-bit intensity as [0, 1] floats
  cv::Mat i_, g_, g1_, g4_, g8_, i1_, i4_, i16_, ii_, ii1_, gx_, gy_, grad_, grad2_;
  cv::Mat features_, cells_;
  std::vector<double> sums_;
};

}  // namespace regolith::saliency
