// SinkageEstimator: dynamic mask -> segmentation inside the mask -> morphology -> leg axis refit ->
// template comparison along the axis -> interface -> sinkage. All buffers are sized in the
// constructor; process() does not allocate.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "regolith/core/image_limits.hpp"
#include "regolith/sinkage/sinkage.hpp"

namespace regolith::sinkage {
namespace {

inline double sq(double v) {
  return v * v;
}

/// Blue chromaticity code: b - (r + g) / 2 in [-255, 255] mapped to [1, 255] (0 = outside mask).
/// The leg colour test of both segmentation passes: value >= vmin, saturation (v - min) / v >=
/// smin and hue (degrees, OpenCV's full-range HSV formula) in [hlo, hhi] (wrapping through 0 when
/// `wrap`). `v` / `mn` are the channel maximum / minimum.
inline bool in_hsv_range(int b, int g, int r, int v, int mn, float vmin, float smin, float hlo, float hhi, bool wrap) {
  const int dv = v - mn;
  if (!(static_cast<float>(v) >= vmin && dv > 0 && static_cast<float>(dv) >= smin * static_cast<float>(v)))
    return false;
  const float inv = 60.0F / static_cast<float>(dv);
  float hue;
  if (v == r) {
    hue = static_cast<float>(g - b) * inv;
    if (hue < 0.0F) hue += 360.0F;
  } else if (v == g) {
    hue = 120.0F + static_cast<float>(b - r) * inv;
  } else {
    hue = 240.0F + static_cast<float>(r - g) * inv;
  }
  return wrap ? (hue >= hlo || hue <= hhi) : (hue >= hlo && hue <= hhi);
}

inline std::uint8_t chroma_code(int b, int g, int r) {
  const int c = 2 * b - r - g;     // 2x chroma, [-510, 510]
  const int code = (c + 514) / 4;  // [1, 256]
  return static_cast<std::uint8_t>(std::min(code, 255));
}
inline double code_to_chroma(double code) {
  return code * 2.0 - 257.0;
}

/// Otsu threshold over histogram bins [1, 255]; returns the bin t (class 1 = code > t) and the
/// class means. Returns false when a class is empty.
bool otsu(const std::array<std::uint32_t, 256>& h, int& t_out, double& mu0, double& mu1) {
  double total = 0, sum = 0;
  for (int i = 1; i < 256; ++i) {
    total += h[static_cast<std::size_t>(i)];
    sum += static_cast<double>(i) * h[static_cast<std::size_t>(i)];
  }
  if (total < 2) return false;
  double w0 = 0, s0 = 0, best = -1;
  int best_t = -1;
  for (int t = 1; t < 255; ++t) {
    w0 += h[static_cast<std::size_t>(t)];
    s0 += static_cast<double>(t) * h[static_cast<std::size_t>(t)];
    const double w1 = total - w0;
    if (w0 <= 0 || w1 <= 0) continue;
    const double m0 = s0 / w0, m1 = (sum - s0) / w1;
    const double between = w0 * w1 * sq(m0 - m1);
    if (between > best) {
      best = between;
      best_t = t;
      mu0 = m0;
      mu1 = m1;
    }
  }
  t_out = best_t;
  return best_t > 0;
}

/// Separable square min (erode) or max (dilate) filter of radius r on 0/255 images of equal size,
/// ignoring pixels outside the image. src and dst must differ; tmp is scratch of the same size.
void minmax_filter(const cv::Mat& src, cv::Mat& tmp, cv::Mat& dst, int r, bool is_min) {
  const int w = src.cols, h = src.rows;
  // horizontal: tmp = op over x +- r
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* s = src.ptr<std::uint8_t>(y);
    std::uint8_t* t = tmp.ptr<std::uint8_t>(y);
    std::memcpy(t, s, static_cast<std::size_t>(w));
    for (int dx = 1; dx <= r; ++dx) {
      if (dx >= w) break;
      // t[x] op= s[x + dx] for x < w - dx ; t[x] op= s[x - dx] for x >= dx
      if (is_min) {
        for (int x = 0; x < w - dx; ++x) t[x] = std::min(t[x], s[x + dx]);
        for (int x = dx; x < w; ++x) t[x] = std::min(t[x], s[x - dx]);
      } else {
        for (int x = 0; x < w - dx; ++x) t[x] = std::max(t[x], s[x + dx]);
        for (int x = dx; x < w; ++x) t[x] = std::max(t[x], s[x - dx]);
      }
    }
  }
  // vertical: dst = op over y +- r
  for (int y = 0; y < h; ++y) {
    std::uint8_t* d = dst.ptr<std::uint8_t>(y);
    std::memcpy(d, tmp.ptr<std::uint8_t>(y), static_cast<std::size_t>(w));
    const int y0 = std::max(0, y - r), y1 = std::min(h - 1, y + r);
    for (int yy = y0; yy <= y1; ++yy) {
      if (yy == y) continue;
      const std::uint8_t* t = tmp.ptr<std::uint8_t>(yy);
      if (is_min) {
        for (int x = 0; x < w; ++x) d[x] = std::min(d[x], t[x]);
      } else {
        for (int x = 0; x < w; ++x) d[x] = std::max(d[x], t[x]);
      }
    }
  }
}

}  // namespace

SinkageEstimator::SinkageEstimator(const WheelGeometry& geometry, const SinkageParams& params, cv::Size image_size)
    : geometry_(geometry), params_(params), size_(image_size) {
  geometry_.validate();
  params_.validate();
  if (image_size.width < 8 || image_size.height < 8 || image_size.width > kMaxImageSidePx ||
      image_size.height > kMaxImageSidePx) {
    throw std::invalid_argument("SinkageEstimator: image_size must be within [8, " + std::to_string(kMaxImageSidePx) +
                                "] px (got " + std::to_string(image_size.width) + "x" +
                                std::to_string(image_size.height) + ")");
  }
  mm_per_px_ = params_.scale_mm_per_px(geometry_);
  mask_ = cv::Mat::zeros(size_, CV_8UC1);
  seg_ = cv::Mat::zeros(size_, CV_8UC1);
  chroma_ = cv::Mat::zeros(size_, CV_8UC1);
  tmp_ = cv::Mat::zeros(size_, CV_8UC1);
  tmp2_ = cv::Mat::zeros(size_, CV_8UC1);
  clean_ = cv::Mat::zeros(size_, CV_8UC1);
  const double reach =
      std::hypot(geometry_.leg_length_px, 0.5 * geometry_.foot_width_px) + params_.mask_margin_px + 4.0;
  bins_.assign(static_cast<std::size_t>(std::ceil(reach)) + 2, {0, 0, 0, 0});
  s0_ = geometry_.hub_radius_px + 1.0;
  n_along_ = std::max(1, static_cast<int>(std::floor(geometry_.leg_length_px - s0_)) + 1);
  col_half_ = 0.7 * 0.5 * geometry_.leg_width_px;
  n_cols_ = std::min(static_cast<int>(col_y_.size()) - 1, 2 * std::max(1, static_cast<int>(std::floor(col_half_))) + 1);
  cols_.assign(static_cast<std::size_t>(n_cols_ * n_along_), 2);
  prev_full_ = true;
}

void SinkageEstimator::reset_filter() {
  history_count_ = 0;
  history_head_ = 0;
  ema_init_ = false;
}

SinkageEstimator::Roi SinkageEstimator::leg_roi(double phi) const {
  const double m = params_.mask_margin_px;
  const double hw = std::max(0.5 * geometry_.leg_width_px, 0.5 * geometry_.foot_width_px) + m;
  const double s_lo = std::max(0.0, geometry_.hub_radius_px - m);
  const double s_hi = geometry_.leg_length_px + m;
  double xmin = 1e18, xmax = -1e18, ymin = 1e18, ymax = -1e18;
  constexpr int kSteps = 6;
  for (int i = 0; i <= kSteps; ++i) {
    const double a =
        phi - params_.angle_tolerance_rad + 2.0 * params_.angle_tolerance_rad * i / static_cast<double>(kSteps);
    const double sa = std::sin(a), ca = std::cos(a);
    for (double s : {s_lo, s_hi}) {
      for (double t : {-hw, hw}) {
        const double x = geometry_.hub_center_px.x + s * sa + t * ca;
        const double y = geometry_.hub_center_px.y + s * ca - t * sa;
        xmin = std::min(xmin, x);
        xmax = std::max(xmax, x);
        ymin = std::min(ymin, y);
        ymax = std::max(ymax, y);
      }
    }
  }
  const int pad = 2 + std::max(params_.open_kernel_px, params_.close_kernel_px) / 2;
  Roi r;
  r.x0 = std::max(0, static_cast<int>(std::floor(xmin)) - pad);
  r.y0 = std::max(0, static_cast<int>(std::floor(ymin)) - pad);
  r.x1 = std::min(size_.width, static_cast<int>(std::ceil(xmax)) + pad + 1);
  r.y1 = std::min(size_.height, static_cast<int>(std::ceil(ymax)) + pad + 1);
  if (r.empty()) r = Roi{};
  return r;
}

// One pass over the leg's ROI: dynamic-mask test (swept template), and when `segment` is set,
// HSV band test + blue-chroma code for the pixels inside the mask.
void SinkageEstimator::build_mask_and_segment(int slot, double phi, const Roi& roi, const cv::Mat& bgr, bool segment) {
  const auto bit = static_cast<std::uint8_t>(1U << (slot % 8));
  const double m = params_.mask_margin_px;
  const double d = params_.angle_tolerance_rad;
  const double s_lo = std::max(0.0, geometry_.hub_radius_px - m);
  const double foot_start = geometry_.leg_length_px - geometry_.foot_thickness_px;
  const double s_hi = geometry_.leg_length_px + m;
  const double hw_leg = 0.5 * geometry_.leg_width_px + m;
  const double hw_foot = geometry_.half_width_at(geometry_.leg_length_px) + m;
  const double r_lo2 = sq(s_lo);
  const double r_hi2 = sq(std::hypot(geometry_.leg_length_px, hw_foot - m) + m);
  const double sa = std::sin(phi - d), ca = std::cos(phi - d);
  const double sb = std::sin(phi + d), cb = std::cos(phi + d);
  const double sp = std::sin(phi), cp = std::cos(phi);
  const double cx = geometry_.hub_center_px.x, cy = geometry_.hub_center_px.y;

  const float vmin = static_cast<float>(params_.val_min * 255.0);
  const float smin = static_cast<float>(params_.sat_min);
  const float hlo = static_cast<float>(params_.hue_min_deg);
  const float hhi = static_cast<float>(params_.hue_max_deg);
  const bool hue_wrap = hlo > hhi;

  auto inside_rect = [&](double along, double across) {
    if (along < s_lo || along > s_hi) return false;
    const double hw = (along >= foot_start) ? hw_foot : hw_leg;
    return std::abs(across) <= hw;
  };

  for (int y = roi.y0; y < roi.y1; ++y) {
    const double py = y - cy;
    std::uint8_t* mrow = mask_.ptr<std::uint8_t>(y);
    std::uint8_t* srow = seg_.ptr<std::uint8_t>(y);
    std::uint8_t* crow = chroma_.ptr<std::uint8_t>(y);
    const std::uint8_t* img = segment ? bgr.ptr<std::uint8_t>(y) : nullptr;
    for (int x = roi.x0; x < roi.x1; ++x) {
      const double px = x - cx;
      const double across_a = px * ca - py * sa;  // > 0: pixel angle above phi - d
      const double across_b = px * cb - py * sb;  // < 0: pixel angle below phi + d
      bool in;
      if (across_a >= 0.0 && across_b <= 0.0) {
        const double r2 = px * px + py * py;
        in = (px * sp + py * cp) > 0.0 && r2 >= r_lo2 && r2 <= r_hi2;
      } else if (across_a < 0.0) {
        in = inside_rect(px * sa + py * ca, across_a);
      } else {
        in = inside_rect(px * sb + py * cb, across_b);
      }
      if (!segment) {
        if (in) mrow[x] = static_cast<std::uint8_t>(mrow[x] | bit);
        continue;
      }
      if (!in) {
        srow[x] = 0;
        crow[x] = 0;
        continue;
      }
      mrow[x] = static_cast<std::uint8_t>(mrow[x] | bit);
      const int b = img[3 * x], g = img[3 * x + 1], r = img[3 * x + 2];
      const int v = std::max(b, std::max(g, r));
      const int mn = std::min(b, std::min(g, r));
      const std::uint8_t code = chroma_code(b, g, r);
      crow[x] = code;
      ++hist_[code];
      ++mask_count_;
      value_sum_ += v;
      std::uint8_t leg = 0;
      if (in_hsv_range(b, g, r, v, mn, vmin, smin, hlo, hhi, hue_wrap)) {
        leg = 255;
        ++hsv_count_;
      }
      srow[x] = leg;
    }
  }
}

void SinkageEstimator::threshold_adaptive(const Roi& roi) {
  int t = 0;
  double mu0 = 0, mu1 = 0;
  const bool ok =
      otsu(hist_, t, mu0, mu1) && (code_to_chroma(mu1) - code_to_chroma(mu0)) >= params_.adaptive_min_separation;
  for (int y = roi.y0; y < roi.y1; ++y) {
    const std::uint8_t* c = chroma_.ptr<std::uint8_t>(y);
    std::uint8_t* s = seg_.ptr<std::uint8_t>(y);
    if (!ok) {
      std::memset(s + roi.x0, 0, static_cast<std::size_t>(roi.x1 - roi.x0));
      continue;
    }
    for (int x = roi.x0; x < roi.x1; ++x) s[x] = c[x] > t ? 255 : 0;
  }
}

void SinkageEstimator::morphology(const Roi& roi, const cv::Mat& src_full, cv::Mat& dst_full) {
  const cv::Rect rect(roi.x0, roi.y0, roi.x1 - roi.x0, roi.y1 - roi.y0);
  const cv::Mat src = src_full(rect);
  cv::Mat dst = dst_full(rect);
  cv::Mat a = tmp_(rect);
  cv::Mat b = tmp2_(rect);
  const int ro = params_.open_kernel_px / 2, rc = params_.close_kernel_px / 2;
  if (ro == 0 && rc == 0) {
    src.copyTo(dst);  // same size and type: no reallocation
    return;
  }
  // opening: erode then dilate (src -> dst); closing: dilate then erode (dst -> dst)
  if (ro > 0) {
    minmax_filter(src, a, b, ro, true);
    minmax_filter(b, a, dst, ro, false);
  } else {
    src.copyTo(dst);
  }
  if (rc > 0) {
    minmax_filter(dst, a, b, rc, false);
    minmax_filter(b, a, dst, rc, true);
  }
}

void SinkageEstimator::segment_full_frame(const cv::Mat& bgr, bool force_adaptive) {
  const Roi full{0, 0, size_.width, size_.height};
  // Reuse the masked pass with an always-true mask: emulate by a sweep covering everything.
  // (Implemented directly to keep the comparison honest: every pixel is classified.)
  const float vmin = static_cast<float>(params_.val_min * 255.0);
  const float smin = static_cast<float>(params_.sat_min);
  const float hlo = static_cast<float>(params_.hue_min_deg);
  const float hhi = static_cast<float>(params_.hue_max_deg);
  const bool hue_wrap = hlo > hhi;
  hist_.fill(0);
  mask_count_ = 0;
  hsv_count_ = 0;
  value_sum_ = 0;
  for (int y = 0; y < size_.height; ++y) {
    const std::uint8_t* img = bgr.ptr<std::uint8_t>(y);
    std::uint8_t* srow = seg_.ptr<std::uint8_t>(y);
    std::uint8_t* crow = chroma_.ptr<std::uint8_t>(y);
    for (int x = 0; x < size_.width; ++x) {
      const int b = img[3 * x], g = img[3 * x + 1], r = img[3 * x + 2];
      const int v = std::max(b, std::max(g, r));
      const int mn = std::min(b, std::min(g, r));
      const std::uint8_t code = chroma_code(b, g, r);
      crow[x] = code;
      ++hist_[code];
      value_sum_ += v;
      std::uint8_t leg = 0;
      if (in_hsv_range(b, g, r, v, mn, vmin, smin, hlo, hhi, hue_wrap)) leg = 255;
      srow[x] = leg;
    }
  }
  mask_count_ = static_cast<std::uint64_t>(size_.area());
  bool adaptive = force_adaptive;
  if (params_.mode == SegmentationMode::kAuto) {
    adaptive = value_sum_ / (255.0 * static_cast<double>(mask_count_)) < params_.dark_mean_value;
  }
  if (adaptive) threshold_adaptive(full);
  adaptive_frame_ = adaptive;
  morphology(full, seg_, clean_);
}

bool SinkageEstimator::fit_axis(double phi_enc, double along_max, double& phi) const {
  double sxx = 0, syy = 0, sxy = 0, n = 0;
  const auto lo = static_cast<std::size_t>(std::max(0.0, geometry_.hub_radius_px));
  const auto hi = std::min(bins_.size(), static_cast<std::size_t>(std::max(0.0, along_max)));
  for (std::size_t i = lo; i < hi; ++i) {
    sxx += bins_[i][0];
    syy += bins_[i][1];
    sxy += bins_[i][2];
    n += bins_[i][3];
  }
  if (n < 20) return false;
  // principal axis through the hub: direction (ux, uy) maximising sum (p . u)^2
  const double alpha = 0.5 * std::atan2(2.0 * sxy, sxx - syy);  // from +x towards +y
  double ux = std::cos(alpha), uy = std::sin(alpha);
  if (ux * std::sin(phi_enc) + uy * std::cos(phi_enc) < 0.0) {
    ux = -ux;
    uy = -uy;
  }
  double p = std::atan2(ux, uy);
  double diff = std::remainder(p - phi_enc, 2.0 * std::numbers::pi);
  const double tol = params_.angle_tolerance_rad;
  diff = std::clamp(diff, -tol, tol);
  phi = phi_enc + diff;
  return true;
}

// Samples the cleaned segmentation on a grid of columns parallel to the leg axis (inner 70 % of the
// shaft width), one sample per px from the hub radius to the tip.
void SinkageEstimator::sample_columns(double phi, const Roi& roi) {
  const double sp = std::sin(phi), cp = std::cos(phi);
  const double cx = geometry_.hub_center_px.x, cy = geometry_.hub_center_px.y;
  const int half = n_cols_ / 2;
  for (int j = 0; j < n_cols_; ++j) {
    const double t = (j - half) * (col_half_ / std::max(1, half));
    std::uint8_t* col = cols_.data() + static_cast<std::ptrdiff_t>(j) * n_along_;
    for (int i = 0; i < n_along_; ++i) {
      const double s = s0_ + i;
      const int x = static_cast<int>(std::lround(cx + s * sp + t * cp));
      const int y = static_cast<int>(std::lround(cy + s * cp - t * sp));
      if (x < roi.x0 || x >= roi.x1 || y < roi.y0 || y >= roi.y1) {
        col[i] = 2;
      } else {
        col[i] = clean_.ptr<std::uint8_t>(y)[x] != 0 ? 1 : 0;
      }
    }
  }
}

// Per column: step fit (visible prefix, buried suffix) giving the image y where the column's visible
// part ends (its template end when not cut). A horizontal soil line y_s predicts
// min(y_s, end(column)) for every column; y_s is the L1 best fit over the candidates {column ends,
// +inf}, refined by the mean of the cut columns that agree with it. Robust to a few columns cut
// short by noise. Returns false when too few columns are known.
bool SinkageEstimator::fit_interface(double phi, double& soil_y, double& agreement, int& cut_columns,
                                     int& known_columns) {
  const double sp = std::sin(phi), cp = std::cos(phi);
  const double cy = geometry_.hub_center_px.y;
  const double plz = geometry_.leg_length_px;
  const int half = n_cols_ / 2;
  double agree_sum = 0;
  known_columns = 0;
  cut_columns = 0;
  for (int j = 0; j < n_cols_; ++j) {
    const std::uint8_t* col = cols_.data() + static_cast<std::ptrdiff_t>(j) * n_along_;
    int g = 0, best = 0, k = 0, known = 0, zeros = 0, last_known = -1;
    for (int i = 0; i < n_along_; ++i) {
      if (col[i] == 2) continue;
      ++known;
      last_known = i;
      if (col[i] != 0) {
        ++g;
      } else {
        --g;
        ++zeros;
      }
      if (g > best) {
        best = g;
        k = i + 1;
      }
    }
    if (known * 2 < n_along_) continue;
    const double t = (j - half) * (col_half_ / std::max(1, half));
    const auto idx = static_cast<std::size_t>(known_columns++);
    agree_sum += static_cast<double>(best + zeros) / known;
    col_end_[idx] = cy + plz * cp - t * sp;
    if (k > last_known) {
      col_y_[idx] = col_end_[idx];  // visible up to the tip
    } else {
      col_y_[idx] = std::min(col_end_[idx], cy + (s0_ + k - 0.5) * cp - t * sp);
      ++cut_columns;
    }
  }
  if (known_columns * 2 < n_cols_) return false;
  agreement = agree_sum / known_columns;
  const auto n = static_cast<std::size_t>(known_columns);
  auto cost = [&](double ys) {
    double c = 0;
    for (std::size_t i = 0; i < n; ++i) c += std::abs(col_y_[i] - std::min(ys, col_end_[i]));
    return c;
  };
  double best_y = std::numeric_limits<double>::infinity();
  double best_c = cost(best_y);
  for (std::size_t i = 0; i < n; ++i) {
    if (col_y_[i] >= col_end_[i]) continue;  // not a cut column
    const double c = cost(col_y_[i]);
    if (c < best_c - 1e-9) {
      best_c = c;
      best_y = col_y_[i];
    }
  }
  soil_y = best_y;
  if (!std::isfinite(best_y)) return true;
  double sum = 0;
  int m = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (col_end_[i] > best_y + 0.5 && std::abs(col_y_[i] - best_y) <= 3.0) {
      sum += col_y_[i];
      ++m;
    }
  }
  if (m > 0) soil_y = sum / m;
  return true;
}

void SinkageEstimator::analyse_leg(int slot, double phi_enc, const Roi& roi, LegSinkage& leg) {
  const auto bit = static_cast<std::uint8_t>(1U << (slot % 8));
  const double cx = geometry_.hub_center_px.x, cy = geometry_.hub_center_px.y;
  const double plz = geometry_.leg_length_px;
  leg.encoder_angle_rad = phi_enc;
  leg.angle_rad = phi_enc;
  leg.tip_px = {cx + plz * std::sin(phi_enc), cy + plz * std::cos(phi_enc)};

  // 1. axial moment bins of the leg's segmented pixels inside its mask
  for (auto& b : bins_) b = {0, 0, 0, 0};
  const double sp = std::sin(phi_enc), cp = std::cos(phi_enc);
  const double nb = static_cast<double>(bins_.size() - 1);
  int count = 0;
  for (int y = roi.y0; y < roi.y1; ++y) {
    const std::uint8_t* mrow = mask_.ptr<std::uint8_t>(y);
    const std::uint8_t* crow = clean_.ptr<std::uint8_t>(y);
    const double py = y - cy;
    for (int x = roi.x0; x < roi.x1; ++x) {
      if ((mrow[x] & bit) == 0 || crow[x] == 0) continue;
      const double px = x - cx;
      const double along = std::clamp(px * sp + py * cp, 0.0, nb);
      auto& b = bins_[static_cast<std::size_t>(along)];
      b[0] += px * px;
      b[1] += py * py;
      b[2] += px * py;
      b[3] += 1.0;
      ++count;
    }
  }
  leg.leg_pixels = count;
  if (count < 20) {
    leg.reason = InvalidReason::kNoLegPixels;
    return;
  }

  double phi = phi_enc;
  if (params_.refine_leg_angle) fit_axis(phi_enc, static_cast<double>(bins_.size()), phi);

  double soil_y = 0, agreement = 0;
  int cut = 0, known = 0;
  for (int pass = 0; pass < 2; ++pass) {
    sample_columns(phi, roi);
    if (!fit_interface(phi, soil_y, agreement, cut, known)) {
      leg.reason = InvalidReason::kOutsideImage;
      return;
    }
    if (pass == 0 && params_.refine_leg_angle && std::isfinite(soil_y)) {
      // refit the axis without the slanted cut region, then sample again
      const double vis = (soil_y - cy) / std::max(1e-6, std::cos(phi));
      const double cut_len = geometry_.half_width_at(plz) * std::min(3.0, std::abs(std::tan(phi)));
      double phi2 = phi;
      if (fit_axis(phi_enc, vis - cut_len - 2.0, phi2) && std::abs(phi2 - phi) > 1e-4) {
        phi = phi2;
        continue;
      }
    }
    break;
  }
  const double s0 = s0_;
  const double cphi = std::max(1e-6, std::cos(phi));
  const double tip_y = cy + plz * cphi;
  double visible = plz;
  if (std::isfinite(soil_y) && soil_y < tip_y) visible = (soil_y - cy) / cphi;
  visible = std::clamp(visible, s0 - 1.0, plz);
  leg.angle_rad = phi;
  leg.visible_length_px = visible;
  leg.tip_px = {cx + plz * std::sin(phi), cy + plz * std::cos(phi)};
  const double hw = geometry_.half_width_at(visible);
  const cv::Point2d c{cx + visible * std::sin(phi), cy + visible * std::cos(phi)};
  const cv::Point2d nrm{std::cos(phi), -std::sin(phi)};
  leg.interface_left_px = c - hw * nrm;
  leg.interface_right_px = c + hw * nrm;
  leg.sinkage_px = std::max(0.0, (plz - visible) * std::cos(phi));
  leg.sinkage_mm = leg.sinkage_px * mm_per_px_;
  leg.confidence = std::clamp(2.0 * agreement - 1.0, 0.0, 1.0);
  if (visible - s0 < params_.min_visible_px) {
    leg.reason = InvalidReason::kNoLegPixels;
    leg.confidence = 0;
    return;
  }
  if (leg.confidence < params_.min_confidence) {
    leg.reason = InvalidReason::kLowConfidence;
    return;
  }
  leg.valid = true;
  leg.in_contact = leg.sinkage_mm > params_.contact_min_mm;
  leg.reason = InvalidReason::kNone;
}

double SinkageEstimator::apply_filter(double z) {
  switch (params_.filter) {
    case TemporalFilter::kNone: return z;
    case TemporalFilter::kEma:
      if (!ema_init_) {
        ema_ = z;
        ema_init_ = true;
      } else {
        ema_ = params_.ema_alpha * z + (1.0 - params_.ema_alpha) * ema_;
      }
      return ema_;
    case TemporalFilter::kMedian: {
      const int w = params_.median_window;
      history_[static_cast<std::size_t>(history_head_)] = z;
      history_head_ = (history_head_ + 1) % w;
      history_count_ = std::min(history_count_ + 1, w);
      std::copy_n(history_.begin(), history_count_, sort_buf_.begin());
      auto mid = sort_buf_.begin() + history_count_ / 2;
      std::nth_element(sort_buf_.begin(), mid, sort_buf_.begin() + history_count_);
      return *mid;
    }
  }
  return z;
}

void SinkageEstimator::process(const cv::Mat& bgr, double wheel_angle_rad, SinkageResult& out) {
  if (bgr.empty()) throw std::invalid_argument("SinkageEstimator::process: bgr: empty image");
  if (bgr.type() != CV_8UC3) {
    throw std::invalid_argument("SinkageEstimator::process: bgr: expected CV_8UC3 (got type " +
                                std::to_string(bgr.type()) + ")");
  }
  if (bgr.size() != size_) {
    throw std::invalid_argument("SinkageEstimator::process: bgr: expected " + std::to_string(size_.width) + "x" +
                                std::to_string(size_.height) + " (got " + std::to_string(bgr.cols) + "x" +
                                std::to_string(bgr.rows) + ")");
  }
  ++diag_.frames;
  out.valid = false;
  out.sinkage_mm = 0;
  out.raw_sinkage_mm = 0;
  out.confidence = 0;
  out.deepest = -1;
  out.used_adaptive = false;
  out.leg_count = 0;
  out.reason = InvalidReason::kNone;

  // clear the previous frame's mask
  if (prev_full_) {
    mask_.setTo(0);
    prev_full_ = false;
  } else {
    for (std::size_t i = 0; i < prev_roi_count_; ++i) {
      const Roi& r = prev_rois_[i];
      for (int y = r.y0; y < r.y1; ++y) {
        std::memset(mask_.ptr<std::uint8_t>(y) + r.x0, 0, static_cast<std::size_t>(r.x1 - r.x0));
      }
    }
  }
  prev_roi_count_ = 0;

  auto finish_invalid = [&](InvalidReason r) {
    out.reason = r;
    ++diag_.frame_reasons[static_cast<std::size_t>(r)];
  };
  if (!std::isfinite(wheel_angle_rad)) {
    finish_invalid(InvalidReason::kBadAngle);
    return;
  }

  const bool masked = params_.use_dynamic_mask;
  if (!masked) segment_full_frame(bgr, params_.mode == SegmentationMode::kAdaptive);

  int slot = 0;
  for (int k = 0; k < geometry_.leg_count && slot < static_cast<int>(kMaxLegs); ++k) {
    const double phi = geometry_.leg_angle(k, wheel_angle_rad);
    if (std::abs(phi) > params_.contact_half_angle_rad) continue;
    LegSinkage& leg = out.legs[static_cast<std::size_t>(slot)];
    leg = LegSinkage{};
    leg.leg = k;
    leg.encoder_angle_rad = phi;
    leg.angle_rad = phi;
    const Roi roi = leg_roi(phi);
    ++out.leg_count;
    if (roi.empty() || (roi.x1 - roi.x0) < 4 || (roi.y1 - roi.y0) < 4) {
      leg.reason = InvalidReason::kOutsideImage;
      ++diag_.leg_reasons[static_cast<std::size_t>(leg.reason)];
      ++slot;
      continue;
    }
    prev_rois_[prev_roi_count_++] = roi;
    if (masked) {
      hist_.fill(0);
      mask_count_ = 0;
      hsv_count_ = 0;
      value_sum_ = 0;
      build_mask_and_segment(slot, phi, roi, bgr, true);
      bool adaptive = params_.mode == SegmentationMode::kAdaptive;
      if (params_.mode == SegmentationMode::kAuto && mask_count_ > 0) {
        adaptive = value_sum_ / (255.0 * static_cast<double>(mask_count_)) < params_.dark_mean_value;
      }
      if (adaptive) {
        threshold_adaptive(roi);
        out.used_adaptive = true;
      }
      morphology(roi, seg_, clean_);
    } else {
      build_mask_and_segment(slot, phi, roi, bgr, false);
      out.used_adaptive = adaptive_frame_;
    }
    analyse_leg(slot, phi, roi, leg);
    ++diag_.leg_reasons[static_cast<std::size_t>(leg.reason)];
    ++slot;
  }

  if (out.leg_count == 0) {
    finish_invalid(InvalidReason::kNoContactLeg);
    return;
  }
  // wheel sinkage: deepest valid leg
  int best = -1;
  for (std::size_t i = 0; i < out.leg_count; ++i) {
    const LegSinkage& l = out.legs[i];
    if (!l.valid) continue;
    if (best < 0 || l.sinkage_mm > out.legs[static_cast<std::size_t>(best)].sinkage_mm) {
      best = static_cast<int>(i);
    }
  }
  if (best < 0) {
    // report the reason of the leg nearest straight down
    std::size_t nearest = 0;
    for (std::size_t i = 1; i < out.leg_count; ++i) {
      if (std::abs(out.legs[i].encoder_angle_rad) < std::abs(out.legs[nearest].encoder_angle_rad)) {
        nearest = i;
      }
    }
    finish_invalid(out.legs[nearest].reason);
    return;
  }
  const LegSinkage& deep = out.legs[static_cast<std::size_t>(best)];
  out.valid = true;
  out.deepest = best;
  out.raw_sinkage_mm = deep.sinkage_mm;
  out.sinkage_mm = apply_filter(deep.sinkage_mm);
  out.confidence = deep.confidence;
  ++diag_.valid_frames;
  if (out.used_adaptive) ++diag_.adaptive_frames;
  ++diag_.frame_reasons[0];
}

}  // namespace regolith::sinkage
