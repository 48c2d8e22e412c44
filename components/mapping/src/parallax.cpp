#include "regolith/mapping/parallax.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "regolith/common/box.hpp"
#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"
#include "regolith/mapping/cost_minimum.hpp"

namespace regolith::mapping {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
constexpr float kBig = 1e30f;

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.parallax", field, why);
}

using common::fill;

}  // namespace

void ParallaxParams::validate() const {
  if (!std::isfinite(resolution_m) || resolution_m <= 0) fail("resolution_m", "must be > 0");
  if (!std::isfinite(max_range_m) || max_range_m <= 0) fail("max_range_m", "must be > 0");
  if (!std::isfinite(min_range_m) || min_range_m < 0 || min_range_m >= max_range_m)
    fail("min_range_m", "must be in [0, max_range_m)");
  if (!std::isfinite(half_width_m) || half_width_m <= 0) fail("half_width_m", "must be > 0");
  if ((max_range_m - min_range_m) / resolution_m > 2048 || 2 * half_width_m / resolution_m > 2048)
    fail("resolution_m", "more than 2048 cells per side");
  if (!std::isfinite(min_baseline_m) || min_baseline_m <= 0) fail("min_baseline_m", "must be > 0");
  if (!std::isfinite(min_height_m) || min_height_m > 0) fail("min_height_m", "must be <= 0");
  if (!std::isfinite(max_height_m) || max_height_m <= 0) fail("max_height_m", "must be > 0");
  if (!std::isfinite(step_cells) || step_cells <= 0 || step_cells > 2) fail("step_cells", "must be in (0, 2]");
  if (window < 1 || window > 8) fail("window", "must be 1..8");
  if (!std::isfinite(noise_dn) || noise_dn <= 0) fail("noise_dn", "must be > 0");
  if (!(min_confidence >= 0 && min_confidence < 1)) fail("min_confidence", "must be in [0, 1)");
  if (!valid_uniqueness_ratio(uniqueness_ratio)) fail("uniqueness_ratio", "must be 0 (off) or in [1, 10]");
}

direct_depth::RectifiedGrid parallax_grid(const ParallaxParams& p) {
  p.validate();
  direct_depth::RectifiedGrid g;
  g.resolution_m = p.resolution_m;
  g.rows = std::max(1, static_cast<int>(std::ceil((p.max_range_m - p.min_range_m) / p.resolution_m)));
  g.cols = std::max(1, static_cast<int>(std::ceil(2.0 * p.half_width_m / p.resolution_m)));
  g.x_far_m = p.max_range_m;
  g.y_left_m = p.half_width_m;
  g.max_range_m = std::hypot(p.max_range_m, p.half_width_m);
  return g;
}

GroundParallax::GroundParallax(const direct_depth::DirectDepth& depth, const ParallaxParams& params)
    : p_((params.validate(), params)),
      rect_(depth, parallax_grid(p_)),
      grid_(rect_.grid()),
      h_(depth.model().mount_height_m) {
  if (!(h_ > p_.max_height_m)) fail("max_height_m", "must be below the camera height");
  for (cv::Mat* m :
       {&key_, &cur_, &e_, &c0_, &c1_, &c2_, &best_, &second_, &left_, &right_, &bests_, &tmp_, &z_, &x_, &y_, &conf_})
    m->create(grid_.rows, grid_.cols, CV_32F);
  for (cv::Mat* m : {&a_row_, &b_row_, &a_col_, &b_col_}) m->create(grid_.rows, grid_.cols, CV_32F);
  key_ok_.create(grid_.rows, grid_.cols, CV_8U);
  cur_ok_.create(grid_.rows, grid_.cols, CV_8U);
  cur_ok4_.create(grid_.rows, grid_.cols, CV_8U);
  spans_.resize(static_cast<std::size_t>(grid_.rows));
  proj_i_.resize(static_cast<std::size_t>(grid_.cols));
  proj_j_.resize(static_cast<std::size_t>(grid_.cols));
}

void GroundParallax::set_frame(const cv::Mat& gray) {
  rect_.resample(gray, cur_, 0.0, "gray");
  const cv::Mat& v = rect_.valid();
  for (int i = 0; i < cur_.rows; ++i) {
    const float* c = cur_.ptr<float>(i);
    const uchar* vv = v.ptr<uchar>(i);
    uchar* o = cur_ok_.ptr<uchar>(i);
    for (int j = 0; j < cur_.cols; ++j) o[j] = (vv[j] && c[j] > 3.0f && c[j] < 252.0f) ? 255 : 0;  // clipped = unusable
  }
}

void GroundParallax::promote() {
  std::swap(key_, cur_);
  std::swap(key_ok_, cur_ok_);
  has_key_ = true;
  // A keyframe cell outside the keyframe's view (or clipped) costs the penalty at every
  // hypothesis: written once per keyframe here (compute writes e_ only inside the spans), then
  // each row's search (samples, window sums, minima) runs only over its span of usable cells
  // (about half of the grid lies outside the camera's wedge). A cell outside the spans keeps no
  // minimum (bests_ -1); inside, every window sum is the whole grid's bit for bit.
  for (int i = 0; i < key_ok_.rows; ++i) {
    const uchar* ko = key_ok_.ptr<uchar>(i);
    float* e = e_.ptr<float>(i);
    const int C = key_ok_.cols;
    int lo = 0, hi = C;
    while (lo < C && !ko[lo]) ++lo;
    while (hi > lo && !ko[hi - 1]) --hi;
    spans_[static_cast<std::size_t>(i)] = {lo, hi};
    std::fill(e, e + lo, kUnusableSampleCost);
    std::fill(e + hi, e + C, kUnusableSampleCost);
  }
}

bool GroundParallax::compute(const Pose2& m, double gain, double bias, const cv::Vec2d& kt, const cv::Vec2d& ct,
                             double height_ratio) {
  const cv::Mat &key = key_, &key_ok = key_ok_, &cur = cur_, &cur_ok = cur_ok_;
  const double base = std::hypot(m.x, m.y);
  for (cv::Mat* q : {&z_, &x_, &y_}) fill(*q, kNaNf);
  fill(conf_, 0.0f);
  if (!has_key_ || !(base >= p_.min_baseline_m) || !m.finite() || !(height_ratio > 0.5 && height_ratio < 2.0))
    return false;
  const double bx = m.x / base, by = m.y / base;
  const Pose2 a = inverse(m);  // keyframe ground coordinates -> current
  const double ca = std::cos(a.yaw), sa = std::sin(a.yaw);
  // Displacements d = base (1 - k) for heights min..max (k = h / (h - z)).
  const double k_lo = h_ / (h_ - p_.min_height_m), k_hi = h_ / (h_ - p_.max_height_m);
  const double d_lo = base * (1 - k_hi), d_hi = base * (1 - k_lo);
  const double step = p_.step_cells * grid_.resolution_m;
  const int n = static_cast<int>(std::floor((d_hi - d_lo) / step)) + 1;
  fill(best_, kBig);
  fill(second_, kBig);
  fill(bests_, -1.0f);
  const int R = grid_.rows, C = grid_.cols;
  // A camera tilted by (pitch, roll) against the ground shows the ground point X at the nominal
  // rectified position X - D(X) tilt (first order; D as in GroundVisualOdometry).
  const double h = h_, ih = 1.0 / h_;
  auto shift = [&](double x, double y, const cv::Vec2d& t) {
    return cv::Point2d(-(h + x * x * ih) * t[0] + x * y * ih * t[1], -x * y * ih * t[0] + (h + y * y * ih) * t[1]);
  };
  auto true_ground = [&](const cv::Point2d& p, const cv::Vec2d& t) { return p + shift(p.x, p.y, t); };
  // Where keyframe cell (i, j) lands in the current grid for displacement d: its true ground
  // point moved d along the baseline, into the current camera's ground frame (rotated, shifted,
  // scaled by height_ratio: X = X0 + d xd, Y = Y0 + d yd), then shown where the current tilt puts
  // it (nominal: quadratic in X, Y). So the fractional cell is a0 + d b + d^2 c per axis, with a0
  // and b per cell and c the same for every cell; made once here, the search then costs two
  // multiply-adds per cell and hypothesis for the position.
  const double hr = height_ratio, t0 = ct[0], t1 = ct[1], ir = 1.0 / grid_.resolution_m;
  const double xd = hr * (ca * bx - sa * by), yd = hr * (sa * bx + ca * by);
  const double cr = -(xd * xd * t0 - xd * yd * t1) * ih * ir, cc = -(xd * yd * t0 - yd * yd * t1) * ih * ir;
  for (int i = 0; i < R; ++i) {
    float* ar = a_row_.ptr<float>(i);
    float* br = b_row_.ptr<float>(i);
    float* ac = a_col_.ptr<float>(i);
    float* bc = b_col_.ptr<float>(i);
    for (int j = 0; j < C; ++j) {
      const cv::Point2d pc = true_ground(grid_.center(i, j), kt);
      const double x0 = hr * (ca * pc.x - sa * pc.y + a.x), y0 = hr * (sa * pc.x + ca * pc.y + a.y);
      const double qx = x0 + (h + x0 * x0 * ih) * t0 - x0 * y0 * ih * t1;
      const double qy = y0 + x0 * y0 * ih * t0 - (h + y0 * y0 * ih) * t1;
      const double dqx = xd + (2 * x0 * xd * t0 - (x0 * yd + y0 * xd) * t1) * ih;
      const double dqy = yd + ((x0 * yd + y0 * xd) * t0 - 2 * y0 * yd * t1) * ih;
      const cv::Point2d cell = grid_.cell(qx, qy);  // its (row, column) at d = 0; b below is its slope
      ar[j] = static_cast<float>(cell.x);
      ac[j] = static_cast<float>(cell.y);
      br[j] = static_cast<float>(-dqx * ir);
      bc[j] = static_cast<float>(-dqy * ir);
    }
  }
  bilinear_footprint_usable(cur_ok, cur_ok4_);
  const float g = static_cast<float>(gain), o = static_cast<float>(bias);
  for (int t = 0; t < n; ++t) {
    const double d = d_lo + t * step;
    const float fd = static_cast<float>(d), kr = static_cast<float>(cr * d * d), kc = static_cast<float>(cc * d * d);
    for (int i = 0; i < R; ++i) {
      float* e = e_.ptr<float>(i);
      const float* kv = key.ptr<float>(i);
      const uchar* ko = key_ok.ptr<uchar>(i);
      const float* ar = a_row_.ptr<float>(i);
      const float* br = b_row_.ptr<float>(i);
      const float* ac = a_col_.ptr<float>(i);
      const float* bc = b_col_.ptr<float>(i);
      const common::ColumnSpan span = spans_[static_cast<std::size_t>(i)];
      float* pi = proj_i_.data();
      float* pj = proj_j_.data();
      // The row's positions first, branch-free (vectorised); then the checks and samples.
      for (int j = span.begin; j < span.end; ++j) {
        pi[j] = ar[j] + kr + br[j] * fd;
        pj[j] = ac[j] + kc + bc[j] * fd;
      }
      bilinear_costs(pi, pj, kv, ko, cur, cur_ok4_, g, o, span, e);
    }
    // Rolling three cost slices: c0 = t-2, c1 = t-1, c2 = t; a minimum at t-1 is bracketed.
    std::swap(c0_, c1_);
    std::swap(c1_, c2_);
    common::box_sum_spans(e_, c2_, tmp_, p_.window, spans_.data());
    if (t >= 2)
      keep_bracketed_minimum(c0_, c1_, c2_, best_, bests_, left_, right_, t, 0, R - 1, &second_, spans_.data());
  }
  // Sub-step minimum, height, true position and confidence.
  const double cells = (2 * p_.window + 1) * (2 * p_.window + 1);
  const double noise2 = p_.noise_dn * p_.noise_dn;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) {
      const float t = bests_.at<float>(i, j);
      const float b = best_.at<float>(i, j);
      if (t < 0 || b >= kUnusableSampleCost) continue;
      const double l = left_.at<float>(i, j), r = right_.at<float>(i, j);
      if (l >= kUnusableSampleCost || r >= kUnusableSampleCost) continue;
      double off = 0.0, conf = 0.0;
      if (!parabola_minimum(l, b, r, cells, noise2, off, conf)) continue;
      const double d = d_lo + (t + off) * step;
      const double k = 1.0 - d / base;
      if (!(k > 0)) continue;
      if (conf < p_.min_confidence) continue;
      if (!unique_minimum(b, second_.at<float>(i, j), p_.uniqueness_ratio, cells, noise2)) continue;
      const cv::Point2d pc = true_ground(grid_.center(i, j), kt);
      z_.at<float>(i, j) = static_cast<float>(h_ * (1.0 - 1.0 / k));
      x_.at<float>(i, j) = static_cast<float>(pc.x / k);
      y_.at<float>(i, j) = static_cast<float>(pc.y / k);
      conf_.at<float>(i, j) = static_cast<float>(conf);
    }
  if (p_.remove_plane) remove_plane();
  return true;
}

void GroundParallax::remove_plane() {
  // Weighted least-squares plane z = a x + b y + c over the confident cells, twice: the second
  // pass leaves out cells more than 3 cm off the first plane (rocks). A camera tilt the fit got
  // slightly wrong shows up as exactly such a plane; the ground's own slope is a plane too and
  // belongs to the pose, not to the relief.
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (int i = 0; i < z_.rows; ++i)
      for (int j = 0; j < z_.cols; ++j) {
        const float z = z_.at<float>(i, j);
        const double w = conf_.at<float>(i, j);
        if (!std::isfinite(z) || !(w > 0)) continue;
        if (pass == 1 && std::abs(z) > 0.03) continue;  // after the first removal: off-plane cells out
        const Eigen::Vector3d v(x_.at<float>(i, j), y_.at<float>(i, j), 1.0);
        a.noalias() += w * v * v.transpose();
        b.noalias() += w * z * v;
      }
    if (std::abs(a.determinant()) < 1e-9) return;
    const Eigen::Vector3d c = a.ldlt().solve(b);
    if (!c.allFinite()) return;
    for (int i = 0; i < z_.rows; ++i)
      for (int j = 0; j < z_.cols; ++j) {
        float& z = z_.at<float>(i, j);
        if (std::isfinite(z)) z -= static_cast<float>(c[0] * x_.at<float>(i, j) + c[1] * y_.at<float>(i, j) + c[2]);
      }
  }
}

}  // namespace regolith::mapping
