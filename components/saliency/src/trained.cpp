// Trained ranking stage for rock boxes: see trained.hpp.
#include "regolith/saliency/trained.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>

#include <opencv2/imgproc.hpp>
#include <opencv2/ml.hpp>

#include "regolith/core/csv.hpp"
#include "regolith/saliency/dataset.hpp"
#include "regolith/saliency/image_ops.hpp"

#ifndef REGOLITH_ROCKS_MODEL_SOURCE
#define REGOLITH_ROCKS_MODEL_SOURCE ""
#endif
#ifndef REGOLITH_ROCKS_MODEL_INSTALLED
#define REGOLITH_ROCKS_MODEL_INSTALLED ""
#endif

namespace regolith::saliency {

namespace {

constexpr int kBoxFeatures = kFeatureCount - 8;  // per-box features; then 5 context and 3 shadow-side features
constexpr int kCoarseMeanIn = 8;                 // index of "coarse_mean_in" in feature_names()
constexpr float kDarkOffset = 0.05f;             // I - G_64 * I below -this: dark pixel
constexpr float kBrightOffset = 0.05f;           // above +this: bright pixel
constexpr float kEdgeMagnitude = 0.08f;          // |grad I| (Sobel / 8) above this: edge pixel

// Sum over a rect of an integral image (CV_64F, (h+1) x (w+1)).
double rect_sum(const cv::Mat& ii, const cv::Rect& r) {
  if (r.width <= 0 || r.height <= 0) return 0.0;
  const double* a = ii.ptr<double>(r.y);
  const double* b = ii.ptr<double>(r.y + r.height);
  return b[r.x + r.width] - b[r.x] - a[r.x + r.width] + a[r.x];
}

void integral_of(const cv::Mat& src, cv::Mat& ii) {
  cv::integral(src, ii, CV_64F);
}

}  // namespace

const std::vector<std::string>& feature_names() {
  static const std::vector<std::string> names{"log_box_area",
                                              "log_aspect",
                                              "rel_width",
                                              "rel_height",
                                              "centre_row",
                                              "bottom_row",
                                              "centre_col_offset",
                                              "fill_ratio",
                                              "coarse_mean_in",
                                              "coarse_max_in",
                                              "coarse_ring",
                                              "coarse_in_minus_ring",
                                              "fine_mean_in",
                                              "fine_in_minus_ring",
                                              "intensity_in",
                                              "intensity_std_in",
                                              "intensity_ring",
                                              "intensity_std_ring",
                                              "intensity_in_minus_ring",
                                              "intensity_in_minus_image",
                                              "gradient_mean_in",
                                              "edge_density_in",
                                              "edge_density_ring",
                                              "bright_frac_in",
                                              "dark_frac_in",
                                              "dark_side_max",
                                              "dark_side_mean",
                                              "dark_side_min",
                                              "source_scale",
                                              "image_intensity_std",
                                              "chroma_r_in_minus_ring",
                                              "chroma_b_in_minus_ring",
                                              "chroma_r_in_minus_image",
                                              "chroma_b_in_minus_image",
                                              "chroma_map_mean_in",
                                              "chroma_map_in_minus_ring",
                                              "stability",
                                              "log_largest_parent_area_ratio",
                                              "children",
                                              "parents",
                                              "max_iou_other_candidate",
                                              "dark_on_shadow_side",
                                              "dark_on_sun_side",
                                              "shading_towards_sun"};
  return names;
}

void CandidateParams::validate() const {
  coarse.validate();
  fine.validate();
  chroma.validate();
  if (coarse_scales.empty() && fine_scales.empty())
    throw std::invalid_argument("CandidateParams.coarse_scales: no threshold scale at all");
  if (coarse_scales.size() + fine_scales.size() + chroma_scales.size() > 8)
    throw std::invalid_argument("CandidateParams.coarse_scales: at most 8 scales in total (coarse, fine and chroma)");
  for (double s : coarse_scales)
    if (!(s > 0.0 && s <= 4.0)) throw std::invalid_argument("CandidateParams.coarse_scales: must be in (0, 4]");
  for (double s : fine_scales)
    if (!(s > 0.0 && s <= 4.0)) throw std::invalid_argument("CandidateParams.fine_scales: must be in (0, 4]");
  for (double s : chroma_scales)
    if (!(s > 0.0 && s <= 4.0)) throw std::invalid_argument("CandidateParams.chroma_scales: must be in (0, 4]");
  if (min_area < 1) throw std::invalid_argument("CandidateParams.min_area: must be >= 1 px");
  if (open_radius < 0) throw std::invalid_argument("CandidateParams.open_radius: must be >= 0");
  if (close_radius < 0) throw std::invalid_argument("CandidateParams.close_radius: must be >= 0");
  if (working_width_px < 0 || working_width_px > 8192)
    throw std::invalid_argument("CandidateParams.working_width_px: must be in [0, 8192] px (0: each image's own)");
}

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
  // cv::RNG is multiply-with-carry: from state 0 it draws 0 for ever (every bootstrap sample
  // the first candidate), and the forest learns nothing
  if (seed == 0) throw std::invalid_argument("TrainParams.seed: must be non-zero (OpenCV's generator stays at 0)");
}

CandidateExtractor::CandidateExtractor(CandidateParams params)
    : params_(std::move(params)), coarse_(params_.coarse), fine_(params_.fine), chroma_(params_.chroma) {
  params_.validate();
  auto add = [&](double scale) {
    PostProcessParams pp;
    pp.threshold_scale = scale;
    pp.min_area = params_.min_area;
    pp.open_radius = params_.open_radius;
    pp.close_radius = params_.close_radius;
    pp.max_detections = 0;
    detectors_.emplace_back(pp);
  };
  for (double s : params_.coarse_scales) add(s);
  for (double s : params_.fine_scales) add(s);
  for (double s : params_.chroma_scales) add(s);
}

cv::Size CandidateExtractor::working_size(cv::Size size) const {
  const int w = params_.working_width_px;
  if (w <= 0 || w == size.width || size.width <= 0) return size;
  const double s = static_cast<double>(w) / size.width;
  return {w, std::max(1, static_cast<int>(std::lround(size.height * s)))};
}

std::size_t CandidateExtractor::max_candidates(cv::Size size) const {
  const cv::Size ws = working_size(size);
  const std::size_t per_source = static_cast<std::size_t>(ws.width) * static_cast<std::size_t>(ws.height) /
                                     static_cast<std::size_t>(params_.min_area) +
                                 1;
  return per_source * detectors_.size();
}

void CandidateExtractor::extract(const cv::Mat& image, CandidateSet& out) {
  if (image.empty()) throw std::invalid_argument("empty image");
  const cv::Size size = image.size(), ws = working_size(size);
  const bool resample = ws != size;
  // Intensity and chromaticity at the image's size; then, for an image of another width than
  // the model's, resampled to the working size (tables made once per size: no allocation after).
  // A grey image's chromaticity is a constant, made at the working size (nothing to resample).
  to_unit_float(image, unit_);
  const bool colour = image.channels() == 3;
  cv::Mat& i0 = resample ? full_intensity_ : intensity_;
  cv::Mat& r0 = resample && colour ? full_chroma_r_ : chroma_r_;
  cv::Mat& b0 = resample && colour ? full_chroma_b_ : chroma_b_;
  intensity_of(unit_, i0);
  chromaticity(image, colour ? size : ws, r0, b0);
  if (!resample) {
    extract_at_working_size(out, out.source_masks, colour);
    return;
  }
  if (to_working_.src_size() != size || to_working_.dst_size() != ws) {
    to_working_.build(size, ws, ws.width < size.width ? ResizeTable::Mode::kArea : ResizeTable::Mode::kLinear);
    // nearest working pixel of every image pixel (as cv::resize INTER_NEAREST), for the masks
    back_x_.resize(static_cast<std::size_t>(size.width));
    back_y_.resize(static_cast<std::size_t>(size.height));
    for (int x = 0; x < size.width; ++x)
      back_x_[static_cast<std::size_t>(x)] = std::min(ws.width - 1, x * ws.width / size.width);
    for (int y = 0; y < size.height; ++y)
      back_y_[static_cast<std::size_t>(y)] = std::min(ws.height - 1, y * ws.height / size.height);
  }
  to_working_.apply(i0, intensity_);
  if (colour) {
    to_working_.apply(r0, chroma_r_);
    to_working_.apply(b0, chroma_b_);
  }
  extract_at_working_size(out, working_masks_, colour);
  // The model's pixel scales and box-size features hold at its working width; the boxes (outwards,
  // so a box still covers its blob) and the sources' masks go back to the image's pixels.
  const double sx = static_cast<double>(size.width) / ws.width, sy = static_cast<double>(size.height) / ws.height;
  for (RockCandidate& c : out.candidates) {
    const cv::Rect& b = c.box;
    const int x0 = static_cast<int>(std::floor(b.x * sx)), y0 = static_cast<int>(std::floor(b.y * sy));
    const int x1 = std::min(size.width, static_cast<int>(std::ceil((b.x + b.width) * sx)));
    const int y1 = std::min(size.height, static_cast<int>(std::ceil((b.y + b.height) * sy)));
    c.box = cv::Rect(x0, y0, std::max(1, x1 - x0), std::max(1, y1 - y0));
    c.area = static_cast<int>(std::lround(c.area * sx * sy));
  }
  out.source_masks.create(size, CV_8U);
  for (int y = 0; y < size.height; ++y) {
    const uchar* m = working_masks_.ptr<uchar>(back_y_[static_cast<std::size_t>(y)]);
    uchar* o = out.source_masks.ptr<uchar>(y);
    for (int x = 0; x < size.width; ++x) o[x] = m[back_x_[static_cast<std::size_t>(x)]];
  }
  out.size = size;
}

void CandidateExtractor::chromaticity(const cv::Mat& image, cv::Size size, cv::Mat& r, cv::Mat& b) {
  // r = R / (R + G + B), b = B / (R + G + B): rock against dust; 1/3 for grey images
  r.create(size, CV_32F);
  b.create(size, CV_32F);
  const int W = size.width, H = size.height;
  if (image.channels() == 3) {
    image.convertTo(colour_, CV_32FC3);
    for (int y = 0; y < H; ++y) {
      const float* c = colour_.ptr<float>(y);  // B, G, R
      float* rp = r.ptr<float>(y);
      float* bp = b.ptr<float>(y);
      for (int x = 0; x < W; ++x, c += 3) {
        const float sum = c[0] + c[1] + c[2] + 1e-3f;
        rp[x] = c[2] / sum;
        bp[x] = c[0] / sum;
      }
    }
  } else {
    for (cv::Mat* m : {&r, &b})
      for (int y = 0; y < H; ++y) std::fill(m->ptr<float>(y), m->ptr<float>(y) + W, 1.0f / 3.0f);
  }
}

void CandidateExtractor::prepare_maps(bool colour) {
  const cv::Mat& I = intensity_;
  const int W = I.cols, H = I.rows;
  coarse_.compute_from_intensity(I, s_coarse_);
  fine_.compute_from_intensity(I, s_fine_);
  // The chroma map: the contrast of the redness r - b. A grey image's redness is 0 everywhere and
  // so is its contrast (what compute_from_intensity would return after two sigma-64 blurs of
  // zeros): written directly, which saves the sams rate group a blur pair per cycle.
  if (colour) {
    for (int y = 0; y < H; ++y) {
      const float* r = chroma_r_.ptr<float>(y);
      const float* b = chroma_b_.ptr<float>(y);
      float* q = redness_.ptr<float>(y);
      for (int x = 0; x < W; ++x) q[x] = r[x] - b[x];
    }
    chroma_.compute_from_intensity(redness_, s_chroma_);
  } else {
    s_chroma_.create(I.size(), CV_32F);
    for (int y = 0; y < H; ++y) std::fill(s_chroma_.ptr<float>(y), s_chroma_.ptr<float>(y) + W, 0.0f);
  }
  surround_blur_.apply(I, surround_, params_.coarse.sigma_px);
  sobel3_32f(I, gx_, gy_, 1.0f / 8.0f);
  cv::magnitude(gx_, gy_, grad_);
  // Per pixel: intensity squared, and the edge / dark / bright indicators (0 or 1).
  for (int y = 0; y < H; ++y) {
    const float* ip = I.ptr<float>(y);
    const float* sp = surround_.ptr<float>(y);
    const float* gp = grad_.ptr<float>(y);
    float* q = i2_.ptr<float>(y);
    float* e = edge_.ptr<float>(y);
    float* d = dark_.ptr<float>(y);
    float* b = bright_.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      const float diff = ip[x] - sp[x];
      q[x] = ip[x] * ip[x];
      e[x] = gp[x] > kEdgeMagnitude ? 1.0f : 0.0f;
      d[x] = diff < -kDarkOffset ? 1.0f : 0.0f;
      b[x] = diff > kBrightOffset ? 1.0f : 0.0f;
    }
  }
  Integrals& ii = ii_;
  integral_of(I, ii.i);
  integral_of(i2_, ii.i2);
  integral_of(s_coarse_, ii.sc);
  integral_of(s_fine_, ii.sf);
  integral_of(grad_, ii.g);
  integral_of(edge_, ii.edge);
  integral_of(dark_, ii.dark);
  integral_of(bright_, ii.bright);
  integral_of(chroma_r_, ii.cr);
  integral_of(chroma_b_, ii.cb);
  integral_of(s_chroma_, ii.sch);
  const cv::Rect frame(0, 0, W, H);
  const double n_img = static_cast<double>(W) * H;
  image_.mean = rect_sum(ii.i, frame) / n_img;
  image_.std = std::sqrt(std::max(0.0, rect_sum(ii.i2, frame) / n_img - image_.mean * image_.mean));
  image_.cr = rect_sum(ii.cr, frame) / n_img, image_.cb = rect_sum(ii.cb, frame) / n_img;
}

void CandidateExtractor::box_features(const Detection& d, double source, RockCandidate& c) {
  const Integrals& ii = ii_;
  const int W = intensity_.cols, H = intensity_.rows;
  const cv::Rect frame(0, 0, W, H);
  const cv::Rect& b = d.box;
  const int margin = std::max(3, static_cast<int>(std::lround(0.25 * std::max(b.width, b.height))));
  const cv::Rect outer = cv::Rect(b.x - margin, b.y - margin, b.width + 2 * margin, b.height + 2 * margin) & frame;
  const double n_in = static_cast<double>(b.area());
  const double n_ring = std::max(1.0, static_cast<double>(outer.area()) - n_in);
  auto in = [&](const cv::Mat& ig) { return rect_sum(ig, b) / n_in; };
  auto ring = [&](const cv::Mat& ig) { return std::max(0.0, rect_sum(ig, outer) - rect_sum(ig, b)) / n_ring; };
  const double i_in = in(ii.i), i_ring = ring(ii.i);
  const double i2_in = in(ii.i2), i2_ring = ring(ii.i2);
  double smax = 0.0;
  cv::minMaxLoc(s_coarse_(b), nullptr, &smax);
  // Dark fraction of the four side strips of the ring.
  const cv::Rect sides[4] = {
      cv::Rect(b.x - margin, b.y, margin, b.height) & frame, cv::Rect(b.x + b.width, b.y, margin, b.height) & frame,
      cv::Rect(b.x, b.y - margin, b.width, margin) & frame, cv::Rect(b.x, b.y + b.height, b.width, margin) & frame};
  double dmax = 0.0, dsum = 0.0, dmin = 1.0;
  int nsides = 0;
  Sides& cs = sides_.emplace_back();
  for (std::size_t si = 0; si < 4; ++si) {
    const cv::Rect& s = sides[si];
    cs.dark[si] = -1.0f;
    if (s.area() <= 0) continue;
    const double f = rect_sum(ii.dark, s) / s.area();
    cs.dark[si] = static_cast<float>(f);
    dmax = std::max(dmax, f);
    dmin = std::min(dmin, f);
    dsum += f;
    ++nsides;
  }
  if (nsides == 0) dmin = 0.0;
  {
    const int hw = std::max(1, b.width / 2), hh = std::max(1, b.height / 2);
    const cv::Rect halves[4] = {cv::Rect(b.x, b.y, hw, b.height), cv::Rect(b.x + b.width - hw, b.y, hw, b.height),
                                cv::Rect(b.x, b.y, b.width, hh), cv::Rect(b.x, b.y + b.height - hh, b.width, hh)};
    for (std::size_t si = 0; si < 4; ++si)
      cs.half_mean[si] = static_cast<float>(rect_sum(ii.i, halves[si]) / halves[si].area());
  }
  const double v[kBoxFeatures] = {std::log(n_in),
                                  std::log(static_cast<double>(b.width) / b.height),
                                  static_cast<double>(b.width) / W,
                                  static_cast<double>(b.height) / H,
                                  (b.y + 0.5 * b.height) / H,
                                  static_cast<double>(b.y + b.height) / H,
                                  std::abs(b.x + 0.5 * b.width - 0.5 * W) / W,
                                  d.area / n_in,
                                  in(ii.sc),
                                  smax,
                                  ring(ii.sc),
                                  in(ii.sc) - ring(ii.sc),
                                  in(ii.sf),
                                  in(ii.sf) - ring(ii.sf),
                                  i_in,
                                  std::sqrt(std::max(0.0, i2_in - i_in * i_in)),
                                  i_ring,
                                  std::sqrt(std::max(0.0, i2_ring - i_ring * i_ring)),
                                  i_in - i_ring,
                                  i_in - image_.mean,
                                  in(ii.g),
                                  in(ii.edge),
                                  ring(ii.edge),
                                  in(ii.bright),
                                  in(ii.dark),
                                  dmax,
                                  nsides ? dsum / nsides : 0.0,
                                  dmin,
                                  source,
                                  image_.std,
                                  in(ii.cr) - ring(ii.cr),
                                  in(ii.cb) - ring(ii.cb),
                                  in(ii.cr) - image_.cr,
                                  in(ii.cb) - image_.cb,
                                  in(ii.sch),
                                  in(ii.sch) - ring(ii.sch)};
  for (int f = 0; f < kBoxFeatures; ++f) c.features[f] = static_cast<float>(v[f]);
}

namespace {

// Context among the candidates: a rock is found at several thresholds, whole and in fragments;
// where a box sits in that nesting tells the whole from a fragment.
void context_features(std::vector<RockCandidate>& candidates) {
  const size_t nc = candidates.size();
  for (size_t a = 0; a < nc; ++a) {
    RockCandidate& c = candidates[a];
    const cv::Rect& b = c.box;
    double parent_area = b.area(), max_iou = 0.0;
    int children = 0, parents = 0;
    for (size_t o = 0; o < nc; ++o) {
      if (o == a) continue;
      const cv::Rect& q = candidates[o].box;
      max_iou = std::max(max_iou, iou(b, q));
      const cv::Point qc(q.x + q.width / 2, q.y + q.height / 2), bc(b.x + b.width / 2, b.y + b.height / 2);
      if (q.area() < b.area() && b.contains(qc)) ++children;
      if (q.area() > b.area() && q.contains(bc)) {
        ++parents;
        parent_area = std::max(parent_area, static_cast<double>(q.area()));
      }
    }
    c.features[kBoxFeatures] = static_cast<float>(c.stability);
    c.features[kBoxFeatures + 1] = static_cast<float>(std::log(parent_area / std::max(1, b.area())));
    c.features[kBoxFeatures + 2] = static_cast<float>(children);
    c.features[kBoxFeatures + 3] = static_cast<float>(parents);
    c.features[kBoxFeatures + 4] = static_cast<float>(max_iou);
  }
}

}  // namespace

void CandidateExtractor::shadow_side_features(CandidateSet& out) const {
  const std::size_t nc = out.candidates.size();
  // The image's shadow side: rocks cast their shadows to the same side in one image (the sun's
  // opposite), ground texture to every side. The side whose ring strips are darker than the
  // candidate's other strips, summed over the candidates (each weighted by its contrast), is the
  // shadow side; each candidate's strip there and on the opposite (sun) side, and how much
  // brighter its half towards the sun is, are features.
  std::array<double, 4> excess{};
  for (std::size_t k = 0; k < nc; ++k) {
    const std::array<float, 4>& dark = sides_[k].dark;
    double m = 0.0;
    int n = 0;
    for (float f : dark)
      if (f >= 0) m += f, ++n;
    if (n == 0) continue;
    m /= n;
    for (std::size_t si = 0; si < 4; ++si)
      if (dark[si] >= 0) excess[si] += out.candidates[k].features[kCoarseMeanIn] * (dark[si] - m);
  }
  const auto sh = static_cast<std::size_t>(std::max_element(excess.begin(), excess.end()) - excess.begin());
  const std::size_t su = sh ^ 1u;  // the sun side: left <-> right, top <-> bottom
  for (std::size_t k = 0; k < nc; ++k) {
    const Sides& cs = sides_[k];
    float* f = out.candidates[k].features.data();
    f[kBoxFeatures + 5] = std::max(0.0f, cs.dark[sh]);
    f[kBoxFeatures + 6] = std::max(0.0f, cs.dark[su]);
    f[kBoxFeatures + 7] = cs.half_mean[su] - cs.half_mean[sh];
  }
}

void CandidateExtractor::extract_at_working_size(CandidateSet& out, cv::Mat& masks, bool colour) {
  const cv::Mat& I = intensity_;
  const int W = I.cols, H = I.rows;
  if (I.size() != sized_) {
    // Each source's components are disjoint and at least min_area px: a bound on what one image
    // can give, reserved once so that later images of this size allocate nothing.
    dets_.reserve(max_candidates(I.size()) / std::max<std::size_t>(1, detectors_.size()) + 1);
    for (cv::Mat* m : {&grad_, &i2_, &edge_, &dark_, &bright_, &redness_}) m->create(I.size(), CV_32F);
    sized_ = I.size();
  }
  out.candidates.reserve(max_candidates(I.size()));
  sides_.reserve(max_candidates(I.size()));
  prepare_maps(colour);

  out.size = I.size();
  out.candidates.clear();
  sides_.clear();
  masks.create(I.size(), CV_8U);
  for (int y = 0; y < H; ++y) std::fill(masks.ptr<uchar>(y), masks.ptr<uchar>(y) + W, uchar{0});
  out.sources = static_cast<int>(detectors_.size());
  const size_t n_coarse = params_.coarse_scales.size(), n_fine = params_.fine_scales.size();
  // Each map prepared once (8 bits, Otsu threshold, integral) for all its threshold scales.
  coarse_map_.prepare(s_coarse_);
  fine_map_.prepare(s_fine_);
  if (!params_.chroma_scales.empty()) chroma_map_.prepare(s_chroma_);
  for (size_t k = 0; k < detectors_.size(); ++k) {
    const bool is_coarse = k < n_coarse, is_fine = !is_coarse && k < n_coarse + n_fine;
    detectors_[k].detect(is_coarse ? coarse_map_ : is_fine ? fine_map_ : chroma_map_, dets_);
    const cv::Mat& m = detectors_[k].mask();
    const uchar bit = static_cast<uchar>(1u << k);
    for (int y = 0; y < H; ++y) {
      const uchar* mp = m.ptr<uchar>(y);
      uchar* sp = masks.ptr<uchar>(y);
      for (int x = 0; x < W; ++x)
        if (mp[x]) sp[x] = static_cast<uchar>(sp[x] | bit);
    }
    // the source feature: the threshold scale, + 10 on the fine map, + 20 on the chroma map
    const double source = is_coarse ? params_.coarse_scales[k]
                          : is_fine ? params_.fine_scales[k - n_coarse] + 10.0
                                    : params_.chroma_scales[k - n_coarse - n_fine] + 20.0;
    for (const Detection& d : dets_) {
      // the same blob at several maps / thresholds (IoU > 0.85): kept once, its stability counted
      bool dup = false;
      int near_same = 0;
      for (RockCandidate& c : out.candidates) {
        if (iou(c.box, d.box) > 0.85) {
          ++c.stability;
          ++near_same;
        }
        if (c.box == d.box) {
          dup = true;
          c.source_bits |= 1u << k;
        }
      }
      if (dup) continue;
      RockCandidate c;
      c.box = d.box;
      c.area = d.area;
      c.source = static_cast<int>(k);
      c.source_bits = 1u << k;
      c.stability = 1 + near_same;
      box_features(d, source, c);
      out.candidates.push_back(c);
    }
  }
  context_features(out.candidates);
  shadow_side_features(out);
}

// ---------------------------------------------------------------------------------------------
struct TrainedModel::Forest {
  cv::Ptr<cv::ml::RTrees> rtrees;
  // The trees again, flat, for an allocation-free evaluation (cv::ml::StatModel::predict makes
  // matrices at every call). Leaves have var < 0.
  struct Node {
    int var = -1;
    float threshold = 0.0f;
    int left = -1, right = -1;
    double value = 0.0;
  };
  std::vector<Node> nodes;
  std::vector<int> roots;

  void flatten() {
    nodes.clear();
    roots.clear();
    const auto& src = rtrees->getNodes();
    const auto& splits = rtrees->getSplits();
    nodes.resize(src.size());
    for (std::size_t i = 0; i < src.size(); ++i) {
      const auto& n = src[i];
      Node& o = nodes[i];
      o.value = n.value;
      if (n.split < 0) continue;
      const auto& sp = splits.at(static_cast<std::size_t>(n.split));
      // every feature is an ordered variable (fit_forest's var_type): no categorical subsets
      o.var = sp.varIdx;
      o.threshold = sp.c;
      // value <= c goes left; an inversed split swaps the children
      o.left = sp.inversed ? n.right : n.left;
      o.right = sp.inversed ? n.left : n.right;
      if (o.var < 0 || o.var >= kFeatureCount || o.left < 0 || o.right < 0 ||
          static_cast<std::size_t>(o.left) >= src.size() || static_cast<std::size_t>(o.right) >= src.size())
        throw std::runtime_error("rock model: a tree node points outside the forest");
    }
    roots = rtrees->getRoots();
    for (int r : roots)
      if (r < 0 || static_cast<std::size_t>(r) >= nodes.size()) throw std::runtime_error("rock model: bad tree root");
  }

  float predict(const float* x) const {
    double sum = 0.0;
    for (int r : roots) {
      int k = r;
      // depth <= max_depth (<= 30): the bound only stops a malformed file's cycle
      for (int step = 0; nodes[static_cast<std::size_t>(k)].var >= 0 && step < 64; ++step) {
        const Node& n = nodes[static_cast<std::size_t>(k)];
        k = x[n.var] <= n.threshold ? n.left : n.right;
      }
      sum += nodes[static_cast<std::size_t>(k)].value;
    }
    return roots.empty() ? 0.0f : static_cast<float>(sum / static_cast<double>(roots.size()));
  }
};

TrainedModel::TrainedModel() = default;
TrainedModel::~TrainedModel() = default;
TrainedModel::TrainedModel(const TrainedModel&) = default;
TrainedModel& TrainedModel::operator=(const TrainedModel&) = default;

bool TrainedModel::trained() const {
  return forest_ && forest_->rtrees && forest_->rtrees->isTrained();
}

namespace {

cv::Mat feature_matrix(const std::vector<RockCandidate>& cands) {
  cv::Mat m(static_cast<int>(cands.size()), kFeatureCount, CV_32F);
  for (size_t i = 0; i < cands.size(); ++i)
    std::copy(cands[i].features.begin(), cands[i].features.end(), m.ptr<float>(static_cast<int>(i)));
  return m;
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
  const cv::Mat x = feature_matrix(all);
  const cv::Mat y(static_cast<int>(labels.size()), 1, CV_32F, labels.data());
  cv::Mat var_type(1, kFeatureCount + 1, CV_8U, cv::Scalar(cv::ml::VAR_ORDERED));
  auto data = cv::ml::TrainData::create(x, cv::ml::ROW_SAMPLE, y.clone(), cv::noArray(), cv::noArray(), cv::noArray(),
                                        var_type);
  auto rt = cv::ml::RTrees::create();
  rt->setMaxDepth(tp.max_depth);
  rt->setMinSampleCount(tp.min_sample_count);
  rt->setRegressionAccuracy(1e-6f);
  rt->setUseSurrogates(false);
  rt->setMaxCategories(2);
  rt->setCVFolds(0);
  rt->setCalculateVarImportance(false);
  rt->setActiveVarCount(0);
  rt->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, tp.trees, 0.0));
  // RTrees draws its bootstrap samples and split variables from cv::theRNG(): pin it for a
  // bit-for-bit reproducible forest, and restore the caller's state afterwards.
  const uint64 saved = cv::theRNG().state;
  cv::theRNG().state = tp.seed;
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

double objective(const Summary& s) {
  return 0.5 * (s.n_moda02 + s.n_moda05);
}

}  // namespace

std::vector<float> TrainedModel::score(const CandidateSet& set) const {
  std::vector<float> out;
  score(set, out);
  return out;
}

void TrainedModel::score(const CandidateSet& set, std::vector<float>& scores) const {
  if (!trained()) throw std::logic_error("TrainedModel::score: no trained forest");
  scores.resize(set.candidates.size());
  for (std::size_t i = 0; i < set.candidates.size(); ++i)
    scores[i] = std::clamp(forest_->predict(set.candidates[i].features.data()), 0.0f, 1.0f);
}

std::vector<float> TrainedModel::score_by_opencv(const CandidateSet& set) const {
  if (!trained()) throw std::logic_error("TrainedModel::score_by_opencv: no trained forest");
  std::vector<float> out(set.candidates.size(), 0.0f);
  if (out.empty()) return out;
  const cv::Mat x = feature_matrix(set.candidates);
  cv::Mat y;
  forest_->rtrees->predict(x, y);
  for (int i = 0; i < x.rows; ++i) out[static_cast<size_t>(i)] = std::clamp(y.at<float>(i), 0.0f, 1.0f);
  return out;
}

std::vector<Detection> TrainedModel::select(const CandidateSet& set, const std::vector<float>& scores,
                                            const BoxParams& p) {
  std::vector<Detection> out;
  std::vector<std::uint32_t> order;
  out.reserve(set.candidates.size());
  order.reserve(set.candidates.size());
  select(set, scores, p, out, order);
  return out;
}

void TrainedModel::select(const CandidateSet& set, const std::vector<float>& scores, const BoxParams& p,
                          std::vector<Detection>& out, std::vector<std::uint32_t>& order) {
  const double threshold = p.score_threshold;
  const CrowdRule& crowd = p.crowd;
  out.clear();
  order.resize(set.candidates.size());
  std::iota(order.begin(), order.end(), std::uint32_t{0});
  // Descending score, ties in candidate order (std::sort does not allocate; stable_sort would).
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return scores[a] != scores[b] ? scores[a] > scores[b] : a < b; });
  // Below the threshold, a crowded image (crowd.count boxes kept above it) goes on to the crowd's.
  const bool crowd_lower = crowd.on() && crowd.threshold < threshold;
  for (std::uint32_t i : order) {
    if (scores[i] < threshold &&
        !(crowd_lower && scores[i] >= crowd.threshold && out.size() >= static_cast<std::size_t>(crowd.count)))
      break;
    const cv::Rect& b = set.candidates[i].box;
    const bool suppressed =
        std::any_of(out.begin(), out.end(), [&](const Detection& d) { return iou(d.box, b) > p.nms_iou; });
    if (suppressed) continue;
    out.push_back(Detection{b, scores[i], set.candidates[i].area});
  }
}

void TrainedModel::score_map(const CandidateSet& set, const std::vector<float>& scores, cv::Mat& map) {
  std::vector<int> spans;
  score_map(set, scores, map, spans);
}

void TrainedModel::score_map(const CandidateSet& set, const std::vector<float>& scores, cv::Mat& map,
                             std::vector<int>& spans) {
  map.create(set.size, CV_32F);
  for (int y = 0; y < map.rows; ++y) std::fill(map.ptr<float>(y), map.ptr<float>(y) + map.cols, 0.0f);
  if (set.sources <= 0) return;
  const float per_source = 1.0f / static_cast<float>(set.sources);
  spans.resize(2 * static_cast<std::size_t>(map.rows + map.cols));  // no-op once sized
  for (size_t i = 0; i < set.candidates.size(); ++i) {
    const RockCandidate& c = set.candidates[i];
    const float w = scores[i] * per_source;
    const int bx = c.box.x, by = c.box.y, bw = c.box.width, bh = c.box.height;
    // Per source of the candidate: its blob filled to the pixels that lie between the blob's
    // first and last pixel both along their row and along their column in the box (holes and
    // notches closed; the outline's outer bends kept, unlike a convex hull).
    int* row_first = spans.data();
    int* row_last = row_first + bh;
    int* col_first = row_last + bh;
    int* col_last = col_first + bw;
    for (unsigned bits = c.source_bits; bits != 0u; bits &= bits - 1u) {
      const unsigned bit = bits & (~bits + 1u);
      std::fill(row_first, row_first + bh, bw);
      std::fill(row_last, row_last + bh, -1);
      std::fill(col_first, col_first + bw, bh);
      std::fill(col_last, col_last + bw, -1);
      for (int y = 0; y < bh; ++y) {
        const uchar* sp = set.source_masks.ptr<uchar>(by + y) + bx;
        for (int x = 0; x < bw; ++x) {
          if ((sp[x] & bit) == 0u) continue;
          row_first[y] = std::min(row_first[y], x);
          row_last[y] = x;
          col_first[x] = std::min(col_first[x], y);
          col_last[x] = y;
        }
      }
      for (int y = 0; y < bh; ++y) {
        float* mp = map.ptr<float>(by + y) + bx;
        for (int x = row_first[y]; x <= row_last[y]; ++x)
          if (y >= col_first[x] && y <= col_last[x]) mp[x] += w;
      }
    }
  }
  for (int y = 0; y < map.rows; ++y)
    for (float* p = map.ptr<float>(y); p != map.ptr<float>(y) + map.cols; ++p) *p = std::min(*p, 1.0f);
}

void TrainedModel::BoxScratch::reserve(cv::Size map, std::size_t candidate_count) {
  order.reserve(candidate_count);
  if (map.empty()) return;
  // no-ops once sized: the words of any box of the map, the parts of the largest box
  above.create(map.height, map.width);
  parts.reserve(map.height, map.width);
  sums.reserve(static_cast<std::size_t>(map.height) * static_cast<std::size_t>((map.width + 1) / 2));
}

void TrainedModel::guide_map(const cv::Mat& intensity, cv::Mat& map, GuidedFilter& filter) {
  filter.apply(intensity, map, map, 0.0f, 1.0f);
}

int TrainedModel::map_guide_radius_px(int image_width_px) const {
  const int working = candidates.working_width_px;
  if (working <= 0 || image_width_px <= 0) return kMapGuideRadiusPx;
  return std::max(1, static_cast<int>(std::lround(kMapGuideRadiusPx * static_cast<double>(image_width_px) / working)));
}

void TrainedModel::refine(const cv::Mat& map, double fraction, std::vector<Detection>& dets, BoxScratch& scratch) {
  if (!(fraction > 0.0) || dets.empty()) return;
  CV_Assert(map.type() == CV_32FC1);
  const cv::Rect frame(0, 0, map.cols, map.rows);
  for (Detection& d : dets) {
    const cv::Rect roi = d.box & frame;
    if (roi.empty()) continue;
    float peak = 0.f;
    for (int y = roi.y; y < roi.br().y; ++y)
      for (const float* p = map.ptr<float>(y) + roi.x; p != map.ptr<float>(y) + roi.br().x; ++p)
        peak = std::max(peak, *p);
    if (!(peak > 0.f)) continue;
    const auto cut = static_cast<float>(fraction * peak);
    BitMask& above = scratch.above;
    above.create(roi.height, roi.width);
    for (int y = 0; y < roi.height; ++y) {
      const float* p = map.ptr<float>(roi.y + y) + roi.x;
      std::uint64_t* bits = above.row(y);
      std::fill(bits, bits + above.words(), std::uint64_t{0});
      for (int x = 0; x < roi.width; ++x)
        if (p[x] >= cut) bits[x / 64] |= std::uint64_t{1} << (x % 64);
    }
    const int n = scratch.parts.run(above);
    scratch.sums.assign(static_cast<std::size_t>(n), 0.0);
    scratch.parts.for_each_run([&](int part, int row, int begin, int end) {
      const float* p = map.ptr<float>(roi.y + row) + roi.x;
      double& sum = scratch.sums[static_cast<std::size_t>(part)];
      for (int x = begin; x < end; ++x) sum += static_cast<double>(p[x]);
    });
    const auto best = std::max_element(scratch.sums.begin(), scratch.sums.end());  // the first of equal sums
    if (best == scratch.sums.end() || !(*best > 0.0)) continue;
    const std::array<int, 5>& st = scratch.parts.stats(static_cast<int>(best - scratch.sums.begin()));
    d.box = cv::Rect(roi.x + st[0], roi.y + st[1], st[2], st[3]);
  }
}

void TrainedModel::boxes(const CandidateSet& set, const std::vector<float>& scores, const cv::Mat& map,
                         const BoxParams& p, std::vector<Detection>& out, BoxScratch& scratch) {
  select(set, scores, p, out, scratch.order);
  refine(map, p.refine_fraction, out, scratch);
}

std::vector<Detection> TrainedModel::detect(const CandidateSet& set) const {
  const std::vector<float> s = score(set);
  cv::Mat map;
  if (box.refine_fraction > 0.0) score_map(set, s, map);
  std::vector<Detection> out;
  BoxScratch scratch;
  boxes(set, s, map, box, out, scratch);
  return out;
}

void TrainedModel::save(const std::string& path) const {
  if (!trained()) throw ModelError(path + ": cannot save an untrained model");
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) throw ModelError(path + ": cannot open for writing");
    fs << "format" << kTrainedModelFormat;
    fs << "version" << kTrainedModelVersion;
    fs << "feature_count" << kFeatureCount;
    fs << "features"
       << "[";
    for (const auto& n : feature_names()) fs << n;
    fs << "]";
    fs << "candidates"
       << "{";
    fs << "coarse_sigma_px" << candidates.coarse.sigma_px << "coarse_smooth_px" << candidates.coarse.smooth_sigma_px;
    fs << "fine_sigma_px" << candidates.fine.sigma_px << "fine_smooth_px" << candidates.fine.smooth_sigma_px;
    fs << "coarse_scales" << candidates.coarse_scales << "fine_scales" << candidates.fine_scales;
    fs << "chroma_sigma_px" << candidates.chroma.sigma_px << "chroma_smooth_px" << candidates.chroma.smooth_sigma_px;
    fs << "chroma_scales" << candidates.chroma_scales;
    fs << "min_area_px" << candidates.min_area << "open_radius_px" << candidates.open_radius << "close_radius_px"
       << candidates.close_radius;
    fs << "working_width_px" << candidates.working_width_px;
    fs << "}";
    fs << "score_threshold" << box.score_threshold << "nms_iou" << box.nms_iou << "box_refine_fraction"
       << box.refine_fraction;
    fs << "crowd_count" << box.crowd.count << "crowd_threshold" << box.crowd.threshold;
    fs << "training_images" << training_images << "training_samples" << training_samples << "training_positives"
       << training_positives;
    fs << "forest"
       << "{";
    forest_->rtrees->write(fs);
    fs << "}";
    fs.release();
  } catch (const cv::Exception& e) {
    throw ModelError(path + ": cannot write model (" + trim_blanks(e.msg) + ")");
  }
  if (!std::filesystem::is_regular_file(path)) throw ModelError(path + ": model file not written");
}

TrainedModel TrainedModel::load(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw ModelError(path + ": rock model file not found");
  TrainedModel m;
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) throw ModelError(path + ": cannot read rock model file");
    const std::string format = fs["format"].isString() ? static_cast<std::string>(fs["format"]) : "";
    if (format != kTrainedModelFormat)
      throw ModelError(path + ": not a regolith rock model (format '" + format + "', expected '" + kTrainedModelFormat +
                       "')");
    const int version = fs["version"].isInt() ? static_cast<int>(fs["version"]) : -1;
    if (version != kTrainedModelVersion)
      throw ModelError(path + ": rock model version " + std::to_string(version) + ", this build reads version " +
                       std::to_string(kTrainedModelVersion) + " (re-train with `regolith train rocks`)");
    if (static_cast<int>(fs["feature_count"]) != kFeatureCount)
      throw ModelError(path + ": rock model has " + std::to_string(static_cast<int>(fs["feature_count"])) +
                       " features, this build computes " + std::to_string(kFeatureCount));
    const cv::FileNode c = fs["candidates"];
    if (!c.isMap()) throw ModelError(path + ": rock model: missing 'candidates'");
    m.candidates.coarse.sigma_px = static_cast<double>(c["coarse_sigma_px"]);
    m.candidates.coarse.smooth_sigma_px = static_cast<double>(c["coarse_smooth_px"]);
    m.candidates.fine.sigma_px = static_cast<double>(c["fine_sigma_px"]);
    m.candidates.fine.smooth_sigma_px = static_cast<double>(c["fine_smooth_px"]);
    c["coarse_scales"] >> m.candidates.coarse_scales;
    c["fine_scales"] >> m.candidates.fine_scales;
    m.candidates.chroma.sigma_px = static_cast<double>(c["chroma_sigma_px"]);
    m.candidates.chroma.smooth_sigma_px = static_cast<double>(c["chroma_smooth_px"]);
    c["chroma_scales"] >> m.candidates.chroma_scales;
    m.candidates.min_area = static_cast<int>(c["min_area_px"]);
    m.candidates.open_radius = static_cast<int>(c["open_radius_px"]);
    m.candidates.close_radius = static_cast<int>(c["close_radius_px"]);
    // absent in models written before 2026-11-28: each image at its own size, as they were trained
    m.candidates.working_width_px = c["working_width_px"].isInt() ? static_cast<int>(c["working_width_px"]) : 0;
    try {
      m.candidates.validate();
    } catch (const std::invalid_argument& e) {
      throw ModelError(path + ": rock model: " + e.what());
    }
    BoxParams& b = m.box;
    b.score_threshold = static_cast<double>(fs["score_threshold"]);
    b.nms_iou = static_cast<double>(fs["nms_iou"]);
    if (!(b.score_threshold >= 0.0 && b.score_threshold <= 1.0) || !(b.nms_iou > 0.0 && b.nms_iou <= 1.0))
      throw ModelError(path + ": rock model: score_threshold / nms_iou out of range");
    // absent in models written before 2026-12-06: the boxes as selected
    b.refine_fraction = fs["box_refine_fraction"].empty() ? 0.0 : static_cast<double>(fs["box_refine_fraction"]);
    if (!(b.refine_fraction >= 0.0 && b.refine_fraction < 1.0))
      throw ModelError(path + ": rock model: box_refine_fraction must be in [0, 1)");
    if (!fs["crowd_count"].empty()) {  // models written before 2026-12-07: no crowd rule
      b.crowd.count = static_cast<int>(fs["crowd_count"]);
      if (fs["crowd_threshold"].empty())
        throw ModelError(path + ": rock model: crowd_count without crowd_threshold (both or neither)");
      b.crowd.threshold = static_cast<double>(fs["crowd_threshold"]);
      if (b.crowd.count < 0) throw ModelError(path + ": rock model: crowd_count must be >= 0");
      if (!(b.crowd.threshold >= 0.0 && b.crowd.threshold <= 1.0))
        throw ModelError(path + ": rock model: crowd_threshold must be in [0, 1]");
    }
    m.training_images = static_cast<int>(fs["training_images"]);
    m.training_samples = static_cast<int>(fs["training_samples"]);
    m.training_positives = static_cast<int>(fs["training_positives"]);
    const cv::FileNode f = fs["forest"];
    if (!f.isMap()) throw ModelError(path + ": rock model: missing 'forest'");
    m.forest_ = std::make_shared<Forest>();
    m.forest_->rtrees = cv::ml::RTrees::create();
    m.forest_->rtrees->read(f);
    if (!m.forest_->rtrees->isTrained() || m.forest_->rtrees->getVarCount() != kFeatureCount)
      throw ModelError(path + ": rock model: the forest is empty or has the wrong input size");
    m.forest_->flatten();
  } catch (const ModelError&) {
    throw;
  } catch (const std::runtime_error& e) {  // Forest::flatten
    throw ModelError(path + ": " + e.what());
  } catch (const cv::Exception& e) {
    throw ModelError(path + ": corrupt rock model file (" + trim_blanks(e.msg) + ")");
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
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

// Out-of-fold scores of `frames` by an inner grouped CV, then the (threshold, NMS, refinement)
// with the best mean of N-MODA@0.2 and @0.5 over them (ties: the first in grid order), then the
// crowd rule for those (only when it beats them).
BoxParams choose_box_params(const std::vector<const LabelledFrame*>& frames, const TrainParams& tp) {
  std::vector<std::string> groups;
  for (const auto* f : frames) groups.push_back(f->group);
  std::vector<std::string> distinct = groups;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  const int k = std::min<int>(tp.inner_folds, static_cast<int>(distinct.size()));
  std::vector<std::vector<float>> scores(frames.size());
  if (k >= 2) {
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
  } else {
    return BoxParams{};
  }
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
  m.box = choose_box_params(frames, tparams);
  m.forest_ = std::make_shared<TrainedModel::Forest>();
  m.forest_->rtrees = fit_forest(frames, tparams, &m.training_samples, &m.training_positives);
  m.forest_->flatten();
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
  cv::Mat map, map8;
  std::vector<Detection> dets;
  TrainedModel::BoxScratch scratch;
  GuidedFilter guide(TrainedModel::kMapGuideRadiusPx, TrainedModel::kMapGuideEps);  // re-made per radius
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
      if (const int radius = m.map_guide_radius_px(map.cols); radius != guide.radius())
        guide = GuidedFilter(radius, TrainedModel::kMapGuideEps);
      TrainedModel::guide_map(frames[i].intensity, map, guide);
      to_8bit(map, map8);
      r.pooled[i] = evaluate_frame(frames[i].name, dets, frames[i].truth, map8);
    }
    r.fold_summaries.push_back(summarise(r.pooled, test));
  }
  return r;
}

std::string default_trained_model_path() {
  const std::string src = REGOLITH_ROCKS_MODEL_SOURCE;
  if (!src.empty() && std::filesystem::is_regular_file(src)) return src;
  const std::string inst = REGOLITH_ROCKS_MODEL_INSTALLED;
  if (!inst.empty()) return inst;
  return src;
}

}  // namespace regolith::saliency
