#pragma once
// Rock-detection evaluation (spec 6.6; data README "Suggested metrics"):
//  * ground truth = 8-connected components of a binary mask; components smaller
//  than a minimum
//    area are "ignored": they count neither as misses nor, when matched, as
//    false positives;
//  * one-to-one matching of boxes by the Hungarian method maximising the summed
//  IoU over pairs
//    with IoU >= threshold (Kasturi et al. 2009);
//  * N-MODA = 1 - sum(misses + false positives) / sum(ground truth), N-MODP =
//  mean over images
//    with matches of the mean IoU of the matched pairs; precision, recall;
//  * centroid hit rate = fraction of (non-ignored) components containing >= 1
//  box centre;
//  * pixel level: max over thresholds of the mean (over images) F-measure,
//  beta^2 = 0.3, and
//    the mean absolute error of the map scaled to [0,1].
#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/saliency/detect.hpp"

namespace regolith::saliency {

struct GtObject {
  cv::Rect box;  ///< x/y min inclusive, max exclusive
  int area = 0;  ///< px, mask pixels of the component
  bool ignored = false;
};

struct FrameTruth {
  cv::Mat mask;    ///< CV_8U, 255 = rock
  cv::Mat labels;  ///< CV_32S, 0 = background, k + 1 = objects[k]
  std::vector<GtObject> objects;
  int valid_count() const;
};

/// 8-connected components of `mask` (CV_8U single channel, nonzero = rock).
/// Throws std::invalid_argument for an empty / multi-channel / non-8-bit mask
/// or min_area < 0.
FrameTruth truth_from_mask(const cv::Mat& mask, int min_area);

struct FrameMatch {
  int n_gt = 0;   ///< non-ignored ground-truth objects
  int n_det = 0;  ///< detections that count (all minus those matched to ignored objects)
  int matched = 0;
  double iou_sum = 0.0;  ///< sum of IoU over matched pairs
  int misses() const { return n_gt - matched; }
  int false_positives() const { return n_det - matched; }
};

/// One-to-one matching at `iou_threshold` (see file comment). Ignored objects
/// are matched only with detections left unmatched by the non-ignored ones.
FrameMatch match_frame(const std::vector<cv::Rect>& dets, const FrameTruth& truth, double iou_threshold);

/// Number of non-ignored objects that contain at least one box centre (pixel
/// floor(x + w/2), floor(y + h/2)).
int centroid_hits(const std::vector<cv::Rect>& dets, const FrameTruth& truth);

/// Pixel-level statistics of one saliency map against the mask.
struct PixelStats {
  std::array<double, 256> f_curve{};  ///< F-measure at threshold t (map8 >= t is positive)
  double mae = 0.0;                   ///< mean |map/255 - gt|
};
/// `map8` CV_8U of the mask's size (std::invalid_argument otherwise).
PixelStats pixel_stats(const cv::Mat& map8, const cv::Mat& mask, double beta2 = 0.3);

/// Per-frame record: matches at IoU 0.2 and 0.5, centroid hits, pixel stats
/// (optional).
struct FrameRecord {
  std::string name;
  FrameMatch at02, at05;
  int hits = 0;
  int n_boxes = 0;  ///< all detections reported
  bool has_pixel = false;
  PixelStats pixel;
};

FrameRecord evaluate_frame(const std::string& name, const std::vector<Detection>& dets, const FrameTruth& truth,
                           const cv::Mat& map8 = cv::Mat());

/// Pooled scores over a set of frames.
struct Summary {
  int images = 0, gt = 0, boxes = 0;
  double n_moda02 = 0, n_modp02 = 0, precision02 = 0, recall02 = 0;
  double n_moda05 = 0, n_modp05 = 0, precision05 = 0, recall05 = 0;
  double centroid_rate = 0;
  double max_f = -1, mae = -1;  ///< -1 when no frame has pixel stats
};

/// Aggregate `records` (all when `subset` is empty, else the listed indices).
Summary summarise(const std::vector<FrameRecord>& records, const std::vector<size_t>& subset = {});

/// N-MODA pooled over frames (exposed for tests).
double n_moda(const std::vector<FrameMatch>& frames);
/// N-MODP: mean over frames with >= 1 match of (iou_sum / matched); 0 when
/// there are none.
double n_modp(const std::vector<FrameMatch>& frames);

/// Markdown table, one row per (label, summary).
std::string markdown_table(const std::vector<std::pair<std::string, Summary>>& rows);

}  // namespace regolith::saliency
