// Training the rock model (trained.hpp): labels, the forest, the inner CV that chooses the box
// parameters, and the grouped cross-validation of the whole stage.
#include "regolith/saliency/train_rocks.hpp"

#include <algorithm>

#include <opencv2/ml.hpp>

#include "regolith/saliency/dataset.hpp"
#include "regolith/saliency/image_ops.hpp"
#include "trained_forest.hpp"

namespace regolith::saliency {

void TrainParams::validate() const {
  if (trees < 1 || trees > 1000) throw std::invalid_argument("TrainParams.trees: must be in [1, 1000]");
  if (max_depth < 1 || max_depth > 30) throw std::invalid_argument("TrainParams.max_depth: must be in [1, 30]");
  if (min_sample_count < 1) throw std::invalid_argument("TrainParams.min_sample_count: must be >= 1");
  if (!(positive_iou > 0.0 && positive_iou <= 1.0))
    throw std::invalid_argument("TrainParams.positive_iou: must be in (0, 1]");
  if (inner_folds < 2) throw std::invalid_argument("TrainParams.inner_folds: must be >= 2");
  if (score_thresholds.empty()) throw std::invalid_argument("TrainParams.score_thresholds: empty");
  if (nms_ious.empty()) throw std::invalid_argument("TrainParams.nms_ious: empty");
  if (refine_fractions.empty()) throw std::invalid_argument("TrainParams.refine_fractions: empty");
  for (double f : refine_fractions)
    if (!(f >= 0.0 && f < 1.0)) throw std::invalid_argument("TrainParams.refine_fractions: each must be in [0, 1)");
  if (crowd_counts.empty()) throw std::invalid_argument("TrainParams.crowd_counts: empty (0 alone: no crowd rule)");
  for (int c : crowd_counts)
    if (c < 0) throw std::invalid_argument("TrainParams.crowd_counts: each must be >= 0");
  for (double d : crowd_drops)
    if (!(d > 0.0 && d < 1.0)) throw std::invalid_argument("TrainParams.crowd_drops: each must be in (0, 1)");
  if (pixel_trees < 0 || pixel_trees > 1000)
    throw std::invalid_argument("TrainParams.pixel_trees: must be in [0, 1000]");
  if (pixel_max_depth < 1 || pixel_max_depth > 30)
    throw std::invalid_argument("TrainParams.pixel_max_depth: must be in [1, 30]");
  if (pixel_min_sample_count < 1) throw std::invalid_argument("TrainParams.pixel_min_sample_count: must be >= 1");
  if (pixel_samples < 1) throw std::invalid_argument("TrainParams.pixel_samples: must be >= 1");
  // cv::RNG is multiply-with-carry: from state 0 it draws 0 for ever (every bootstrap sample
  // the first candidate), and the forest learns nothing
  if (seed == 0) throw std::invalid_argument("TrainParams.seed: must be non-zero (OpenCV's generator stays at 0)");
}

namespace {

// A regression forest on the rows of `x` (CV_32F, every column an ordered variable) and labels
// `y`, with cv::theRNG() pinned to `seed` while it trains: bit-for-bit reproducible.
cv::Ptr<cv::ml::RTrees> fit_rtrees(const cv::Mat& x, const cv::Mat& y, int trees, int max_depth, int min_samples,
                                   uint64_t seed) {
  cv::Mat var_type(1, x.cols + 1, CV_8U, cv::Scalar(cv::ml::VAR_ORDERED));
  auto data =
      cv::ml::TrainData::create(x, cv::ml::ROW_SAMPLE, y, cv::noArray(), cv::noArray(), cv::noArray(), var_type);
  auto rt = cv::ml::RTrees::create();
  rt->setMaxDepth(max_depth);
  rt->setMinSampleCount(min_samples);
  rt->setRegressionAccuracy(1e-6f);
  rt->setUseSurrogates(false);
  rt->setMaxCategories(2);
  rt->setCVFolds(0);
  rt->setCalculateVarImportance(false);
  rt->setActiveVarCount(0);
  rt->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, trees, 0.0));
  // RTrees draws its bootstrap samples and split variables from cv::theRNG(): pin it for a
  // bit-for-bit reproducible forest, and restore the caller's state afterwards.
  const uint64 saved = cv::theRNG().state;
  cv::theRNG().state = seed;
  bool ok = false;
  try {
    ok = rt->train(data);
  } catch (...) {
    cv::theRNG().state = saved;
    throw;
  }
  cv::theRNG().state = saved;
  if (!ok) throw std::runtime_error("train rocks: cv::ml::RTrees::train failed");
  return rt;
}

cv::Ptr<cv::ml::RTrees> fit_forest(const std::vector<const LabelledFrame*>& frames, const TrainParams& tp, int* samples,
                                   int* positives) {
  std::vector<RockCandidate> all;
  std::vector<float> labels;
  for (const LabelledFrame* f : frames) {
    all.insert(all.end(), f->set.candidates.begin(), f->set.candidates.end());
    labels.insert(labels.end(), f->labels.begin(), f->labels.end());
  }
  if (samples) *samples = static_cast<int>(all.size());
  if (positives) *positives = static_cast<int>(std::count(labels.begin(), labels.end(), 1.0f));
  if (all.size() < 2) throw std::invalid_argument("train rocks: fewer than 2 candidates to train on");
  const cv::Mat y(static_cast<int>(labels.size()), 1, CV_32F, labels.data());
  return fit_rtrees(feature_matrix(all), y.clone(), tp.trees, tp.max_depth, tp.min_sample_count, tp.seed);
}

// The pixel stage's forest (pixel_stage.hpp): on every frame's out-of-fold map (`scores`: the
// inner CV's), painted and guided as `m` will paint and guide it, tp.pixel_samples cells drawn
// at random (cv::RNG seeded with tp.seed) with their rock fraction in the truth mask.
cv::Ptr<cv::ml::RTrees> fit_pixel_forest(const std::vector<const LabelledFrame*>& frames,
                                         const std::vector<std::vector<float>>& scores, const TrainedModel& m,
                                         const TrainParams& tp) {
  cv::Mat x(0, kPixelFeatureCount, CV_32F), y(0, 1, CV_32F), map, rock, rock_cells;
  TrainedMapScratch scratch;
  PixelStage& stage = scratch.stage;
  ResizeTable down;
  cv::RNG rng(tp.seed);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const LabelledFrame& f = *frames[i];
    if (f.intensity.empty())
      throw std::invalid_argument(f.name + ": no intensity image for the pixel stage (make_labelled_frame sets it)");
    TrainedModel::score_map(f.set, scores[i], map);
    m.guide_map(f.intensity, map, scratch);
    const cv::Size grid = pixel_grid_size(map.size(), m.candidates.working_width_px);
    stage.compute(f.intensity, map, grid);
    f.truth.mask.convertTo(rock, CV_32F, 1.0 / 255.0);
    down.build(rock.size(), grid, ResizeTable::Mode::kArea);
    down.apply(rock, rock_cells);
    for (int k = 0; k < tp.pixel_samples; ++k) {
      const int c = rng.uniform(0, grid.area());
      x.push_back(stage.features().row(c));
      y.push_back(rock_cells.at<float>(c / grid.width, c % grid.width));
    }
  }
  return fit_rtrees(x, y, tp.pixel_trees, tp.pixel_max_depth, tp.pixel_min_sample_count, tp.seed);
}

double objective(const Summary& s) {
  return 0.5 * (s.n_moda02 + s.n_moda05);
}

}  // namespace

std::vector<float> label_candidates(const CandidateSet& set, const FrameTruth& truth, double positive_iou, bool soft) {
  std::vector<float> labels;
  labels.reserve(set.candidates.size());
  for (const RockCandidate& c : set.candidates) {
    double best = 0.0;
    for (const GtObject& g : truth.objects)
      if (!g.ignored) best = std::max(best, iou(c.box, g.box));
    labels.push_back(soft                   ? static_cast<float>(std::min(1.0, best / positive_iou))
                     : best >= positive_iou ? 1.0f
                                            : 0.0f);
  }
  return labels;
}

LabelledFrame make_labelled_frame(const DatasetItem& item, CandidateExtractor& extractor, int min_gt_area,
                                  double positive_iou) {
  LabelledFrame f;
  f.name = item.name;
  f.group = sol_group(item.name);
  const cv::Mat img = read_image(item.image_path);
  f.truth = read_truth(item.mask_path, img.size(), min_gt_area);
  try {
    extractor.extract(img, f.set);
  } catch (const std::exception& e) {
    throw DataError(item.image_path + ": " + e.what());
  }
  f.labels = label_candidates(f.set, f.truth, positive_iou);
  cv::Mat unit;
  to_unit_float(img, unit);
  intensity_of(unit, f.intensity);
  return f;
}

namespace {

// Out-of-fold scores of `frames` by an inner grouped CV (tp.inner_folds, fewer when there are
// fewer groups); empty when there are fewer than two groups.
std::vector<std::vector<float>> out_of_fold_scores(const std::vector<const LabelledFrame*>& frames,
                                                   const TrainParams& tp) {
  std::vector<std::string> groups;
  for (const auto* f : frames) groups.push_back(f->group);
  std::vector<std::string> distinct = groups;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  const int k = std::min<int>(tp.inner_folds, static_cast<int>(distinct.size()));
  if (k < 2) return {};
  std::vector<std::vector<float>> scores(frames.size());
  const std::vector<int> fold = grouped_folds(groups, k);
  for (int f = 0; f < k; ++f) {
    std::vector<const LabelledFrame*> train;
    for (size_t i = 0; i < frames.size(); ++i)
      if (fold[i] != f) train.push_back(frames[i]);
    TrainedModel inner;
    inner.forest_ = std::make_shared<TrainedModel::Forest>();
    inner.forest_->rtrees = fit_forest(train, tp, nullptr, nullptr);
    inner.forest_->flatten();
    for (size_t i = 0; i < frames.size(); ++i)
      if (fold[i] == f) inner.score(frames[i]->set, scores[i]);
  }
  return scores;
}

// The (threshold, NMS, refinement) with the best mean of N-MODA@0.2 and @0.5 over the frames'
// out-of-fold `scores` (ties: the first in grid order), then the crowd rule for those (only when
// it beats them). Defaults without scores.
BoxParams choose_box_params(const std::vector<const LabelledFrame*>& frames,
                            const std::vector<std::vector<float>>& scores, const TrainParams& tp) {
  if (scores.empty()) return BoxParams{};
  std::vector<cv::Mat> maps(frames.size());  // the pixel maps the refinement reads
  if (std::any_of(tp.refine_fractions.begin(), tp.refine_fractions.end(), [](double f) { return f > 0.0; }))
    for (size_t i = 0; i < frames.size(); ++i) TrainedModel::score_map(frames[i]->set, scores[i], maps[i]);
  BoxParams best;
  double best_obj = -1e300;
  std::vector<Detection> dets;
  TrainedModel::BoxScratch scratch;
  const auto score_of = [&](const BoxParams& c) {
    std::vector<FrameRecord> recs;
    for (size_t i = 0; i < frames.size(); ++i) {
      TrainedModel::boxes(frames[i]->set, scores[i], maps[i], c, dets, scratch);
      recs.push_back(evaluate_frame(frames[i]->name, dets, frames[i]->truth));
    }
    return objective(summarise(recs));
  };
  for (double refine : tp.refine_fractions)
    for (double nms : tp.nms_ious)
      for (double t : tp.score_thresholds)
        if (const double o = score_of(BoxParams{t, nms, refine, {}}); o > best_obj) {
          best_obj = o;
          best = BoxParams{t, nms, refine, {}};
        }
  // Then the crowd rule with those three (ties: the earlier, so no rule unless it gains).
  const BoxParams plain = best;
  for (int count : tp.crowd_counts) {
    if (count <= 0) continue;
    for (double drop : tp.crowd_drops) {
      BoxParams c = plain;
      c.crowd = CrowdRule{count, std::max(0.0, plain.score_threshold - drop)};
      if (const double o = score_of(c); o > best_obj) {
        best_obj = o;
        best = c;
      }
    }
  }
  return best;
}

}  // namespace

TrainedModel train_model(const std::vector<const LabelledFrame*>& frames, const CandidateParams& cparams,
                         const TrainParams& tparams) {
  cparams.validate();
  tparams.validate();
  if (frames.empty()) throw std::invalid_argument("train rocks: no training images");
  TrainedModel m;
  m.candidates = cparams;
  const std::vector<std::vector<float>> oof = out_of_fold_scores(frames, tparams);
  m.box = choose_box_params(frames, oof, tparams);
  m.forest_ = std::make_shared<TrainedModel::Forest>();
  m.forest_->rtrees = fit_forest(frames, tparams, &m.training_samples, &m.training_positives);
  m.forest_->flatten();
  if (tparams.pixel_trees > 0 && !oof.empty()) {
    m.pixel_forest_ = std::make_shared<TrainedModel::Forest>(kPixelFeatureCount);
    m.pixel_forest_->rtrees = fit_pixel_forest(frames, oof, m, tparams);
    m.pixel_forest_->flatten();
  }
  m.training_images = static_cast<int>(frames.size());
  return m;
}

TrainedCvResult cross_validate_trained(const std::vector<LabelledFrame>& frames, const CandidateParams& cparams,
                                       const TrainParams& tparams, int folds) {
  std::vector<std::string> groups;
  for (const auto& f : frames) {
    // The scored maps are guided by the image (as `regolith rocks` and the component guide
    // theirs): a frame without its intensity would be scored on another map, silently.
    if (f.intensity.empty())
      throw std::invalid_argument(f.name + ": no intensity image to guide the pixel map (make_labelled_frame sets it)");
    groups.push_back(f.group);
  }
  TrainedCvResult r;
  r.fold_of = grouped_folds(groups, folds);
  r.pooled.resize(frames.size());
  r.pooled_guided.resize(frames.size());
  cv::Mat map, map8;
  std::vector<Detection> dets;
  TrainedModel::BoxScratch scratch;
  TrainedMapScratch map_scratch;
  for (int f = 0; f < folds; ++f) {
    std::vector<const LabelledFrame*> train;
    std::vector<size_t> test;
    for (size_t i = 0; i < frames.size(); ++i) {
      if (r.fold_of[i] == f)
        test.push_back(i);
      else
        train.push_back(&frames[i]);
    }
    const TrainedModel m = train_model(train, cparams, tparams);
    r.box_params.push_back(m.box);
    for (size_t i : test) {
      const std::vector<float> s = m.score(frames[i].set);
      TrainedModel::score_map(frames[i].set, s, map);
      TrainedModel::boxes(frames[i].set, s, map, m.box, dets, scratch);
      // the published map (finish_map), scored after each of its two steps
      m.guide_map(frames[i].intensity, map, map_scratch);
      to_8bit(map, map8);
      r.pooled_guided[i] = evaluate_frame(frames[i].name, dets, frames[i].truth, map8);
      m.pixel_stage(frames[i].intensity, map, map_scratch);
      to_8bit(map, map8);
      r.pooled[i] = evaluate_frame(frames[i].name, dets, frames[i].truth, map8);
    }
    r.fold_summaries.push_back(summarise(r.pooled, test));
  }
  return r;
}

}  // namespace regolith::saliency
