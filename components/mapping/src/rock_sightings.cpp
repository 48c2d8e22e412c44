#include "regolith/mapping/rock_sightings.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "regolith/common/box.hpp"
#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"
#include "regolith/mapping/tilt.hpp"

namespace regolith::mapping {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.sightings", field, why);
}

using common::fill;

// The camera seen through frames reduced `f` times (f = 2, 4, ...: 2x2 means, repeated): pixel (c, r) of the working
// frame covers camera pixels f c .. f c + f - 1, so its centre is at f c + (f - 1) / 2.
direct_depth::CameraModel reduced(direct_depth::CameraModel m, int f) {
  if (m.height / f < 1)
    fail("max_width_px", "a " + std::to_string(m.width) + "x" + std::to_string(m.height) + " camera reduced " +
                             std::to_string(f) +
                             "x to this width keeps no row: raise it (sighting_max_width_px), or 0 "
                             "for full size");
  const double shift = 0.5 * (f - 1);
  m.fx /= f, m.fy /= f;
  m.cx = (m.cx - shift) / f, m.cy = (m.cy - shift) / f;
  m.width /= f, m.height /= f;
  return m;
}

}  // namespace

int RockSightingParams::reduction(int width_px) const {
  int f = 1;
  while (max_width_px > 0 && width_px / f > max_width_px) f *= 2;
  return f;
}

RockSightingParams RockSightingParams::scaled_to_width(int width_px) const {
  if (width_px <= 0) fail("width", "must be > 0 px");
  const double s = static_cast<double>(width_px / reduction(width_px)) / kReferenceWidthPx;
  RockSightingParams p = *this;
  p.background_sigma_px = std::clamp(background_sigma_px * s, std::min(background_sigma_px, 4.0), 64.0);
  p.smooth_sigma_px = std::clamp(smooth_sigma_px * s, 0.0, 16.0);
  p.row_band_px = std::clamp(static_cast<int>(std::lround(row_band_px * s)), std::min(row_band_px, 1), 256);
  p.min_pixels = std::max(std::min(min_pixels, 4), static_cast<int>(std::lround(min_pixels * s * s)));
  p.max_pixels = std::max(p.min_pixels, static_cast<int>(std::min(1e9, std::round(max_pixels * s * s))));
  p.merge_gap_px = std::min(64, static_cast<int>(std::lround(merge_gap_px * std::max(1.0, s))));
  return p;
}

void RockSightingParams::validate() const {
  if (!std::isfinite(background_sigma_px) || background_sigma_px < 1 || background_sigma_px > 64)
    fail("background_sigma_px", "must be in [1, 64]");
  if (!std::isfinite(smooth_sigma_px) || smooth_sigma_px < 0 || smooth_sigma_px > 16)
    fail("smooth_sigma_px", "must be in [0, 16]");
  if (!std::isfinite(threshold) || threshold <= 0) fail("threshold", "must be > 0");
  if (min_pixels < 1) fail("min_pixels", "must be >= 1");
  if (row_band_px < 0 || row_band_px > 256) fail("row_band_px", "must be 0..256");
  if (max_pixels < min_pixels) fail("max_pixels", "must be >= min_pixels");
  if (!std::isfinite(max_range_m) || max_range_m <= 0) fail("max_range_m", "must be > 0");
  if (!std::isfinite(min_range_m) || min_range_m < 0 || min_range_m >= max_range_m)
    fail("min_range_m", "must be in [0, max_range_m)");
  if (!std::isfinite(min_height_m) || min_height_m < 0) fail("min_height_m", "must be >= 0");
  if (!std::isfinite(max_height_m) || max_height_m <= min_height_m) fail("max_height_m", "must be > min_height_m");
  if (max_sightings < 1 || max_sightings > 4096) fail("max_sightings", "must be 1..4096");
  if (merge_gap_px < 0 || merge_gap_px > 64) fail("merge_gap_px", "must be 0..64");
  if (!std::isfinite(tilt_sigma_rad) || tilt_sigma_rad < 0) fail("tilt_sigma_rad", "must be >= 0");
  if (!std::isfinite(footprint_per_height) || footprint_per_height < 0 || footprint_per_height > 5)
    fail("footprint_per_height", "must be in [0, 5]");
  if (!std::isfinite(silhouette_floor) || silhouette_floor < 0 || silhouette_floor > 1)
    fail("silhouette_floor", "must be in [0, 1]");
  if (max_width_px < 0 || (max_width_px > 0 && max_width_px < 16))
    fail("max_width_px", "must be 0 (full size) or at least 16 px");
}

RockSightings::RockSightings(const direct_depth::DirectDepth& depth, const RockSightingParams& params)
    : p_((params.validate(), params)),
      camera_(depth),
      f_(p_.reduction(depth.model().width)),
      work_(f_ > 1 ? std::make_unique<direct_depth::DirectDepth>(reduced(depth.model(), f_)) : nullptr),
      depth_(work_ ? *work_ : depth),
      rot_(depth.body_from_optical()) {
  for (int f = 2; f <= f_; f *= 2) halves_.emplace_back(depth.model().height / f, depth.model().width / f, CV_8U);
  const auto& m = depth_.model();
  for (cv::Mat* q : {&gray_f_, &img_, &bg_, &wimg_, &wsum_, &tmp_, &tmp2_}) q->create(m.height, m.width, CV_32F);
  mask_.create(m.height, m.width, CV_8U);
  label_.create(m.height, m.width, CV_32S);
  row_thr_.create(1, m.height, CV_32F);
  row_med_.create(1, m.height, CV_32F);
  acc_.create(1, m.width, CV_64F);
  values_.resize(static_cast<std::size_t>(m.width));  // one row's values and levels at a time (the row median)
  levels_.resize(static_cast<std::size_t>(m.width));
  stack_.resize(static_cast<std::size_t>(m.width) * static_cast<std::size_t>(m.height));
  table_.create(kSightRows, p_.max_sightings + 1, CV_32F);  // + a spare column for merge_halves
  fill(table_, kNaNf);
  x_ = table_.row(kSightX), y_ = table_.row(kSightY), h_ = table_.row(kSightHeight), w_ = table_.row(kSightWidth);
  s_ = table_.row(kSightScore), sr_ = table_.row(kSightSigmaRange), sl_ = table_.row(kSightSigmaLateral);
}

void RockSightings::blur(cv::Mat& m, double sigma) {
  // Three box passes of radius r approximate a Gaussian of sigma^2 = r (r + 1) (each pass adds
  // ((2r + 1)^2 - 1) / 12).
  if (sigma <= 0) return;
  const int r = std::max(1, static_cast<int>(std::lround((std::sqrt(1.0 + 4.0 * sigma * sigma) - 1.0) / 2.0)));
  const float norm = 1.0f / static_cast<float>((2 * r + 1) * (2 * r + 1));
  for (int pass = 0; pass < 3; ++pass) {
    common::box_sum(m, tmp2_, tmp_, r, &acc_);
    for (int i = 0; i < m.rows; ++i) {
      const float* s = tmp2_.ptr<float>(i);
      float* d = m.ptr<float>(i);
      for (int j = 0; j < m.cols; ++j) d[j] = s[j] * norm;
    }
  }
}

cv::Vec3d RockSightings::ray(double col, double row) const {
  const cv::Point2d q = depth_.normalised(col, row);
  return rot_ * cv::Vec3d(q.x, q.y, 1.0);
}

void RockSightings::contrast_and_thresholds() {
  // img_ = |gray - background| (smoothed); the ground's own contrast grows towards the horizon
  // (foreshortened texture): a threshold per row, k x the median over the seen pixels of the
  // rows within +-row_band_px.
  const int H = img_.rows, W = img_.cols;
  for (int i = 0; i < H; ++i) {
    const float* g = gray_f_.ptr<float>(i);
    const float* b = bg_.ptr<float>(i);
    float* a = img_.ptr<float>(i);
    for (int j = 0; j < W; ++j) a[j] = std::abs(g[j] - b[j]);
  }
  blur(img_, p_.smooth_sigma_px);
  const cv::Mat& valid = depth_.valid_map();
  float* med = row_med_.ptr<float>(0);
  // Each row's median (its (n / 2)-th smallest seen value, exactly): a histogram of the values in
  // quarter grey levels finds the level that holds it, and only that level's values are ordered.
  // The ground's contrast is a few grey levels, so whole levels would put a third of a row in the
  // median's bin. A value's level is 4 x it, truncated and clamped to 0..kLevels - 1 (NaN: 0),
  // made for the row at once (compare-selects the compiler vectorises); an unseen pixel adds 0 to
  // its level's count.
  constexpr int kLevels = 512;
  constexpr float kTop = static_cast<float>(kLevels - 1);
  std::uint16_t* lv = levels_.data();
  for (int i = 0; i < H; ++i) {
    const float* a = img_.ptr<float>(i);
    const uchar* v = valid.ptr<uchar>(i);
    for (int j = 0; j < W; ++j) {
      const float lo = a[j] > 0.0f ? 4.0f * a[j] : 0.0f;
      lv[j] = static_cast<std::uint16_t>(static_cast<int>(lo < kTop ? lo : kTop));
    }
    std::array<int, kLevels> hist{};
    int n = 0;
    for (int j = 0; j < W; ++j) {
      const int seen = v[j] != 0;
      hist[lv[j]] += seen;
      n += seen;
    }
    med[i] = std::numeric_limits<float>::quiet_NaN();
    if (n < 16) continue;
    int below = 0, b = 0;
    while (below + hist[static_cast<std::size_t>(b)] <= n / 2) below += hist[static_cast<std::size_t>(b++)];
    std::size_t m = 0;
    for (int j = 0; j < W; ++j)
      if (v[j] && lv[j] == b) values_[m++] = a[j];
    const auto k = static_cast<std::ptrdiff_t>(n / 2 - below);
    std::nth_element(values_.begin(), values_.begin() + k, values_.begin() + static_cast<std::ptrdiff_t>(m));
    med[i] = values_[static_cast<std::size_t>(k)];
  }
  float* row_thr = row_thr_.ptr<float>(0);
  for (int i = 0; i < H; ++i) {
    double sum = 0;
    int n = 0;
    for (int r = std::max(0, i - p_.row_band_px); r <= std::min(H - 1, i + p_.row_band_px); ++r)
      if (!std::isnan(med[r])) sum += med[r], ++n;
    row_thr[i] =
        n > 0 ? static_cast<float>(p_.threshold * std::max(sum / n, 0.5)) : std::numeric_limits<float>::infinity();
  }
}

const cv::Mat& RockSightings::reduce(const cv::Mat& gray) {
  const cv::Mat* src = &gray;
  for (cv::Mat& dst : halves_) {
    for (int i = 0; i < dst.rows; ++i) {
      const uchar* a = src->ptr<uchar>(2 * i);
      const uchar* b = src->ptr<uchar>(2 * i + 1);
      uchar* d = dst.ptr<uchar>(i);
      for (int j = 0; j < dst.cols; ++j)
        d[j] = static_cast<uchar>((a[2 * j] + a[2 * j + 1] + b[2 * j] + b[2 * j + 1] + 2) / 4);
    }
    src = &dst;
  }
  return *src;
}

int RockSightings::compute(const cv::Mat& camera_gray, const cv::Vec2d& tilt, const cv::Vec3d& sun) {
  const auto& cam = camera_.model();
  if (camera_gray.empty() || camera_gray.type() != CV_8UC1 || camera_gray.cols != cam.width ||
      camera_gray.rows != cam.height)
    fail("gray", "expected an 8-bit grey frame of " + std::to_string(cam.width) + "x" + std::to_string(cam.height));
  const cv::Mat& gray = reduce(camera_gray);
  const int H = gray.rows, W = gray.cols;
  if (!std::isfinite(sun[0]) || !std::isfinite(sun[1]) || !std::isfinite(sun[2]))
    fail("sun", "must be finite (zero: unknown)");
  count_ = 0;
  fill(table_, kNaNf);
  rot_ = tilt_rotation(tilt[0], tilt[1]) * depth_.body_from_optical();
  sun_ = sun;
  // Contrast against the local ground, in two passes: the second background leaves out what the
  // first found (a bright rock would otherwise lift the ground around it into a halo).
  for (int i = 0; i < H; ++i) {
    const uchar* s = gray.ptr<uchar>(i);
    float* g = gray_f_.ptr<float>(i);
    float* b = bg_.ptr<float>(i);
    for (int j = 0; j < W; ++j) g[j] = b[j] = s[j];
  }
  blur(bg_, p_.background_sigma_px);
  contrast_and_thresholds();
  for (int i = 0; i < H; ++i) {
    const float* g = gray_f_.ptr<float>(i);
    const float* a = img_.ptr<float>(i);
    const float thr = row_thr_.at<float>(0, i);
    float* wi = wimg_.ptr<float>(i);
    float* ws = wsum_.ptr<float>(i);
    for (int j = 0; j < W; ++j) {
      const bool ground = a[j] <= thr;
      wi[j] = ground ? g[j] : 0.0f;
      ws[j] = ground ? 1.0f : 0.0f;
    }
  }
  blur(wimg_, p_.background_sigma_px);
  blur(wsum_, p_.background_sigma_px);
  for (int i = 0; i < H; ++i) {
    const float* wi = wimg_.ptr<float>(i);
    const float* ws = wsum_.ptr<float>(i);
    float* b = bg_.ptr<float>(i);
    for (int j = 0; j < W; ++j)
      if (ws[j] > 0.05f) b[j] = wi[j] / ws[j];
  }
  contrast_and_thresholds();
  const cv::Mat& valid = depth_.valid_map();
  const float* row_thr = row_thr_.ptr<float>(0);
  for (int i = 0; i < H; ++i) {
    const float* a = img_.ptr<float>(i);
    const uchar* v = valid.ptr<uchar>(i);
    uchar* mk = mask_.ptr<uchar>(i);
    for (int j = 0; j < W; ++j) mk[j] = (v[j] && a[j] > row_thr[i]) ? 255 : 0;
  }
  fill(label_, 0);
  // Blobs by flood fill with a preallocated stack.
  int next = 0;
  for (int i0 = 0; i0 < H && count_ < p_.max_sightings; ++i0)
    for (int j0 = 0; j0 < W && count_ < p_.max_sightings; ++j0) {
      if (!mask_.at<uchar>(i0, j0) || label_.at<int>(i0, j0)) continue;
      ++next;
      int top = 0;
      stack_[static_cast<std::size_t>(top++)] = i0 * W + j0;
      label_.at<int>(i0, j0) = next;
      int pixels = 0, rmin = i0, rmax = i0, cmin = j0, cmax = j0;
      double contrast = 0.0;
      bool border = false;
      while (top > 0) {
        const int k = stack_[static_cast<std::size_t>(--top)];
        const int i = k / W, j = k % W;
        ++pixels;
        contrast += img_.at<float>(i, j) / row_thr[i];
        rmin = std::min(rmin, i), rmax = std::max(rmax, i), cmin = std::min(cmin, j), cmax = std::max(cmax, j);
        // The top edge cuts far rocks above their ground contact: kept unless keep_top_cut is off.
        if (j == 0 || i == H - 1 || j == W - 1 || (i == 0 && !p_.keep_top_cut)) border = true;
        for (int di = -1; di <= 1; ++di)
          for (int dj = -1; dj <= 1; ++dj) {
            const int a = i + di, b = j + dj;
            if (a < 0 || b < 0 || a >= H || b >= W || !mask_.at<uchar>(a, b) || label_.at<int>(a, b)) continue;
            label_.at<int>(a, b) = next;
            stack_[static_cast<std::size_t>(top++)] = a * W + b;
          }
      }
      if (border || pixels < p_.min_pixels || pixels > p_.max_pixels) continue;
      // Contact point: mean column of the blob's lowest row.
      double csum = 0;
      int cn = 0;
      for (int j = cmin; j <= cmax; ++j)
        if (label_.at<int>(rmax, j) == next) csum += j, ++cn;
      const double cb = cn > 0 ? csum / cn : 0.5 * (cmin + cmax);
      if (measure(count_, cb, rmin, rmax, cmin, cmax, std::clamp(contrast / pixels - 1.0, 0.05, 1.0))) ++count_;
    }
  if (p_.merge_halves) merge_halves();
  for (int k = 0; k < count_ && f_ > 1; ++k) {  // the boxes in camera pixels
    for (const SightingRow r : {kSightCol0, kSightRow0}) table_.at<float>(r, k) *= static_cast<float>(f_);
    for (const SightingRow r : {kSightCol1, kSightRow1})
      table_.at<float>(r, k) = table_.at<float>(r, k) * static_cast<float>(f_) + static_cast<float>(f_ - 1);
  }
  return count_;
}

bool RockSightings::measure(int k, double cb, int rmin, int rmax, int cmin, int cmax, double score) {
  const auto& cam = depth_.model();
  const double h = cam.mount_height_m;
  const cv::Vec3d d = ray(cb, rmax + 0.5);
  if (!(d[2] < -1e-6)) return false;
  const double t = h / -d[2];
  const cv::Vec2d g(t * d[0], t * d[1]);
  const double range_m = std::hypot(g[0], g[1]);
  if (range_m < p_.min_range_m || range_m > p_.max_range_m) return false;
  // Width: ground distance between the blob's side columns at the contact's depth.
  const cv::Vec3d dl = ray(cmin - 0.5, rmax + 0.5), dr = ray(cmax + 0.5, rmax + 0.5);
  if (!(dl[2] < -1e-6) || !(dr[2] < -1e-6)) return false;
  const double tl = h / -dl[2], tr = h / -dr[2];
  const double width = std::hypot(tl * dl[0] - tr * dr[0], tl * dl[1] - tr * dr[1]);
  const cv::Vec2d u = g / range_m;
  // Height: the top ray (through the blob's top, at the contact column) at the centre's
  // distance; centre = contact + the footprint radius, which the blob underestimates (a
  // dome's low flanks barely differ from the ground): at least footprint_per_height x the
  // height (two passes: the height depends on the centre's distance).
  const cv::Vec3d dt = ray(cb, rmin - 0.5);
  const double horiz = std::hypot(dt[0], dt[1]);
  if (!(horiz > 1e-9)) return false;
  double radius = 0.5 * width, height = 0.0;
  cv::Vec2d c = g + radius * u;
  const double tan_alpha = -dt[2] / horiz;
  for (int pass = 0; pass < 2; ++pass) {
    height = silhouette(h + std::hypot(c[0], c[1]) / horiz * dt[2], tan_alpha, u, radius);
    radius = std::max(0.5 * width, p_.footprint_per_height * std::max(height, 0.0));
    c = g + radius * u;
  }
  height = silhouette(h + std::hypot(c[0], c[1]) / horiz * dt[2], tan_alpha, u, radius);
  if (height < p_.min_height_m || height > p_.max_height_m) return false;
  x_.at<float>(0, k) = static_cast<float>(c[0]);
  y_.at<float>(0, k) = static_cast<float>(c[1]);
  h_.at<float>(0, k) = static_cast<float>(height);
  w_.at<float>(0, k) = static_cast<float>(width);
  s_.at<float>(0, k) = static_cast<float>(score);
  const double cr = std::hypot(c[0], c[1]);
  const double angle = std::hypot(1.0 / cam.fy, p_.tilt_sigma_rad);
  sr_.at<float>(0, k) = static_cast<float>((h * h + cr * cr) / h * angle + 0.25 * width);
  sl_.at<float>(0, k) = static_cast<float>(cr / cam.fx + 0.25 * width);
  table_.at<float>(kSightCol0, k) = static_cast<float>(cmin);
  table_.at<float>(kSightRow0, k) = static_cast<float>(rmin);
  table_.at<float>(kSightCol1, k) = static_cast<float>(cmax);
  table_.at<float>(kSightRow1, k) = static_cast<float>(rmax);
  table_.at<float>(kSightContactX, k) = static_cast<float>(g[0]);
  table_.at<float>(kSightContactY, k) = static_cast<float>(g[1]);
  table_.at<float>(kSightTopSlope, k) = static_cast<float>(dt[2] / horiz);
  return true;
}

double RockSightings::silhouette(double h_ray, double tan_alpha, const cv::Vec2d& view, double radius) const {
  // The far flank's brightness against flat ground (Lambertian, both lit): its normal is
  // perpendicular to the grazing ray, n = (sin alpha view, cos alpha), so n.s / s_z =
  // cos alpha + sin alpha (view . s_horizontal) / s_z. Below 1 (sun behind or beside the camera)
  // the flank is darker than the ground around it and the blob's top is the silhouette; above 1
  // (sun ahead) the lit flank blends into lit ground and the blob ends lower, near the apex's ray.
  if (!p_.silhouette_height || !(sun_[2] > 0) || !(tan_alpha > 0) || !(h_ray > 0)) return h_ray;
  const double cos_a = 1.0 / std::sqrt(1.0 + tan_alpha * tan_alpha), sin_a = tan_alpha * cos_a;
  const double flank = cos_a + sin_a * (view[0] * sun_[0] + view[1] * sun_[1]) / sun_[2];
  if (!(flank < 1.0)) return h_ray;
  const double reach = radius * tan_alpha;
  return std::max(p_.silhouette_floor * h_ray * cos_a, std::sqrt(std::max(0.0, h_ray * h_ray - reach * reach)));
}

void RockSightings::object_mask(cv::Mat& out, int margin_px) const {
  const auto& cam = camera_.model();
  if (out.type() != CV_8UC1 || out.cols != cam.width || out.rows != cam.height)
    fail("objects", "expected an 8-bit image of " + std::to_string(cam.width) + "x" + std::to_string(cam.height));
  if (f_ == 1) {
    mask_.copyTo(out);
  } else {  // each working pixel covers f_ x f_ camera pixels; a halving leaves the odd last row / column out
    out.setTo(0);
    const auto row_bytes = static_cast<std::size_t>(mask_.cols) * static_cast<std::size_t>(f_);
    for (int i = 0; i < mask_.rows; ++i) {
      const uchar* m = mask_.ptr<uchar>(i);
      uchar* o = out.ptr<uchar>(i * f_);
      for (int j = 0; j < mask_.cols; ++j)
        for (int c = 0; c < f_; ++c) o[j * f_ + c] = m[j];
      for (int r = 1; r < f_; ++r) std::memcpy(out.ptr<uchar>(i * f_ + r), o, row_bytes);
    }
  }
  const cv::Rect frame(0, 0, out.cols, out.rows);
  for (int k = 0; k < count_; ++k) {
    const auto at = [&](SightingRow r) { return static_cast<int>(table_.at<float>(r, k)); };
    const cv::Rect box(at(kSightCol0) - margin_px, at(kSightRow0) - margin_px,
                       at(kSightCol1) - at(kSightCol0) + 1 + 2 * margin_px,
                       at(kSightRow1) - at(kSightRow0) + 1 + 2 * margin_px);
    out(box & frame).setTo(255);
  }
}

void RockSightings::merge_halves() {
  // A rock lit from the side shows a bright and a dark half, each contrasting with the ground
  // on either side of a mid-tone line: two blobs side by side. Two sightings whose boxes overlap
  // vertically by at least half the shorter and whose columns touch (a gap of at most
  // merge_gap_px) are one rock, measured again from the union box (contact at its middle
  // column). The merged sighting takes the first one's column; the last column fills the hole.
  for (bool merged = true; merged;) {
    merged = false;
    for (int a = 0; a < count_ && !merged; ++a)
      for (int b = a + 1; b < count_ && !merged; ++b) {
        const auto box = [&](int k, SightingRow r) { return static_cast<int>(table_.at<float>(r, k)); };
        const int ar0 = box(a, kSightRow0), ar1 = box(a, kSightRow1), ac0 = box(a, kSightCol0),
                  ac1 = box(a, kSightCol1);
        const int br0 = box(b, kSightRow0), br1 = box(b, kSightRow1), bc0 = box(b, kSightCol0),
                  bc1 = box(b, kSightCol1);
        const int overlap = std::min(ar1, br1) - std::max(ar0, br0) + 1;
        const int gap = std::max(ac0, bc0) - std::min(ac1, bc1) - 1;
        if (overlap < (std::min(ar1 - ar0, br1 - br0) + 1) / 2 || gap > p_.merge_gap_px) continue;
        const int r0 = std::min(ar0, br0), r1 = std::max(ar1, br1), c0 = std::min(ac0, bc0), c1 = std::max(ac1, bc1);
        const double score = std::max(s_.at<float>(0, a), s_.at<float>(0, b));
        // Measure into the spare column after the last sighting (NaN, as every column from
        // count_ on), move it into a's place and the last sighting into b's, then clear both.
        if (count_ >= table_.cols || !measure(count_, 0.5 * (c0 + c1), r0, r1, c0, c1, score)) continue;
        for (int r = 0; r < kSightRows; ++r) {
          table_.at<float>(r, a) = table_.at<float>(r, count_);
          table_.at<float>(r, b) = table_.at<float>(r, count_ - 1);
          table_.at<float>(r, count_) = table_.at<float>(r, count_ - 1) = kNaNf;
        }
        --count_;
        merged = true;
      }
  }
}

}  // namespace regolith::mapping
