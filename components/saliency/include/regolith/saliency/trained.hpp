#pragma once
// Trained ranking stage for rock boxes (issue 15), method "trained":
//  1. candidates: connected components of two intensity-contrast maps (ContrastSaliency,
//     sigma 64 / smooth 8 px and sigma 16 / smooth 4 px) and of a chroma map (the coarse
//     contrast of the redness r - b: grey rock on red dust) thresholded at several Otsu scales
//     (BoxDetector, permissive minimum area); identical boxes are kept once;
//  2. per-candidate features (kFeatureCount, feature_names()): box size / aspect / image row,
//     contrast saliency inside vs a ring around the box, intensity mean / std inside vs ring,
//     edge density, bright / dark fractions, dark-region-adjacent cue (dark fraction of the
//     ring's four side strips: max / mean / min), fill ratio of the thresholded blob, ...;
//     context among the candidates (stability: how many maps / thresholds found the same box;
//     nesting: parents, children, the largest parent's area, the best overlap with another
//     candidate), chromaticity inside vs ring and image and the chroma map inside and inside vs
//     ring (0 for grey images); the image's shadow
//     side (the ring side darker than the others over all candidates): each candidate's dark
//     fraction there and on the sun side, and its half towards the sun minus the other half;
//  3. a random forest (cv::ml::RTrees, regression on the soft label min(1, IoU / 0.5) with the
//     best-matching non-ignored ground-truth component; fixed RNG, no randomness elsewhere)
//     whose mean tree output is the box score in [0,1];
//  4. greedy non-maximum suppression (IoU > nms_iou) and a score threshold, lower in an image
//     with many sure boxes (CrowdRule), then the boxes refined on the pixel map (BoxParams); all
//     chosen on out-of-fold predictions of an inner grouped CV over the training images only.
// The model file (format name and version, these parameters, the forest's arrays) is read and
// written by model_file.hpp, library regolith::saliency_model_file.
// Training and cross-validation (labels from ground truth, the inner CV that chooses BoxParams)
// are in train_rocks.hpp, library regolith::saliency_eval.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/saliency/contrast.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/image_ops.hpp"
#include "regolith/saliency/pixel_stage.hpp"

namespace regolith::saliency {

inline constexpr int kFeatureCount = 44;
/// 7: each forest's nodes as one base64 list of little-endian records (read ~10x faster than the
/// 150 k YAML numbers of 6); 6: + the pixel stage (pixel_stage.hpp) and its forest; 5: the forest as plain arrays per
/// tree, every key required (model_file.hpp); 4: 44 features (+ the chroma map), chroma candidates, OpenCV's forest; 3:
/// 42 features.
inline constexpr int kTrainedModelVersion = 7;
inline constexpr const char* kTrainedModelFormat = "regolith.saliency.trained_rocks";

/// Names of the features, in order (kFeatureCount entries).
const std::vector<std::string>& feature_names();

struct CandidateParams {
  ContrastParams coarse{64.0, 8.0};                       ///< px, the contrast method's defaults
  ContrastParams fine{16.0, 4.0};                         ///< px, a second, finer contrast map
  ContrastParams chroma{64.0, 8.0};                       ///< px, the chroma map's contrast (below)
  std::vector<double> coarse_scales{0.6, 0.8, 1.0, 1.3};  ///< Otsu scales on the coarse map
  std::vector<double> fine_scales{0.8, 1.2};              ///< Otsu scales on the fine map
  /// Otsu scales on the chroma map: the contrast (`chroma`) of the redness r - b (chromaticities) of a
  /// colour image, where grey rocks stand out of red dust that is as bright as they are. A grey
  /// image has no chroma candidates.
  std::vector<double> chroma_scales{0.8, 1.2};
  int min_area = 200;    ///< px, smallest candidate component (contrast method: 1600)
  int open_radius = 2;   ///< px
  int close_radius = 2;  ///< px
  /// px: every image is resampled to this width (aspect kept) before its candidates and features
  /// are computed, and the boxes are mapped back; the pixel scales above and the box-size features
  /// hold at this width. `regolith train rocks` sets it to the training images' median width;
  /// 0: each image at its own size (a model file without the key). An image taller than twice
  /// its width is resampled to at most 2 x working_width_px^2 pixels instead (CandidateExtractor::
  /// working_size: a 17 x 500 strip would otherwise become 560 x 16,470 and 3.4 GB of buffers).
  int working_width_px = 0;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
  bool operator==(const CandidateParams&) const = default;
};

/// A crowded image's lower bar: an image in which at least `count` boxes reach the score
/// threshold (after NMS) is a rock field, where a candidate is more likely a rock than the same
/// score says over all images; its boxes down to `threshold` are kept as well (NMS against all
/// kept). count 0: no such rule.
struct CrowdRule {
  int count = 0;
  double threshold = 1.0;
  bool on() const { return count > 0; }
  bool operator==(const CrowdRule&) const = default;
};

/// How a model's scored candidates become its boxes (TrainedModel::boxes()): chosen together by
/// the inner grouped CV of train_model(), stored in the model file, and overridable per
/// deployment (the `sams` component's parameters of the same names).
struct BoxParams {
  double score_threshold = 0.5;  ///< a box scores at least this (a crowded image: crowd.threshold)
  double nms_iou = 0.3;          ///< greedy NMS: a box overlapping a kept one by IoU above this is dropped
  /// refine(): each kept box shrunk to the strongest part of the pixel map inside it at this
  /// fraction of the map's peak there; 0 keeps the boxes as selected.
  double refine_fraction = 0.0;
  CrowdRule crowd;  ///< the crowded image's lower bar (off: none)
  bool operator==(const BoxParams&) const = default;
};

/// One candidate box with its features.
struct RockCandidate {
  cv::Rect box;
  int area = 0;              ///< px of the thresholded component
  int source = 0;            ///< index of the (map, scale) it came from (bit of CandidateSet::source_masks)
  unsigned source_bits = 0;  ///< bit k set for every source k that found exactly this box (source's bit included)
  int stability = 0;         ///< how many (map, scale) sources found (nearly) this box, itself included
  std::array<float, kFeatureCount> features{};
};

struct CandidateSet {
  cv::Size size;
  std::vector<RockCandidate> candidates;
  /// CV_8U, bit k set where the binary mask of source k is set (for the pixel score map).
  cv::Mat source_masks;
  int sources = 0;  ///< number of (map, scale) sources (bits used in source_masks)
};

/// Reusable candidate generator + feature extractor (plain OpenCV).
class CandidateExtractor {
 public:
  explicit CandidateExtractor(CandidateParams params = {});
  /// `image`: as ContrastSaliency::compute. Throws std::invalid_argument on bad input, and on an
  /// image of more than kMaxUnscaledAreaPx pixels for a model without a working width (it would
  /// be processed at its own size: ~600 bytes of buffers per pixel).
  /// Allocation-free from the second image of a size on (and the first of the same size into
  /// `out`): every buffer is kept, and `out.candidates` is reserved for the most candidates an
  /// image can give (each source's components are disjoint and >= min_area px).
  void extract(const cv::Mat& image, CandidateSet& out);
  /// Most candidates one image of `size` can give.
  std::size_t max_candidates(cv::Size size) const;
  /// The size an image of `size` is processed at: params().working_width_px wide (`size` when 0),
  /// the aspect kept, but never more than kMaxWorkingAreaFactor x working_width_px^2 pixels.
  static constexpr double kMaxWorkingAreaFactor = 2.0;
  /// The most pixels a model without a working width processes (2048 x 2048: ~2.5 GB of buffers).
  static constexpr double kMaxUnscaledAreaPx = 2048.0 * 2048.0;
  cv::Size working_size(cv::Size size) const;
  const CandidateParams& params() const { return params_; }

 private:
  /// extract() from intensity_, chroma_r_ and chroma_b_ (at the working size); the sources'
  /// masks go to `masks`. `colour`: the image had three channels (a grey one has no chroma map).
  void extract_at_working_size(CandidateSet& out, cv::Mat& masks, bool colour);
  /// The maps, per-pixel indicators, their integral images and the image statistics of intensity_.
  void prepare_maps(bool colour);
  /// Candidate `c`'s per-box features (kBoxFeatures of them) from detection `d` of a source with
  /// feature value `source`; its ring strips and box halves go to sides_.
  void box_features(const Detection& d, double source, RockCandidate& c);
  /// The image's shadow side from all candidates' ring strips, and each candidate's features for it.
  void shadow_side_features(CandidateSet& out) const;
  /// r = R / (R + G + B) and b = B / (R + G + B) of a colour `image` (its size), CV_32F; of a
  /// grey one the constant 1/3, made at `size` (for a colour image `size` must be its own).
  void chromaticity(const cv::Mat& image, cv::Size size, cv::Mat& r, cv::Mat& b);

  CandidateParams params_;
  // An image of another width than the working one: its intensity and (colour) chromaticity at its size,
  // the resampling to the working size, the sources' masks there and the way back (nearest).
  cv::Mat full_intensity_, full_chroma_r_, full_chroma_b_, working_masks_;
  ResizeTable to_working_;
  std::vector<int> back_x_, back_y_;
  ContrastSaliency coarse_, fine_, chroma_;
  DecimatedGaussian surround_blur_;
  std::vector<BoxDetector> detectors_;  // coarse scales, then fine scales, then chroma scales
  cv::Mat unit_, intensity_, surround_, s_coarse_, s_fine_, gx_, gy_, grad_, i2_, edge_, dark_, bright_;
  PreparedMap coarse_map_, fine_map_, chroma_map_;  // the maps prepared once for their detectors
  cv::Mat colour_, chroma_r_, chroma_b_, redness_, s_chroma_;
  struct Integrals {
    cv::Mat i, i2, sc, sf, g, edge, dark, bright, cr, cb, sch;
  } ii_;
  struct ImageStats {
    double mean = 0, std = 0, cr = 0, cb = 0;  ///< intensity mean and std, mean chromaticity r and b
  } image_;
  cv::Size sized_;  // image size the buffers and reservations were made for
  std::vector<Detection> dets_;
  /// Per candidate (same order), until the image's shadow side is known: the dark fraction of
  /// the ring's left / right / top / bottom strips (-1: outside the image) and the mean
  /// intensity of the box's left / right / top / bottom half.
  struct Sides {
    std::array<float, 4> dark{}, half_mean{};
  };
  std::vector<Sides> sides_;
};

/// How a trained model's published map is made from the painted one (TrainedModel::finish_map;
/// the defaults are the model's own).
struct TrainedMapOptions {
  /// Window radius of the guided filter both steps end with; unset: TrainedModel::map_guide_radius_px() of
  /// the image's width; 0: no filter (the painted map goes on as it is, the stage's grid is
  /// only interpolated back).
  std::optional<int> guide_radius_px;
  /// The filter's ridge on the intensity gain (intensity in [0, 1]).
  double guide_eps = 1e-3;  // TrainedModel::kMapGuideEps
  /// Whether the pixel stage runs (a model without one never runs it).
  bool pixel_stage = true;
};
/// Scratch of TrainedModel::finish_map's steps: no allocation once it has seen a map of this size and radius.
struct TrainedMapScratch {
  std::optional<GuidedFilter> guide;  // at the radius and ridge in use
  PixelStage stage;
};
/// A trained model: candidate parameters, chosen thresholds and the forest.
class TrainedModel {
 public:
  TrainedModel();
  ~TrainedModel();
  TrainedModel(const TrainedModel&);
  TrainedModel& operator=(const TrainedModel&);

  CandidateParams candidates;
  /// The model's boxes.
  BoxParams box;
  int training_images = 0, training_samples = 0, training_positives = 0;

  bool trained() const;
  /// Score in [0,1] of every candidate (same order): the mean output of the forest's trees,
  /// evaluated on the model's own copy of the trees (equal to cv::ml::RTrees::predict, checked
  /// in tests/saliency/test_trained.cpp), which allocates nothing.
  std::vector<float> score(const CandidateSet& set) const;
  /// The same into `scores` (resized; no allocation within its capacity).
  void score(const CandidateSet& set, std::vector<float>& scores) const;
  /// The same scores by cv::ml::RTrees::predict (allocates): the reference the tests hold score() to.
  std::vector<float> score_by_opencv(const CandidateSet& set) const;
  /// The model's boxes (`box`) of a candidate set, best first: score(), then boxes() on the
  /// painted pixel map (allocates; for tools and tests).
  std::vector<Detection> detect(const CandidateSet& set) const;
  /// The boxes of precomputed scores before refinement, best first: the candidates at or above
  /// `p.score_threshold` in descending score (ties keep the candidates' order), each dropped when
  /// it overlaps a kept box by IoU above `p.nms_iou`; once `p.crowd.count` boxes are kept,
  /// candidates down to `p.crowd.threshold` are taken too. `p.refine_fraction` is not read
  /// (boxes() applies it). Into `out`, with `order` as scratch: no allocation within their
  /// capacities.
  static void select(const CandidateSet& set, const std::vector<float>& scores, const BoxParams& p,
                     std::vector<Detection>& out, std::vector<std::uint32_t>& order);
  /// The same, returned (allocates).
  static std::vector<Detection> select(const CandidateSet& set, const std::vector<float>& scores, const BoxParams& p);
  /// Pixel score map (CV_32F [0,1]): at each pixel, the mean over the sources of the score of the
  /// candidate whose blob in that source covers the pixel (0 where none does), each blob filled to
  /// the pixels between its first and last pixel along both their row and their column in the
  /// candidate's box (a rock's mid-grey middle is no contrast blob, but it is rock). A rock's core,
  /// found at every threshold, scores near its box score; the fringe only the loosest threshold
  /// takes in scores a fraction of it (grouped CV max F 0.730 against 0.695 for the max over
  /// NMS-kept blobs; 0.754 -> 0.773 with the fill). `spans`: scratch, no allocation once it and
  /// `map` have been used at the set's size.
  static void score_map(const CandidateSet& set, const std::vector<float>& scores, cv::Mat& map,
                        std::vector<int>& spans);
  /// The same with a scratch of its own (allocates; for tools and tests).
  static void score_map(const CandidateSet& set, const std::vector<float>& scores, cv::Mat& map);
  /// The filter's radius at the model's working width (candidates.working_width_px, where its
  /// pixel scales hold; chosen on the 560 px development images), and its ridge.
  static constexpr int kMapGuideRadiusPx = 12;
  static constexpr double kMapGuideEps = 1e-3;
  /// The radius for an image `image_width_px` wide: kMapGuideRadiusPx in proportion to the image's
  /// width against the working width (rounded, at least 1), so that it spans as much of a rock
  /// whatever the camera; kMapGuideRadiusPx for a model without a working width.
  int map_guide_radius_px(int image_width_px) const;
  /// The published map, made from score_map()'s painting after boxes() have been refined on it:
  /// guide_map(), then pixel_stage(). Every user of a model publishes this map (the `sams`
  /// component, `regolith rocks --saliency-dir`, the grouped CV's max F). `intensity`: the image's
  /// (CV_32FC1 in [0, 1] or CV_8UC1, the map's size); `map` CV_32FC1 in [0, 1], in place.
  void finish_map(const cv::Mat& intensity, cv::Mat& map, TrainedMapScratch& scratch,
                  const TrainedMapOptions& o = {}) const;
  /// The first step: `map` := the guided filter of itself with the image's intensity as the guide,
  /// in [0, 1]. Inside a rock (an even stretch of the image) the map is smoothed, so the low values
  /// the painting leaves on its fringe and middle rise towards its core's; across the rock's
  /// outline (an edge of the image) the map's step is kept rather than bled onto the ground
  /// (grouped CV max F 0.773 -> 0.781, every seed +0.006 to +0.010; components/saliency/README.md,
  /// "The map follows the image's edges").
  void guide_map(const cv::Mat& intensity, cv::Mat& map, TrainedMapScratch& scratch,
                 const TrainedMapOptions& o = {}) const;
  /// The second step, the pixel stage (pixel_stage.hpp): `map` := the pixel forest's rock fraction
  /// of each cell of pixel_grid_size() (scratch.stage keeps the grid's features and values),
  /// brought back to the map's size and through the same guided filter, so that it follows the
  /// image's edges, in [0, 1]. A model without a pixel stage, or `o.pixel_stage` false, leaves
  /// `map` as it is.
  void pixel_stage(const cv::Mat& intensity, cv::Mat& map, TrainedMapScratch& scratch,
                   const TrainedMapOptions& o = {}) const;
  bool has_pixel_stage() const;
  /// The pixel forest's value of each row of `features` (PixelStage::features()) by
  /// cv::ml::RTrees::predict (allocates): the reference pixel_stage()'s own walk is held to in the
  /// tests; only in a freshly trained model (std::logic_error otherwise).
  std::vector<float> pixel_values_by_opencv(const cv::Mat& features) const;
  /// Scratch of refine() and boxes(): no allocation once reserve()d at a map's size and candidate
  /// count (without it, the buffers grow to the largest box and list seen).
  struct BoxScratch {
    void reserve(cv::Size map, std::size_t candidate_count);
    std::vector<std::uint32_t> order;  // select()'s
    BitMask above;                     // a box's pixels at or above the cut
    RunComponents parts;               // their 8-connected parts
    std::vector<double> sums;          // per part, its sum of map values
  };
  /// Box refinement: inside each detection's box, the pixels of `map` (score_map()'s) at or above
  /// `fraction` x the box's highest value, in 8-connected parts; the box becomes the bounding box
  /// of the part with the largest sum of map values (ties: the part RunComponents numbers first; a
  /// blob that took in a neighbour, a shadow or bright ground keeps the rock it was scored for).
  /// Boxes only shrink; scores, order and areas stay. `fraction` <= 0 or a box whose map is 0
  /// changes nothing.
  static void refine(const cv::Mat& map, double fraction, std::vector<Detection>& dets, BoxScratch& scratch);
  /// The boxes every user of a model reports: select() with `p`, then refine() on `map` at
  /// `p.refine_fraction` (`map` is not read when that is 0).
  static void boxes(const CandidateSet& set, const std::vector<float>& scores, const cv::Mat& map, const BoxParams& p,
                    std::vector<Detection>& out, BoxScratch& scratch);

  /// The forest (trained_forest.hpp, internal): set by training and by the model file's reader.
  struct Forest;
  std::shared_ptr<Forest> forest_;
  /// The pixel stage's forest (kPixelFeatureCount features); null: no pixel stage.
  std::shared_ptr<Forest> pixel_forest_;
};

static_assert(TrainedMapOptions{}.guide_eps == TrainedModel::kMapGuideEps);

}  // namespace regolith::saliency
