#pragma once
// Evaluation of every method on an image folder with binary rock masks
// (e.g. ../shared/data/marsdata_rocks_dev): per-frame caching of the conspicuity
// maps, the peers' maps and the intensity (for the contrast method), evaluation
// of any (method, weights / contrast parameters, post-processing) candidate, the
// channel-weight sweep (thesis Table 5.2 analogue) and k-fold cross-validation
// of weights, contrast parameters and thresholds with folds grouped by sol.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/saliency/contrast.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/evaluate.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/peers.hpp"

namespace regolith::saliency {

/// Input file problem (unreadable image, missing mask, size mismatch). The
/// message names the file.
class DataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct DatasetItem {
  std::string name;  ///< image file name (no directory)
  std::string image_path;
  std::string mask_path;  ///< masks_dir/<stem>.png
};

struct DatasetListing {
  std::vector<DatasetItem> items;   ///< sorted by name
  std::vector<std::string> errors;  ///< images without a mask, unreadable directories
};

/// The image files (.jpg .jpeg .png .bmp .tif .tiff .pgm .ppm .pbm .pnm .webp, any case) of a
/// directory, not recursing, sorted by path. Throws DataError naming the directory when it is
/// not one or cannot be read.
std::vector<std::string> list_images(const std::string& dir);

/// The images of `images_dir` (list_images) paired with `masks_dir/<stem>.png`, sorted by name.
/// Throws DataError if a directory does not exist.
DatasetListing list_dataset(const std::string& images_dir, const std::string& masks_dir);

/// Smallest image side read_image accepts (a rock box needs a few pixels and a surround).
inline constexpr int kMinImageSide = 16;
/// An image of the dataset, grey or colour as stored, with 8-bit samples (16-bit ones scaled by
/// the bit depth they use, regolith::to_8bit: a 12-bit image in a 16-bit PNG keeps its contrast);
/// throws DataError naming the file when it cannot be read, is a JPEG cut short (no end-of-image
/// marker: libjpeg would only warn), holds signed samples or is smaller than kMinImageSide.
cv::Mat read_image(const std::string& path);

/// Reads the mask (any depth/channels; nonzero in the first channel = rock) and
/// checks its size. Throws DataError naming the mask file on failure or size
/// mismatch.
FrameTruth read_truth(const std::string& mask_path, cv::Size image_size, int min_gt_area);

/// Acquisition group of an image for grouped cross-validation: the Mars sol, read from the
/// file name as the first '_'-separated token made only of digits, leading zeros dropped
/// ("1044_1044MR00..." -> "1044", "cr_078_0078MR05..." -> "78"; for marsdata_rocks_dev this
/// equals the `sol` column of manifest.csv). A name without such a token is its own group
/// (the whole name).
std::string sol_group(const std::string& name);

/// Median width of the items' images (0 when none can be read; unreadable ones are left out):
/// the trained method's working width (CandidateParams::working_width_px) for a training set.
int median_image_width(const std::vector<DatasetItem>& items);

/// Fold (0 .. k-1) of each item for k-fold cross-validation with the items of one group
/// always in the same fold: groups taken largest first (ties: smaller group key first, keys
/// compared as numbers when both are numbers) and each put in the fold with the fewest items
/// so far (ties: lowest fold). Throws std::invalid_argument when there are fewer than k
/// groups or k < 2.
std::vector<int> grouped_folds(const std::vector<std::string>& groups, int k);

/// Computes the SAMS height map of an image (e.g. an adapter around
/// regolith::sfs). `height`: single channel, any depth, the image's size.
using HeightFn = std::function<void(const cv::Mat& image, cv::Mat& height)>;

struct StudyConfig {
  IttiParams itti;  ///< weights field ignored: see itti_weights / sams_weights
  ChannelWeights itti_weights{1.0, 1.0, 1.0, 0.0};
  PostProcessParams post;                     ///< shared by every method
  int min_gt_area = 50;                       ///< px, smaller ground-truth components are ignored
  int folds = 5;                              ///< k of the k-fold cross-validation
  double weight_step = 0.1;                   ///< grid step of the weight sweep (weights sum to 1)
  std::vector<double> threshold_scales{1.0};  ///< candidate Otsu scales for the sweep / CV
  /// Contrast method: the map of the fixed-settings evaluation and its post-processing
  /// (threshold_scale and min_area; the other fields are taken from `post`).
  ContrastParams contrast;
  PostProcessParams contrast_post = contrast_post_processing();
  /// Contrast grid tuned by the sweep / CV (every combination).
  std::vector<double> contrast_sigmas{2, 4, 8, 16, 32, 48, 64, 96};  ///< px
  std::vector<double> contrast_smooth_sigmas{0, 2, 4, 8, 16};        ///< px
  std::vector<double> contrast_threshold_scales{0.5, 0.6, 0.7, 0.8, 1.0, 1.2, 1.4};
  std::vector<int> contrast_min_areas{100, 200, 400, 800, 1600, 2400, 3200, 4800};  ///< px
  void validate() const;
};

/// One parameter candidate: weights (SAMS / Itti), contrast parameters (contrast), the
/// threshold scale and optionally the minimum box area.
struct Candidate {
  ChannelWeights weights;
  double threshold_scale = 1.0;
  std::optional<int> min_area;  ///< px; unset = StudyConfig::post.min_area
  ContrastParams contrast;      ///< used by Method::kContrast only
  /// The fields that matter for `m`, e.g. "w_I=0.10 ... Otsu x1.00" or
  /// "sigma=8 px smooth=2 px, Otsu x1.40, min area 400 px".
  std::string describe(Method m) const;
  bool operator==(const Candidate&) const = default;
};

struct SweepRow {
  Candidate candidate;
  Summary summary;
};

struct CvResult {
  std::vector<FrameRecord> pooled;               ///< every frame, scored with its test fold's choice
  std::vector<int> fold_of;                      ///< per frame, its test fold
  std::vector<Summary> fold_summaries;           ///< per test fold (pixel stats included)
  std::vector<double> fold_moda02, fold_moda05;  ///< per test fold
  std::vector<Candidate> chosen;                 ///< per fold, the selected candidate
  /// The candidate chosen in most folds (ties: the one chosen first); the CV's
  /// recommendation for the defaults.
  Candidate most_chosen() const;
};

class RockStudy {
 public:
  /// `height` may be empty: SAMS is then unavailable (std::logic_error when
  /// asked for).
  RockStudy(StudyConfig config, HeightFn height);

  /// Reads and caches one frame. Throws DataError (naming the file) on bad
  /// input; the study is unchanged in that case.
  void add(const DatasetItem& item);
  size_t size() const { return frames_.size(); }
  bool has_structure() const { return static_cast<bool>(height_); }
  const StudyConfig& config() const { return config_; }

  /// Name and sol group of cached frame `k`.
  const std::string& name(size_t k) const { return frames_.at(k).name; }
  const std::string& group(size_t k) const { return frames_.at(k).group; }

  /// Saliency map (CV_32F, [0,1], input size) of cached frame `k` (weights: SAMS / Itti;
  /// contrast parameters: contrast).
  void saliency(size_t k, Method m, const Candidate& c, cv::Mat& out);
  FrameRecord evaluate(size_t k, Method m, const Candidate& c, bool pixel);
  std::vector<FrameRecord> evaluate_all(Method m, const Candidate& c, bool pixel);

  /// The fixed-settings candidate of a method: SAMS config.itti.weights, Itti
  /// itti_weights, contrast config.contrast + contrast_post, peers post.threshold_scale.
  Candidate default_candidate(Method m) const;
  /// Candidates for a method. `sweep_params`: SAMS = weight grid (I, O, [C], Z) x scales;
  /// contrast = sigma x smooth x contrast_threshold_scales x contrast_min_areas (its own
  /// scales; `sweep_scales` not used). Otherwise the default candidate, with the Otsu scales
  /// of `threshold_scales` when `sweep_scales`.
  std::vector<Candidate> candidates(Method m, bool sweep_params, bool sweep_scales) const;
  /// Every candidate scored on all frames, best first (by mean of N-MODA@0.2
  /// and @0.5).
  std::vector<SweepRow> sweep(Method m, const std::vector<Candidate>& cands);
  /// k-fold CV with folds grouped by sol (grouped_folds of the frames' groups):
  /// choose the candidate on the train folds, score the test fold.
  CvResult cross_validate(Method m, const std::vector<Candidate>& cands);
  /// The test fold of every cached frame (grouped_folds, config().folds).
  std::vector<int> folds() const;

  /// Selection objective: mean of N-MODA@0.2 and N-MODA@0.5.
  static double objective(const Summary& s) { return 0.5 * (s.n_moda02 + s.n_moda05); }

 private:
  struct Frame {
    std::string name, group;
    cv::Size size;
    FrameTruth truth;
    Conspicuity consp;  // deep copies
    cv::Mat sr, fg;     // CV_32F full size
    cv::Mat intensity;  // CV_32F full size, [0,1] (contrast method)
  };
  // What the map / the detections before the minimum-area filter depend on: candidates that
  // differ only in min_area (or only in the threshold scale) reuse them.
  struct MapKey {
    size_t frame = 0;
    Method method = Method::kSams;
    ChannelWeights weights;
    ContrastParams contrast;
    bool operator==(const MapKey&) const = default;
  };
  /// Score every candidate on every frame (detection only), frames outer.
  std::vector<std::vector<FrameRecord>> score_table(Method m, const std::vector<Candidate>& cands);

  StudyConfig config_;
  HeightFn height_;
  IttiSaliency itti_;
  OpenCvSaliency sr_, fg_;
  std::vector<Frame> frames_;
  cv::Mat height_buf_, scratch_, map_, map8_, unit_;
  std::optional<MapKey> map_key_;
  std::optional<double> dets_scale_;  // threshold scale of all_dets_ (for map_key_)
  std::vector<Detection> all_dets_, dets_;
};

}  // namespace regolith::saliency
