// Rock candidates and their features (trained.hpp, steps 1-2): CandidateParams,
// CandidateExtractor, feature_names().
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "regolith/saliency/image_ops.hpp"
#include "regolith/saliency/trained.hpp"

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
  if (w <= 0 || size.width <= 0) return size;
  const double s = static_cast<double>(w) / size.width;
  const double area = static_cast<double>(size.width) * size.height;
  const double most = kMaxWorkingAreaFactor * static_cast<double>(w) * w;
  if (area * s * s <= most) return {w, std::max(1, static_cast<int>(std::lround(size.height * s)))};
  // a narrow, tall image: the largest scale that keeps the working image within `most` pixels
  const double t = std::sqrt(most / area);
  return {std::max(1, static_cast<int>(std::lround(size.width * t))),
          std::max(1, static_cast<int>(std::lround(size.height * t)))};
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
  if (params_.working_width_px <= 0 && static_cast<double>(size.width) * size.height > kMaxUnscaledAreaPx)
    throw std::invalid_argument(std::to_string(size.width) + "x" + std::to_string(size.height) +
                                " px is more than the 2048x2048 px a rock model without a working width processes "
                                "(`regolith train rocks` gives its models one)");
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

}  // namespace regolith::saliency
