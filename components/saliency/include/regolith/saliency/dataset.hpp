#pragma once
// Evaluation of the four methods on an image folder with binary rock masks
// (e.g.
// ../shared/data/marsdata_rocks_dev): per-frame caching of the conspicuity maps
// and the peers' maps, evaluation of any (method, weights, post-processing)
// candidate, the channel-weight sweep (thesis Table 5.2 analogue) and k-fold
// cross-validation of weights and thresholds.
#include <opencv2/core.hpp>

#include <functional>
#include <string>
#include <vector>

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
  std::string name; ///< image file name (no directory)
  std::string image_path;
  std::string mask_path; ///< masks_dir/<stem>.png
};

struct DatasetListing {
  std::vector<DatasetItem> items; ///< sorted by name
  std::vector<std::string>
      errors; ///< images without a mask, unreadable directories
};

/// Images (.jpg .jpeg .png .bmp .tif .tiff .pgm .ppm) in `images_dir` paired
/// with `masks_dir/<stem>.png`. Throws DataError if a directory does not exist.
DatasetListing list_dataset(const std::string &images_dir,
                            const std::string &masks_dir);

/// cv::imread with IMREAD_UNCHANGED; throws DataError "<path>: cannot read
/// image" on failure.
cv::Mat read_image(const std::string &path);

/// Reads the mask (any depth/channels; nonzero in the first channel = rock) and
/// checks its size. Throws DataError naming the mask file on failure or size
/// mismatch.
FrameTruth read_truth(const std::string &mask_path, cv::Size image_size,
                      int min_gt_area);

/// Computes the SAMS height map of an image (e.g. an adapter around
/// regolith::sfs). `height`: single channel, any depth, the image's size.
using HeightFn = std::function<void(const cv::Mat &image, cv::Mat &height)>;

struct StudyConfig {
  IttiParams itti; ///< weights field ignored: see itti_weights / sams_weights
  ChannelWeights itti_weights{1.0, 1.0, 1.0, 0.0};
  PostProcessParams post; ///< shared by every method
  int min_gt_area = 50;   ///< px, smaller ground-truth components are ignored
  int folds = 5;          ///< k of the k-fold cross-validation
  double weight_step =
      0.1; ///< grid step of the weight sweep (weights sum to 1)
  std::vector<double> threshold_scales{
      1.0}; ///< candidate Otsu scales for the sweep / CV
  void validate() const;
};

/// One parameter candidate: weights (SAMS / Itti) and the threshold scale.
struct Candidate {
  ChannelWeights weights;
  double threshold_scale = 1.0;
  std::string describe(bool with_structure) const;
};

struct SweepRow {
  Candidate candidate;
  Summary summary;
};

struct CvResult {
  std::vector<FrameRecord>
      pooled; ///< every frame, scored with its test fold's choice
  std::vector<double> fold_moda02, fold_moda05; ///< per test fold
  std::vector<std::string> chosen; ///< per fold, the selected candidate
};

class RockStudy {
public:
  /// `height` may be empty: SAMS is then unavailable (std::logic_error when
  /// asked for).
  RockStudy(StudyConfig config, HeightFn height);

  /// Reads and caches one frame. Throws DataError (naming the file) on bad
  /// input; the study is unchanged in that case.
  void add(const DatasetItem &item);
  size_t size() const { return frames_.size(); }
  bool has_structure() const { return static_cast<bool>(height_); }
  const StudyConfig &config() const { return config_; }

  /// Saliency map (CV_32F, [0,1], input size) of cached frame `k`.
  void saliency(size_t k, Method m, const ChannelWeights &w, cv::Mat &out);
  FrameRecord evaluate(size_t k, Method m, const Candidate &c, bool pixel);
  std::vector<FrameRecord> evaluate_all(Method m, const Candidate &c,
                                        bool pixel);

  /// Candidates for a method: SAMS = weight grid (I, O, [C], Z) x scales;
  /// others = scales with the fixed weights (Itti: itti_weights).
  std::vector<Candidate> candidates(Method m, bool sweep_weights,
                                    bool sweep_scales) const;
  /// Every candidate scored on all frames, best first (by mean of N-MODA@0.2
  /// and @0.5).
  std::vector<SweepRow> sweep(Method m, const std::vector<Candidate> &cands);
  /// k-fold CV: choose the candidate on the train folds, score the test fold.
  CvResult cross_validate(Method m, const std::vector<Candidate> &cands);

  /// Selection objective: mean of N-MODA@0.2 and N-MODA@0.5.
  static double objective(const Summary &s) {
    return 0.5 * (s.n_moda02 + s.n_moda05);
  }

private:
  struct Frame {
    std::string name;
    cv::Size size;
    FrameTruth truth;
    Conspicuity consp; // deep copies
    cv::Mat sr, fg;    // CV_32F full size
  };
  StudyConfig config_;
  HeightFn height_;
  IttiSaliency itti_;
  OpenCvSaliency sr_, fg_;
  std::vector<Frame> frames_;
  cv::Mat height_buf_, scratch_, map_, map8_;
  std::vector<Detection> dets_;
};

} // namespace regolith::saliency
