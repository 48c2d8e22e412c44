#pragma once
// Training the trained rock detector (trained.hpp) and cross-validating it, grouped by sol: the
// candidates labelled from ground-truth masks, the inner grouped CV that chooses the model's
// BoxParams on out-of-fold scores, the forest on every training frame. Part of
// regolith::saliency_eval (with the dataset reader and the N-MODA evaluation), not of the
// real-time library: a deployment loads a model, it does not train one.
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/saliency/evaluate.hpp"
#include "regolith/saliency/trained.hpp"

namespace regolith::saliency {

struct TrainParams {
  int trees = 100;  ///< random-forest size
  int max_depth = 8;
  int min_sample_count = 10;         ///< samples per leaf, at least
  double positive_iou = 0.5;         ///< label 1 when max IoU with a non-ignored GT box >= this
  uint64_t seed = 0x5EED0F0C4B5ull;  ///< cv::theRNG() state while a forest trains (bootstrap, splits)
  int inner_folds = 4;               ///< grouped CV on the training images to choose the thresholds
  std::vector<double> score_thresholds{0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45, 0.50,
                                       0.55, 0.60, 0.65, 0.70, 0.75, 0.80, 0.85, 0.90};
  std::vector<double> nms_ious{0.2, 0.3, 0.5};
  /// BoxParams::refine_fraction candidates (0: boxes as selected), chosen with the thresholds.
  std::vector<double> refine_fractions{0.0, 0.3};
  /// BoxParams::crowd candidates, chosen after the three above on the same inner CV: counts
  /// (0: no crowd rule) and how far below the score threshold a crowded image's boxes may score.
  std::vector<int> crowd_counts{0, 6, 8, 10, 12};
  std::vector<double> crowd_drops{0.05, 0.10, 0.15};
  /// The pixel stage's forest (pixel_stage.hpp), trained on the inner CV's out-of-fold maps:
  /// pixel_samples random cells of each training image; 0 trees: a model without a pixel stage
  /// (as one trained on images of a single group, which has no out-of-fold maps).
  int pixel_trees = 10;
  int pixel_max_depth = 10;
  int pixel_min_sample_count = 20;
  int pixel_samples = 3000;
  void validate() const;
};

/// One training / evaluation frame: truth, candidates and their labels.
struct LabelledFrame {
  std::string name, group;
  FrameTruth truth;
  CandidateSet set;
  std::vector<float> labels;  ///< 0/1 per candidate
  cv::Mat intensity;          ///< CV_32FC1 [0, 1], the image's (intensity_of): the pixel map's guide
};

/// Labels of the candidates from their max IoU with a non-ignored GT object: soft (default)
/// min(1, IoU / positive_iou), so that a fragment or an over-sized box ranks between a miss and a
/// match; hard: 1 when IoU >= positive_iou, else 0.
std::vector<float> label_candidates(const CandidateSet& set, const FrameTruth& truth, double positive_iou,
                                    bool soft = true);

struct DatasetItem;
/// Reads one image + mask (read_image / read_truth: DataError naming the file), extracts and
/// labels its candidates.
LabelledFrame make_labelled_frame(const DatasetItem& item, CandidateExtractor& extractor, int min_gt_area,
                                  double positive_iou);

/// Trains on `frames` (all of them): inner grouped CV (by LabelledFrame::group) to choose the
/// model's BoxParams, then the forest on every frame. Deterministic.
TrainedModel train_model(const std::vector<const LabelledFrame*>& frames, const CandidateParams& cparams,
                         const TrainParams& tparams);

struct TrainedCvResult {
  std::vector<FrameRecord> pooled;  ///< per frame (input order), scored with its test fold's model
  /// The same with the map before the pixel stage (the guided map): the stage's ablation.
  std::vector<FrameRecord> pooled_guided;
  std::vector<int> fold_of;
  std::vector<Summary> fold_summaries;
  std::vector<BoxParams> box_params;  ///< chosen per fold
};

/// k-fold CV grouped by sol (grouped_folds of the frames' groups): each test fold is scored
/// by a model trained (thresholds included) on the other folds only; its pixel map is guided by
/// the frame's intensity. std::invalid_argument naming the frame when a frame has no intensity.
TrainedCvResult cross_validate_trained(const std::vector<LabelledFrame>& frames, const CandidateParams& cparams,
                                       const TrainParams& tparams, int folds);

}  // namespace regolith::saliency
