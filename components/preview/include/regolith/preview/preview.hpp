#pragma once
// Camera previews: a camera frame scaled down with what the rover made of it drawn on top, for
// people watching a run (the live page, Foxglove's Image panel). Framework-free (OpenCV); the
// `camera_preview` component (component.hpp) runs these off the real-time threads and publishes
// the JPEG as sensor_msgs/CompressedImage.
#include <cstdint>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/common/grid.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/saliency/ranging.hpp"
#include "regolith/sinkage/sinkage.hpp"

namespace regolith::preview {

/// The preview size for a `source` frame: `width` px wide (never wider than the source, at least
/// 16 px), the height keeping the aspect ratio.
cv::Size preview_size(cv::Size source, int width);

/// The hazard layer of a grid map in the image: for every pixel of a `preview` image of the
/// camera `depth` describes, the index i * size_y + j of the `grid` cell the pixel's ray meets
/// the flat ground in (direct depth: the body-frame ground point of the pixel's centre), -1 where
/// it sees no ground or ground outside the grid. CV_32S, preview size.
cv::Mat grid_cell_lookup(const direct_depth::DirectDepth& depth, const common::GridGeometry& grid, cv::Size preview);

/// A grid layer over the preview: `cell` from grid_cell_lookup, `traversability` the grid's layer
/// (CV_32F, size_x rows x size_y columns, 1 = free, 0 = impassable, NaN = unknown).
struct HazardOverlay {
  const cv::Mat* cell = nullptr;
  const cv::Mat* traversability = nullptr;
};

/// Front camera: `frame` (CV_8UC1 or CV_8UC3, the image the boxes of `rocks` are in) scaled into
/// `out` (CV_8UC3, sized by preview_size; reallocated only when its size differs); with `hazard`,
/// every pixel that sees a cell of traversability t < 1 tinted red by (1 - t) * 0.6 (unknown
/// cells untouched); every rock's box drawn (hazards red and thicker, the others yellow) with its
/// score, and a caption "rocks N  hazards H  nearest R m". Throws std::invalid_argument for an
/// empty frame, or a hazard overlay whose lookup is not of the preview's size or whose layer is
/// not CV_32F.
void draw_rocks(const cv::Mat& frame, std::span<const saliency::RangedRock> rocks, int width, cv::Mat& out,
                const HazardOverlay& hazard = {});

/// Wheel camera: the CV_8UC3 `frame` scaled into `scaled` (preview_size), then sinkage::draw_overlay
/// (leg template red, interface line green, sinkage blue, caption) with the geometry and the
/// result scaled alike, into `out`. Throws std::invalid_argument for a frame that is not CV_8UC3.
void draw_sinkage(const cv::Mat& frame, const sinkage::WheelGeometry& geometry, const sinkage::SinkageResult& result,
                  int width, cv::Mat& scaled, cv::Mat& out);

/// JPEG of a CV_8UC3 image at `quality` (1..100) into `bytes` (reused: it grows, never shrinks).
/// Returns false when OpenCV cannot encode it.
bool encode_jpeg(const cv::Mat& bgr, int quality, std::vector<std::uint8_t>& bytes);

}  // namespace regolith::preview
