#include "regolith/mapping/plane_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/box.hpp"
#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"
#include "regolith/mapping/cost_minimum.hpp"
#include "regolith/mapping/tilt.hpp"

namespace regolith::mapping {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
constexpr float kBig = 1e30f;

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.sweep", field, why);
}

using common::fill;

}  // namespace

void PlaneSweepParams::validate() const {
  if (!std::isfinite(max_range_m) || max_range_m <= 0) fail("max_range_m", "must be > 0");
  if (!std::isfinite(min_range_m) || min_range_m < 0 || min_range_m >= max_range_m)
    fail("min_range_m", "must be in [0, max_range_m)");
  if (!std::isfinite(min_baseline_m) || min_baseline_m <= 0) fail("min_baseline_m", "must be > 0");
  if (!std::isfinite(min_height_m) || min_height_m > 0) fail("min_height_m", "must be <= 0");
  if (!std::isfinite(max_height_m) || max_height_m <= 0) fail("max_height_m", "must be > 0");
  if (!std::isfinite(step_px) || step_px <= 0 || step_px > 4) fail("step_px", "must be in (0, 4]");
  if (max_steps < 4 || max_steps > 1024) fail("max_steps", "must be 4..1024");
  if (max_width_px < 32) fail("max_width_px", "must be >= 32");
  if (window < 1 || window > 8) fail("window", "must be 1..8");
  if (!std::isfinite(noise_dn) || noise_dn <= 0) fail("noise_dn", "must be > 0");
  if (!(min_confidence >= 0 && min_confidence < 1)) fail("min_confidence", "must be in [0, 1)");
  if (!std::isfinite(reference_step_m) || reference_step_m <= 0) fail("reference_step_m", "must be > 0");
  if (!valid_uniqueness_ratio(uniqueness_ratio)) fail("uniqueness_ratio", "must be 0 (off) or in [1, 10]");
}

PlaneSweep::PlaneSweep(const direct_depth::DirectDepth& depth, const PlaneSweepParams& params)
    : p_((params.validate(), params)), depth_(depth), h_(depth.model().mount_height_m) {
  if (!(h_ > p_.max_height_m)) fail("max_height_m", "must be below the camera height");
  const auto& m = depth.model();
  // Working scale: whole 2x2 (4x4, ...) pixel blocks until the width fits max_width_px.
  while (m.width / scale_ > p_.max_width_px && m.height / (2 * scale_) >= 16) scale_ *= 2;
  const int H = m.height / scale_, W = m.width / scale_;
  const double f = scale_;
  fx_ = m.fx / f, fy_ = m.fy / f, cx_ = (m.cx + 0.5) / f - 0.5, cy_ = (m.cy + 0.5) / f - 0.5;
  if (m.has_distortion()) {
    // Undistorted images keep the camera matrix: afterwards every pixel is a pinhole ray.
    const cv::Matx33d K(m.fx, 0, m.cx, 0, m.fy, m.cy, 0, 0, 1);
    const cv::Vec<double, 5> D(m.k1, m.k2, m.p1, m.p2, m.k3);
    cv::initUndistortRectifyMap(K, D, cv::Matx33d::eye(), K, cv::Size(m.width, m.height), CV_32FC1, undist_x_,
                                undist_y_);
    undist_.create(m.height, m.width, CV_8U);
  }
  nrm_.create(H, W, CV_32FC3);
  const cv::Matx33d& r = depth.body_from_optical();
  for (int i = 0; i < H; ++i)
    for (int j = 0; j < W; ++j) {
      const cv::Vec3d d = r * cv::Vec3d((j - cx_) / fx_, (i - cy_) / fy_, 1.0);
      nrm_.at<cv::Vec3f>(i, j) =
          cv::Vec3f(static_cast<float>(d[0]), static_cast<float>(d[1]), static_cast<float>(d[2]));
    }
  for (cv::Mat* q : {&key_, &cur_, &ox_, &oy_, &oz_, &e_, &c0_, &c1_, &c2_, &best_, &second_, &left_, &right_, &bests_,
                     &tmp_, &z_, &x_, &y_, &conf_})
    q->create(H, W, CV_32F);
  key_ok_.create(H, W, CV_8U);
  cur_ok_.create(H, W, CV_8U);
  cur_ok4_.create(H, W, CV_8U);
  row_step_.create(H, 1, CV_64F);
  row_n_.assign(static_cast<std::size_t>(H), 0);
  row_last_.assign(static_cast<std::size_t>(H), 0);
  row_last_e_.assign(static_cast<std::size_t>(H), 0);
  proj_u_.create(1, W, CV_32F);
  proj_v_.create(1, W, CV_32F);
  fill(z_, kNaNf);
  fill(x_, kNaNf);
  fill(y_, kNaNf);
  fill(conf_, 0.0f);
}

void PlaneSweep::load(const cv::Mat& gray, cv::Mat& img, cv::Mat& ok) {
  const auto& m = depth_.model();
  if (gray.empty() || gray.type() != CV_8UC1 || gray.cols != m.width || gray.rows != m.height)
    fail("gray", "expected an 8-bit grey frame of " + std::to_string(m.width) + "x" + std::to_string(m.height));
  const cv::Mat* src = &gray;
  if (!undist_x_.empty()) {
    cv::remap(gray, undist_, undist_x_, undist_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    src = &undist_;
  }
  // Block means at the working scale; a block with a clipped pixel is unusable.
  const int f = scale_;
  const float inv = 1.0f / static_cast<float>(f * f);
  for (int i = 0; i < img.rows; ++i) {
    float* d = img.ptr<float>(i);
    uchar* o = ok.ptr<uchar>(i);
    for (int j = 0; j < img.cols; ++j) {
      int sum = 0;
      bool usable = true;
      for (int a = 0; a < f; ++a) {
        const uchar* s = src->ptr<uchar>(i * f + a) + j * f;
        for (int b = 0; b < f; ++b) {
          sum += s[b];
          usable = usable && s[b] > 3 && s[b] < 252;
        }
      }
      d[j] = static_cast<float>(sum) * inv;
      o[j] = usable ? 255 : 0;
    }
  }
}

void PlaneSweep::set_frame(const cv::Mat& gray) {
  load(gray, cur_, cur_ok_);
}

void PlaneSweep::promote() {
  std::swap(key_, cur_);
  std::swap(key_ok_, cur_ok_);
  has_key_ = true;
}

bool PlaneSweep::compute(const Pose2& m, double gain, double bias, const cv::Vec2d& kt, const cv::Vec2d& ct,
                         double height_ratio) {
  fill(z_, kNaNf);
  fill(x_, kNaNf);
  fill(y_, kNaNf);
  fill(conf_, 0.0f);
  samples_ = 0;
  const double base = std::hypot(m.x, m.y);
  if (!has_key_ || !m.finite() || !(base >= p_.min_baseline_m) || !std::isfinite(gain) || !std::isfinite(bias) ||
      !(height_ratio > 0.5 && height_ratio < 2.0))
    return false;
  const Sweep sweep = project_rays(m, kt, ct, height_ratio);
  if (sweep.steps < 3) return false;
  sweep_costs(sweep, gain, bias);
  read_heights(sweep);
  return true;
}

PlaneSweep::Sweep PlaneSweep::project_rays(const Pose2& m, const cv::Vec2d& kt, const cv::Vec2d& ct,
                                           double height_ratio) {
  const int H = key_.rows, W = key_.cols;
  const double h = h_;
  // Rays of the keyframe camera as tilted against the ground; the current camera's rotation.
  const cv::Matx33d rk = tilt_rotation(kt[0], kt[1]);
  const cv::Matx33d rc_t = (tilt_rotation(ct[0], ct[1]) * depth_.body_from_optical()).t();
  const double cy = std::cos(m.yaw), sy = std::sin(m.yaw);
  auto to_cur = [&](double x, double y) { return cv::Vec2d(cy * x + sy * y, -sy * x + cy * y); };  // R(-yaw)
  // A keyframe point P(w) = (w g, h (1 - w)) (g = the pixel's ground point, z = h (1 - w)) is seen
  // by the current camera (height h / height_ratio) at o(w) = o0 + w o1 (camera coordinates):
  // o0 = Rc^T (R(-yaw)(-t), h - h / height_ratio), o1 = Rc^T (R(-yaw) g, -h).
  const cv::Vec2d t0 = to_cur(-m.x, -m.y);
  const cv::Vec3d o0 = rc_t * cv::Vec3d(t0[0], t0[1], h - h / height_ratio);
  const double w_lo = 1.0 - p_.max_height_m / h, w_hi = 1.0 - p_.min_height_m / h;
  const double fx = fx_, fy = fy_;
  const double r2min = p_.min_range_m * p_.min_range_m, r2max = p_.max_range_m * p_.max_range_m;
  int max_n = 0;
  for (int i = 0; i < H; ++i) {
    const cv::Vec3f* n = nrm_.ptr<cv::Vec3f>(i);
    float *ox = ox_.ptr<float>(i), *oy = oy_.ptr<float>(i), *oz = oz_.ptr<float>(i);
    float* gx = x_.ptr<float>(i);  // ground point, kept in x_/y_ until the results overwrite them
    float* gy = y_.ptr<float>(i);
    double max_disp2 = 0.0;
    for (int j = 0; j < W; ++j) {
      ox[j] = kNaNf;
      const cv::Vec3d d = rk * cv::Vec3d(n[j][0], n[j][1], n[j][2]);
      if (!(d[2] < -1e-6)) continue;
      const double tg = h / -d[2];
      const double g0 = tg * d[0], g1 = tg * d[1], r2 = g0 * g0 + g1 * g1;
      if (g0 * g0 < r2min || r2 > r2max || g0 <= 0) continue;
      const cv::Vec2d gc = to_cur(g0, g1);
      const cv::Vec3d o1 = rc_t * cv::Vec3d(gc[0], gc[1], -h);
      const cv::Vec3d o = o0 + o1;  // the ground point (w = 1)
      if (!(o[2] > 1e-3)) continue;
      // Image motion per unit w at the ground: d(u, v) / dw.
      const double du = fx * (o1[0] * o[2] - o[0] * o1[2]) / (o[2] * o[2]);
      const double dv = fy * (o1[1] * o[2] - o[1] * o1[2]) / (o[2] * o[2]);
      max_disp2 = std::max(max_disp2, du * du + dv * dv);
      // o1 with the focal lengths applied (the sweep's projection needs them only so)
      ox[j] = static_cast<float>(fx * o1[0]), oy[j] = static_cast<float>(fy * o1[1]), oz[j] = static_cast<float>(o1[2]);
      gx[j] = static_cast<float>(g0), gy[j] = static_cast<float>(g1);
    }
    const double max_disp = std::sqrt(max_disp2);  // the largest image motion per unit w (px)
    double step = max_disp > 0 ? p_.step_px / max_disp : (w_hi - w_lo);
    step = std::max(step, (w_hi - w_lo) / (p_.max_steps - 1));
    row_step_.at<double>(i) = step;
    row_n_[static_cast<std::size_t>(i)] = max_disp > 0 ? static_cast<int>(std::ceil((w_hi - w_lo) / step)) + 1 : 0;
    max_n = std::max(max_n, row_n_[static_cast<std::size_t>(i)]);
  }
  return {.o0 = o0, .w_lo = w_lo, .steps = max_n};
}

void PlaneSweep::sweep_costs(const Sweep& sweep, double gain, double bias) {
  const int H = key_.rows, W = key_.cols;
  const double fx = fx_, fy = fy_, cx = cx_, ccy = cy_;
  const cv::Vec3d& o0 = sweep.o0;
  const double w_lo = sweep.w_lo;
  const int max_n = sweep.steps;
  // Only the rows that hold swept pixels (plus the matching window) are matched.
  int r0 = H, r1 = -1;
  for (int i = 0; i < H; ++i) {
    const float* ox = ox_.ptr<float>(i);
    for (int j = 0; j < W; ++j)
      if (!std::isnan(ox[j])) {
        r0 = std::min(r0, i), r1 = std::max(r1, i);
        break;
      }
  }
  r0 = std::max(0, r0 - p_.window);
  r1 = std::min(H - 1, r1 + p_.window);
  // Each row's last t: of its minima (its row_n_ hypotheses and one to bracket the last), and of
  // its costs (the latest of the rows whose window holds it).
  for (int i = r0; i <= r1; ++i)
    row_last_[static_cast<std::size_t>(i)] = std::min(row_n_[static_cast<std::size_t>(i)], max_n - 1);
  for (int i = r0; i <= r1; ++i) {
    int last = -1;
    for (int k = std::max(r0, i - p_.window); k <= std::min(r1, i + p_.window); ++k)
      last = std::max(last, row_last_[static_cast<std::size_t>(k)]);
    row_last_e_[static_cast<std::size_t>(i)] = last;
  }
  cv::Mat e_rows = e_.rowRange(r0, r1 + 1), tmp_rows = tmp_.rowRange(r0, r1 + 1);
  fill(best_, kBig);
  fill(second_, kBig);
  fill(bests_, -1.0f);
  bilinear_footprint_usable(cur_ok_, cur_ok4_);
  const float g = static_cast<float>(gain), b = static_cast<float>(bias);
  // The projection in float with one reciprocal (u, v to ~1e-5 px at these sizes); ox_ / oy_ hold
  // fx o1 and fy o1.
  const float fax = static_cast<float>(fx * o0[0]), fay = static_cast<float>(fy * o0[1]),
              az = static_cast<float>(o0[2]);
  const float fcx = static_cast<float>(cx), fcy = static_cast<float>(ccy);
  constexpr float kNear = 1e-3f;  // depth in front of the current camera below which a point is not sampled
  const cv::v_float32x4 vfax = cv::v_setall_f32(fax), vfay = cv::v_setall_f32(fay), vaz = cv::v_setall_f32(az),
                        vfcx = cv::v_setall_f32(fcx), vfcy = cv::v_setall_f32(fcy), vone = cv::v_setall_f32(1.0f),
                        vnear = cv::v_setall_f32(kNear), vnan = cv::v_setall_f32(kNaNf);
  float* pu = proj_u_.ptr<float>(0);
  float* pv = proj_v_.ptr<float>(0);
  // A window spans rows of one hypothesis index t (each row at its own height for t), so a row's
  // costs are made while a neighbour in its window still sweeps; its own minima are kept only up
  // to one step past its range (that step brackets the last), so a valley below min_height (a
  // neighbour's range) never displaces one inside the row's own.
  for (int t = 0; t < max_n; ++t) {
    long active = 0;
    for (int i = r0; i <= r1; ++i) {
      if (t > row_last_e_[static_cast<std::size_t>(i)]) continue;
      ++active;
      const float *ox = ox_.ptr<float>(i), *oy = oy_.ptr<float>(i), *oz = oz_.ptr<float>(i);
      const float* kv = key_.ptr<float>(i);
      const uchar* ko = key_ok_.ptr<uchar>(i);
      float* e = e_.ptr<float>(i);
      const float w = static_cast<float>(w_lo + t * row_step_.at<double>(i));
      // The row's projections first, four lanes at a time (the same operations as the scalar
      // tail), NaN where the pixel is not swept or the point is not ahead of the current camera.
      const cv::v_float32x4 vw = cv::v_setall_f32(w);
      int j = 0;
      for (; j + cv::v_float32x4::nlanes <= W; j += cv::v_float32x4::nlanes) {
        const cv::v_float32x4 qz = vaz + vw * cv::v_load(oz + j);
        const cv::v_float32x4 iq = vone / qz;
        cv::v_store(pu + j, cv::v_select(qz > vnear, (vfax + vw * cv::v_load(ox + j)) * iq + vfcx, vnan));
        cv::v_store(pv + j, (vfay + vw * cv::v_load(oy + j)) * iq + vfcy);
      }
      for (; j < W; ++j) {
        const float qz = az + w * oz[j];
        const float iq = 1.0f / qz;
        pu[j] = qz > kNear ? (fax + w * ox[j]) * iq + fcx : kNaNf;
        pv[j] = (fay + w * oy[j]) * iq + fcy;
      }
      bilinear_costs(pv, pu, kv, ko, cur_, cur_ok4_, g, b, {0, W}, e);
    }
    samples_ += active * W;
    // Rolling three cost slices: c0 = t-2, c1 = t-1, c2 = t; a minimum at t-1 is bracketed.
    std::swap(c0_, c1_);
    std::swap(c1_, c2_);
    cv::Mat c2_rows = c2_.rowRange(r0, r1 + 1);
    for (int i = r0; i <= r1; ++i) {
      if (t > row_last_[static_cast<std::size_t>(i)]) continue;
      common::box_sum_row(e_rows, c2_rows, tmp_rows, p_.window, i - r0, {0, W});
      if (t >= 2) keep_bracketed_minimum(c0_, c1_, c2_, best_, bests_, left_, right_, t, i, i, &second_);
    }
  }
}

void PlaneSweep::read_heights(const Sweep& sweep) {
  const int H = key_.rows, W = key_.cols;
  const double h = h_, w_lo = sweep.w_lo;
  // Sub-step minimum, height, position and confidence.
  const double cells = (2 * p_.window + 1) * (2 * p_.window + 1);
  const double noise2 = p_.noise_dn * p_.noise_dn;
  for (int i = 0; i < H; ++i) {
    const double step = row_step_.at<double>(i);
    float* zz = z_.ptr<float>(i);
    float* xx = x_.ptr<float>(i);
    float* yy = y_.ptr<float>(i);
    float* cf = conf_.ptr<float>(i);
    const float* ox = ox_.ptr<float>(i);
    for (int j = 0; j < W; ++j) {
      const float gx = xx[j], gy = yy[j];
      xx[j] = yy[j] = kNaNf;
      const float t = bests_.at<float>(i, j);
      const float bc = best_.at<float>(i, j);
      if (std::isnan(ox[j]) || t < 0 || bc >= kUnusableSampleCost)
        continue;  // bc so high: its window holds an unusable sample
      const double l = left_.at<float>(i, j), r = right_.at<float>(i, j);
      if (l >= kUnusableSampleCost || r >= kUnusableSampleCost) continue;
      double off = 0.0, match = 0.0;
      if (!parabola_minimum(l, bc, r, cells, noise2, off, match)) continue;
      const double w = w_lo + (t + off) * step;
      const double z = h * (1.0 - w);
      if (z < p_.min_height_m) continue;  // the bracketing step past the row's range
      // A height step (m) spans `step` in w: the sharper the image fixes the step, the better the
      // height; far rows (large steps) fix heights poorly and weigh accordingly.
      const double dz = h * step;
      const double precision = std::min(1.0, (p_.reference_step_m * p_.reference_step_m) / (dz * dz));
      // Another valley of the cost nearly as deep (a repetitive texture along the epipolar line)
      // makes the match a guess between heights: dropped (a false obstacle otherwise).
      if (!unique_minimum(bc, second_.at<float>(i, j), p_.uniqueness_ratio, cells, noise2)) continue;
      const double conf = match * precision;
      if (conf < p_.min_confidence) continue;
      zz[j] = static_cast<float>(z);
      xx[j] = static_cast<float>(w * gx);
      yy[j] = static_cast<float>(w * gy);
      cf[j] = static_cast<float>(conf);
    }
  }
}

}  // namespace regolith::mapping
