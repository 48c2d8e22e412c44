#include "regolith/mapping/ground_vo.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "regolith/core/error.hpp"

namespace regolith::mapping {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.vo", field, why);
}

constexpr uchar kValue = 128;                 // a usable grey value
constexpr uchar kGradient = 255;              // ... with a usable gradient
constexpr float kLow = 3.0f, kHigh = 252.0f;  // clipped brightness carries no shading

direct_depth::RectifiedGrid finest_grid(const GroundVoParams& p) {
  direct_depth::RectifiedGrid g;
  g.resolution_m = p.resolution_m;
  // Whole cells at every level: a multiple of 2^(levels-1) per side.
  const int m = 1 << (p.levels - 1);
  g.rows = std::max(m, static_cast<int>(std::ceil((p.max_range_m - p.min_range_m) / p.resolution_m / m)) * m);
  g.cols = std::max(m, static_cast<int>(std::ceil(2.0 * p.half_width_m / p.resolution_m / m)) * m);
  g.x_far_m = p.max_range_m;
  g.y_left_m = p.half_width_m;
  g.max_range_m = std::hypot(p.max_range_m, p.half_width_m);
  return g;
}

}  // namespace

void GroundVoParams::validate() const {
  auto pos = [](double v, const char* f) {
    if (!std::isfinite(v) || v <= 0) fail(f, "must be > 0");
  };
  pos(resolution_m, "resolution_m");
  pos(max_range_m, "max_range_m");
  pos(half_width_m, "half_width_m");
  pos(tukey_c, "tukey_c");
  pos(max_sigma_m, "max_sigma_m");
  pos(max_correction_m, "max_correction_m");
  pos(max_correction_rad, "max_correction_rad");
  pos(covariance_inflation, "covariance_inflation");
  pos(attitude_prior_rad, "attitude_prior_rad");
  pos(height_change_prior, "height_change_prior");
  if (!std::isfinite(scale_uncertainty) || scale_uncertainty < 0) fail("scale_uncertainty", "must be >= 0");
  if (!std::isfinite(min_range_m) || min_range_m < 0 || min_range_m >= max_range_m)
    fail("min_range_m", "must be >= 0 and below max_range_m");
  if (levels < 1 || levels > 5) fail("levels", "must be 1..5");
  if (iterations < 1 || iterations > 100) fail("iterations", "must be 1..100");
  if (stride < 1 || stride > 8) fail("stride", "must be 1..8");
  if (!(min_support >= 0 && min_support <= 1)) fail("min_support", "must be in [0, 1]");
  if (min_points < 10) fail("min_points", "must be >= 10");
  if (min_ground_points < 10) fail("min_ground_points", "must be >= 10");
  if ((max_range_m - min_range_m) / resolution_m > 2048 || 2 * half_width_m / resolution_m > 2048)
    fail("resolution_m", "more than 2048 cells per side of the VO window");
}

const char* to_string(VoStatus s) {
  switch (s) {
    case VoStatus::kOk: return "ok";
    case VoStatus::kNoKeyframe: return "no keyframe";
    case VoStatus::kTooFewPoints: return "too little ground in common with the keyframe";
    case VoStatus::kNoTexture: return "too little texture to fix the motion";
    case VoStatus::kUncertain: return "the motion it fixes is too uncertain (translation sigma above max_sigma_m)";
    case VoStatus::kDiverged: return "alignment diverged from the wheel prediction";
  }
  return "?";
}

GroundVisualOdometry::GroundVisualOdometry(const direct_depth::DirectDepth& depth, const GroundVoParams& params)
    : p_((params.validate(), params)), rectifier_(depth, finest_grid(p_)) {
  mount_height_ = depth.model().mount_height_m;
  const direct_depth::RectifiedGrid g0 = rectifier_.grid();
  templates_.resize(static_cast<std::size_t>(p_.levels));
  std::size_t most = 0;
  for (Frame* f : {&key_, &cur_}) {
    f->levels.resize(static_cast<std::size_t>(p_.levels));
    for (int l = 0; l < p_.levels; ++l) {
      Level& lv = f->levels[static_cast<std::size_t>(l)];
      lv.grid = g0;
      lv.grid.resolution_m = g0.resolution_m * (1 << l);
      lv.grid.rows = g0.rows >> l;
      lv.grid.cols = g0.cols >> l;
      for (cv::Mat* m : {&lv.img, &lv.gx, &lv.gy, &lv.support}) m->create(lv.grid.rows, lv.grid.cols, CV_32F);
      lv.usable.create(lv.grid.rows, lv.grid.cols, CV_8U);
      most = std::max(most, static_cast<std::size_t>(lv.grid.rows) * static_cast<std::size_t>(lv.grid.cols));
    }
  }
  for (auto& t : templates_) t.reserve(most);
  ground_template_.reserve(most);
  excluded_cur_.create(g0.rows, g0.cols, CV_8U);
  excluded_key_.create(g0.rows, g0.cols, CV_8U);
  residuals_.resize(most);
  jacobians_.resize(most);
  raw_.create(g0.rows, g0.cols, CV_32F);
  tmp_.create(g0.rows, g0.cols, CV_32F);
}

void GroundVisualOdometry::build_frame(const cv::Mat& gray, Frame& f) {
  rectifier_.resample(gray, raw_, 0.0, "gray");
  Level& l0 = f.levels[0];
  const cv::Mat& valid = rectifier_.valid();
  const int R = raw_.rows, C = raw_.cols;
  for (int i = 0; i < R; ++i) {
    const float* r = raw_.ptr<float>(i);
    const uchar* v = valid.ptr<uchar>(i);
    uchar* u = l0.usable.ptr<uchar>(i);
    for (int j = 0; j < C; ++j) u[j] = (v[j] && r[j] > kLow && r[j] < kHigh) ? kValue : 0;
  }
  rectifier_.support().copyTo(l0.support);
  // 3x3 binomial smoothing where the whole neighbourhood is usable (keeps edges of the view sharp).
  for (int i = 0; i < R; ++i) {
    float* o = l0.img.ptr<float>(i);
    const float* r = raw_.ptr<float>(i);
    for (int j = 0; j < C; ++j) {
      o[j] = r[j];
      if (i == 0 || j == 0 || i == R - 1 || j == C - 1) continue;
      bool all = true;
      float acc = 0.0f;
      static constexpr float k[3] = {0.25f, 0.5f, 0.25f};
      for (int di = -1; di <= 1 && all; ++di) {
        const float* rr = raw_.ptr<float>(i + di);
        const uchar* uu = l0.usable.ptr<uchar>(i + di);
        for (int dj = -1; dj <= 1; ++dj) {
          if (!uu[j + dj]) {
            all = false;
            break;
          }
          acc += k[di + 1] * k[dj + 1] * rr[j + dj];
        }
      }
      if (all) o[j] = acc;
    }
  }
  // Coarser levels: 2x2 means of fully usable blocks.
  for (std::size_t l = 1; l < f.levels.size(); ++l) {
    const Level& a = f.levels[l - 1];
    Level& b = f.levels[l];
    for (int i = 0; i < b.img.rows; ++i) {
      float* o = b.img.ptr<float>(i);
      float* s = b.support.ptr<float>(i);
      uchar* u = b.usable.ptr<uchar>(i);
      for (int j = 0; j < b.img.cols; ++j) {
        float acc = 0.0f, sup = 0.0f;
        bool all = true;
        for (int di = 0; di < 2; ++di)
          for (int dj = 0; dj < 2; ++dj) {
            all = all && a.usable.at<uchar>(2 * i + di, 2 * j + dj) != 0;
            acc += a.img.at<float>(2 * i + di, 2 * j + dj);
            sup += a.support.at<float>(2 * i + di, 2 * j + dj);
          }
        o[j] = 0.25f * acc;
        s[j] = std::min(1.0f, sup);  // 4 cells of the finer level in one cell
        u[j] = all ? kValue : 0;
      }
    }
  }
  // Gradients per metre along body x (rows run along -x) and y (columns run along -y).
  frame_cells_ = 0;
  for (Level& lv : f.levels) {
    const float inv = static_cast<float>(0.5 / lv.grid.resolution_m);
    const int rows = lv.img.rows, cols = lv.img.cols;
    for (int i = 0; i < rows; ++i) {
      float* gx = lv.gx.ptr<float>(i);
      float* gy = lv.gy.ptr<float>(i);
      uchar* u = lv.usable.ptr<uchar>(i);
      for (int j = 0; j < cols; ++j) {
        gx[j] = gy[j] = 0.0f;
        if (!u[j] || i == 0 || j == 0 || i == rows - 1 || j == cols - 1) continue;
        if (!lv.usable.at<uchar>(i - 1, j) || !lv.usable.at<uchar>(i + 1, j) || !u[j - 1] || !u[j + 1]) continue;
        gx[j] = -(lv.img.at<float>(i + 1, j) - lv.img.at<float>(i - 1, j)) * inv;
        gy[j] = -(lv.img.at<float>(i, j + 1) - lv.img.at<float>(i, j - 1)) * inv;
        u[j] = kGradient;
        if (&lv == &f.levels[0]) ++frame_cells_;
      }
    }
  }
}

bool GroundVisualOdometry::align_level(int level, const std::vector<Point>& pts, Params& th, bool record) {
  // Steps are accepted only if they lower the robust cost, in which a template point that leaves
  // the usable view costs as much as an outlier: otherwise a fit can "improve" by warping its
  // far ground out of view (large tilts), leaving a few near cells that agree with anything.
  Params best = th;
  double best_cost = std::numeric_limits<double>::infinity();
  CostScale ref;
  int halvings = 0;
  // Back to half way between the best point and the rejected step; false after 6 halvings.
  auto halve = [&] {
    if (++halvings > 6) return false;
    for (std::size_t q = 0; q < th.size(); ++q) th[q] = best[q] + 0.5 * (th[q] - best[q]);
    return true;
  };
  for (int it = 0; it < p_.iterations; ++it) {
    const int n = linearise(cur_.levels[static_cast<std::size_t>(level)], pts, th);
    if (n < p_.min_points / (1 << (2 * level)) + 5) {
      if (it > 0) {  // the last step moved the ground out of view: back towards the best point
        if (halve()) continue;
        th = best;
        break;
      }
      if (record) used_ = n, inl_ = 0;
      return false;
    }
    int median_bin = 0;
    for (int acc = 0; median_bin < 511 && (acc += histogram_[static_cast<std::size_t>(median_bin)]) * 2 < n;)
      ++median_bin;
    const double sigma = std::max(0.5, 1.4826 * (median_bin + 0.5) / 4.0);
    const double cut = p_.tukey_c * sigma;
    if (it == 0) {
      ref.cut = cut;
      ref.lam = sigma * sigma / (p_.attitude_prior_rad * p_.attitude_prior_rad);
      ref.lam_h = sigma * sigma / (p_.height_change_prior * p_.height_change_prior);
    }
    const double cost = robust_cost(pts, th, ref);
    if (cost > best_cost) {  // the last step went uphill
      if (halve()) continue;
      th = best;
      break;
    }
    best = th;
    best_cost = cost;
    halvings = 0;
    const Step step = gauss_newton_step(pts, cut, sigma, n, th, record);
    if (step == Step::kFailed) return false;
    if (step == Step::kConverged) break;
  }
  return true;
}

int GroundVisualOdometry::linearise(const Level& lv, const std::vector<Point>& pts, const Params& th) {
  const int rows = lv.img.rows, cols = lv.img.cols;
  const double h = mount_height_, ih = 1.0 / h;
  // Where a ground point appears to a camera tilted by a small pitch e (about body y) or roll
  // (about body x) against the ground: the ray through nominal point (x, y) rotated by e meets
  // the ground at (x, y) + D(x, y) * e.
  auto dp = [&](double x, double y) { return std::pair<double, double>{-(h + x * x * ih), -x * y * ih}; };
  auto dr = [&](double x, double y) { return std::pair<double, double>{x * y * ih, h + y * y * ih}; };
  const double c = std::cos(th[kYaw]), s = std::sin(th[kYaw]);
  int n = 0;
  histogram_.fill(0);
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const Point& pt = pts[k];
    // The keyframe cell where it truly lies on the ground (keyframe tilt), moved into the
    // current frame, then where the current camera's nominal rectification shows it.
    const auto [kpx, kpy] = dp(pt.x, pt.y);
    const auto [krx, kry] = dr(pt.x, pt.y);
    const double px = pt.x + kpx * th[kKeyPitch] + krx * th[kKeyRoll];
    const double py = pt.y + kpy * th[kKeyPitch] + kry * th[kKeyRoll];
    const double sc = 1.0 + th[kScale];
    const double rx = c * px - s * py, ry = s * px + c * py;
    const double tx = sc * rx + th[kX], ty = sc * ry + th[kY];
    const auto [dpx, dpy] = dp(tx, ty);
    const auto [drx, dry] = dr(tx, ty);
    const double qx = tx - dpx * th[kPitch] - drx * th[kRoll], qy = ty - dpy * th[kPitch] - dry * th[kRoll];
    const cv::Point2d cell = lv.grid.cell(qx, qy);  // (row, col)
    residuals_[k] = std::numeric_limits<float>::quiet_NaN();
    // The bilinear footprint inside the level (a NaN fails too) before the conversion: there
    // truncation is the floor, and no value is too large for an int.
    if (!(cell.x >= 0.0 && cell.y >= 0.0 && cell.x < rows - 1 && cell.y < cols - 1)) continue;
    const int i0 = static_cast<int>(cell.x), j0 = static_cast<int>(cell.y);
    const uchar* u0 = lv.usable.ptr<uchar>(i0);
    const uchar* u1 = lv.usable.ptr<uchar>(i0 + 1);
    if (u0[j0] != kGradient || u0[j0 + 1] != kGradient || u1[j0] != kGradient || u1[j0 + 1] != kGradient) continue;
    const float fi = static_cast<float>(cell.x - i0), fj = static_cast<float>(cell.y - j0);
    auto bil = [&](const cv::Mat& m) {
      const float* ra = m.ptr<float>(i0);
      const float* rb = m.ptr<float>(i0 + 1);
      const float top = ra[j0] + fj * (ra[j0 + 1] - ra[j0]);
      const float bot = rb[j0] + fj * (rb[j0 + 1] - rb[j0]);
      return top + fi * (bot - top);
    };
    const double v = bil(lv.img), gx = bil(lv.gx), gy = bil(lv.gy);
    const double r = v - (1.0 + th[kGain]) * pt.value - th[kBias];
    const double dqx = sc * (-s * px - c * py), dqy = sc * (c * px - s * py);  // d(rotated point) / d yaw
    residuals_[k] = static_cast<float>(r);
    jacobians_[k] = {static_cast<float>(gx),
                     static_cast<float>(gy),
                     static_cast<float>(gx * dqx + gy * dqy),
                     static_cast<float>(sc * (gx * (c * kpx - s * kpy) + gy * (s * kpx + c * kpy))),
                     static_cast<float>(sc * (gx * (c * krx - s * kry) + gy * (s * krx + c * kry))),
                     static_cast<float>(-(gx * dpx + gy * dpy)),
                     static_cast<float>(-(gx * drx + gy * dry)),
                     -pt.value,
                     -1.0f,
                     static_cast<float>(gx * rx + gy * ry)};
    ++histogram_[static_cast<std::size_t>(std::min(511.0, std::abs(r) * 4.0))];
    ++n;
  }
  return n;
}

double GroundVisualOdometry::robust_cost(const std::vector<Point>& pts, const Params& th, const CostScale& ref) const {
  double cost = 0.0;
  const double cap = ref.cut * ref.cut / 6.0;
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const float r = residuals_[k];
    double rho = cap;
    if (std::isfinite(r) && std::abs(r) < ref.cut) {
      const double v = 1.0 - (r / ref.cut) * (r / ref.cut);
      rho = cap * (1.0 - v * v * v);
    }
    cost += pts[k].weight * rho;
  }
  for (int q : {kKeyPitch, kKeyRoll, kPitch, kRoll})
    cost += 0.5 * ref.lam * th[static_cast<std::size_t>(q)] * th[static_cast<std::size_t>(q)];
  cost += 0.5 * ref.lam_h * th[kScale] * th[kScale];
  return cost;
}

GroundVisualOdometry::Step GroundVisualOdometry::gauss_newton_step(const std::vector<Point>& pts, double cut,
                                                                   double sigma, int n, Params& th, bool record) {
  Eigen::Matrix<double, kParams, kParams> H = Eigen::Matrix<double, kParams, kParams>::Zero();
  Eigen::Matrix<double, kParams, 1> g = Eigen::Matrix<double, kParams, 1>::Zero();
  double wr2 = 0.0, wsum = 0.0;
  int inliers = 0;
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const float r = residuals_[k];
    if (!std::isfinite(r) || std::abs(r) >= cut) continue;
    const double u = r / cut, w = (1.0 - u * u) * (1.0 - u * u) * pts[k].weight;
    const Eigen::Map<const Eigen::Matrix<float, kParams, 1>> jf(jacobians_[k].data());
    const Eigen::Matrix<double, kParams, 1> j = jf.cast<double>();
    H.noalias() += w * j * j.transpose();
    g.noalias() += w * r * j;
    wr2 += w * r * r;
    wsum += w;
    ++inliers;
  }
  // Both cameras' tilts against the ground: a prior around the mount (no IMU), in the units of
  // the photometric cost (residual variance / prior variance).
  const double s2 = wsum > static_cast<double>(kParams) ? wr2 / wsum : sigma * sigma;
  // Each fit estimates both tilts afresh around the mount. (Carrying a keyframe's tilt from fit
  // to fit, or from the current frame to the next keyframe, drifted on every drive tried.)
  const double lam = s2 / (p_.attitude_prior_rad * p_.attitude_prior_rad);
  for (int q : {kKeyPitch, kKeyRoll, kPitch, kRoll}) {
    H(q, q) += lam;
    g[q] += lam * th[static_cast<std::size_t>(q)];
  }
  const double lam_h = s2 / (p_.height_change_prior * p_.height_change_prior);
  H(kScale, kScale) += lam_h;
  g[kScale] += lam_h * th[kScale];
  const Eigen::LDLT<Eigen::Matrix<double, kParams, kParams>> ldlt(H);
  if (ldlt.info() != Eigen::Success || !(H.diagonal().minCoeff() > 0)) return Step::kFailed;
  const Eigen::Matrix<double, kParams, 1> d = ldlt.solve(-g);
  if (!d.allFinite()) return Step::kFailed;
  for (int q = 0; q < kParams; ++q) th[static_cast<std::size_t>(q)] += d[q];
  if (record) {
    info_ = H;
    sigma2_ = s2;
    used_ = n;
    inl_ = inliers;
  }
  const bool converged = std::abs(d[kX]) < 1e-5 && std::abs(d[kY]) < 1e-5 && std::abs(d[kYaw]) < 1e-6;
  return converged ? Step::kConverged : Step::kMoved;
}

const VoMeasurement& GroundVisualOdometry::track(const cv::Mat& gray, const Pose2& prior) {
  build_frame(gray, cur_);
  cur_excluded_ = false;
  last_ = VoMeasurement{};
  last_.pose = prior;
  last_.frame_cells = frame_cells_;
  if (!has_keyframe_) return last_;
  // Unknowns: the transform taking keyframe ground points to the current frame (the inverse of
  // the camera motion) and the brightness change.
  const Pose2 a0 = inverse(prior);
  Params th{};
  th[kX] = a0.x, th[kY] = a0.y, th[kYaw] = a0.yaw;
  used_ = inl_ = 0;
  bool ok = true;
  for (int l = p_.levels - 1; l >= 0 && ok; --l)
    ok = align_level(l, templates_[static_cast<std::size_t>(l)], th, l == 0);
  last_.points = used_;
  last_.inliers = inl_;
  last_.pitch_rad = th[kPitch];
  last_.roll_rad = th[kRoll];
  last_.key_pitch_rad = th[kKeyPitch];
  last_.key_roll_rad = th[kKeyRoll];
  last_.height_ratio = 1.0 + th[kScale];
  last_.gain = 1.0 + th[kGain];
  last_.bias_dn = th[kBias];
  last_.residual_dn = std::sqrt(sigma2_);
  last_.ground_pitch_rad = th[kPitch];
  last_.ground_roll_rad = th[kRoll];
  if (ok) refit_ground_tilt(th);
  if (!ok || inl_ < p_.min_points) {
    last_.status = used_ < p_.min_points ? VoStatus::kTooFewPoints : VoStatus::kNoTexture;
    return last_;
  }
  // The translation is in the current camera's ground units; the keyframe's are the metric ones.
  const Pose2 a{th[kX] / last_.height_ratio, th[kY] / last_.height_ratio, wrap_angle(th[kYaw])};
  const Pose2 m = inverse(a);
  // Covariance of (x, y, yaw) of the motion: marginal of the fit, through the inverse.
  const Eigen::Matrix<double, kParams, kParams> cov = sigma2_ * info_.inverse() * p_.covariance_inflation;
  if (!cov.allFinite()) {
    last_.status = VoStatus::kNoTexture;
    return last_;
  }
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  Eigen::Matrix3d j;
  j << -c, -s, s * a.x - c * a.y, s, -c, c * a.x + s * a.y, 0, 0, -1;
  last_.covariance = j * cov.topLeftCorner<3, 3>() * j.transpose();
  // Model error the fit cannot see: a camera height or tilt against the ground that differs
  // from the one solved for scales the motion (scale_uncertainty x the distance, along it).
  const double dist = std::hypot(m.x, m.y);
  if (dist > 1e-9) {
    const double ux = m.x / dist, uy = m.y / dist, v = std::pow(p_.scale_uncertainty * dist, 2);
    last_.covariance(0, 0) += v * ux * ux;
    last_.covariance(0, 1) += v * ux * uy;
    last_.covariance(1, 0) += v * ux * uy;
    last_.covariance(1, 1) += v * uy * uy;
  }
  last_.pose = m;
  const Pose2 corr = between(prior, m);
  if (!last_.covariance.allFinite()) {
    last_.status = VoStatus::kNoTexture;
  } else if (std::sqrt(std::max(cov(0, 0), cov(1, 1))) > p_.max_sigma_m) {
    last_.status = VoStatus::kUncertain;
  } else if (std::hypot(corr.x, corr.y) > p_.max_correction_m || std::abs(corr.yaw) > p_.max_correction_rad) {
    last_.status = VoStatus::kDiverged;
  } else {
    last_.status = VoStatus::kOk;
  }
  return last_;
}

void GroundVisualOdometry::refit_ground_tilt(const Params& th) {
  if (static_cast<int>(ground_template_.size()) < p_.min_ground_points) return;
  // The tilt again, from the motion fit's solution, over the ground the objects leave free.
  Params tg = th;
  if (align_level(0, ground_template_, tg, false)) {
    last_.ground_distance_m = std::hypot(tg[kX], tg[kY]) / (1.0 + tg[kScale]);
    last_.ground_tilt = true;
    last_.ground_pitch_rad = tg[kPitch];
    last_.ground_roll_rad = tg[kRoll];
  }
}

void GroundVisualOdometry::exclude(const cv::Mat& objects) {
  rectifier_.resample(objects, excluded_cur_, 0.0, "objects");  // checks the type and size
  cur_excluded_ = true;
}

void GroundVisualOdometry::promote_last() {
  std::swap(key_, cur_);
  std::swap(excluded_key_, excluded_cur_);
  key_excluded_ = cur_excluded_;
  cur_excluded_ = false;
  has_keyframe_ = true;
  // The finest level's cells that show no object (none of its source pixels marked: bilinear
  // resampling of the 0 / 255 mask) also make the ground template; without marks it stays empty.
  ground_template_.clear();
  for (std::size_t l = 0; l < key_.levels.size(); ++l) {
    const Level& lv = key_.levels[l];
    std::vector<Point>& t = templates_[l];
    t.clear();
    const bool ground = l == 0 && key_excluded_;
    const int step = l == 0 ? p_.stride : 1;
    for (int i = 0; i < lv.img.rows; i += step) {
      const uchar* u = lv.usable.ptr<uchar>(i);
      const float* v = lv.img.ptr<float>(i);
      const float* s = lv.support.ptr<float>(i);
      const uchar* x = ground ? excluded_key_.ptr<uchar>(i) : nullptr;
      for (int j = 0; j < lv.img.cols; j += step) {
        if (u[j] != kGradient || s[j] < p_.min_support) continue;
        const cv::Point2d q = lv.grid.center(i, j);
        if (q.x < p_.min_range_m) continue;
        t.push_back({static_cast<float>(q.x), static_cast<float>(q.y), v[j], s[j]});
        if (ground && x[j] == 0) ground_template_.push_back(t.back());
      }
    }
  }
}

}  // namespace regolith::mapping
