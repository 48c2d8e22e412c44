#include "regolith/direct_depth/direct_depth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>

#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"

namespace regolith::direct_depth {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("direct_depth", field, why);
}

cv::Matx33d rot_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

}  // namespace

double canonical_range(double h, double alpha, double beta) {
  const double d = alpha + beta;
  if (!(d > 0.0) || d >= CV_PI) return kNaN;
  return h / std::tan(d);
}

void CameraModel::validate() const {
  if (!std::isfinite(fx) || fx <= 0) fail("fx", "must be > 0 px");
  if (!std::isfinite(fy) || fy <= 0) fail("fy", "must be > 0 px");
  if (!std::isfinite(cx) || !std::isfinite(cy)) fail("cx/cy", "must be finite");
  for (double k : {k1, k2, p1, p2, k3})
    if (!std::isfinite(k)) fail("k1/k2/p1/p2/k3", "must be finite");
  if (width <= 0 || height <= 0 || width > kMaxImageSidePx || height > kMaxImageSidePx)
    fail("width/height", "must be in 1.." + std::to_string(kMaxImageSidePx) + " px");
  if (!std::isfinite(mount_height_m) || mount_height_m <= 0) fail("mount_height_m", "must be > 0 m");
  if (!std::isfinite(pitch_rad) || std::abs(pitch_rad) >= CV_PI / 2) fail("pitch_rad", "must be in (-pi/2, pi/2)");
  if (!std::isfinite(roll_rad) || std::abs(roll_rad) >= CV_PI / 2) fail("roll_rad", "must be in (-pi/2, pi/2)");
}

DirectDepth::DirectDepth(const CameraModel& model, Maps maps) : model_(model) {
  model_.validate();
  const cv::Matx33d b0(0, 0, 1, -1, 0, 0, 0, -1, 0);  // optical -> body without pitch/roll
  const double ca = std::cos(model_.pitch_rad), sa = std::sin(model_.pitch_rad);
  const cv::Matx33d pitch(ca, 0, sa, 0, 1, 0, -sa, 0, ca);  // nose down for alpha > 0
  r_body_from_optical_ = pitch * b0 * rot_z(model_.roll_rad);
  if (maps == Maps::kNone) return;

  const int W = model_.width, H = model_.height;
  std::vector<cv::Point2f> px;
  px.reserve(static_cast<size_t>(W) * static_cast<size_t>(H));
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) px.emplace_back(static_cast<float>(c), static_cast<float>(r));
  std::vector<cv::Point2f> uv = px;
  if (model_.has_distortion()) {
    const cv::Matx33d K(model_.fx, 0, model_.cx, 0, model_.fy, model_.cy, 0, 0, 1);
    const cv::Vec<double, 5> D(model_.k1, model_.k2, model_.p1, model_.p2, model_.k3);
    cv::undistortPoints(px, uv, K, D);
  } else {
    for (auto& p : uv)
      p = cv::Point2f(static_cast<float>((p.x - model_.cx) / model_.fx),
                      static_cast<float>((p.y - model_.cy) / model_.fy));
  }
  const float nanf = std::numeric_limits<float>::quiet_NaN();
  range_.create(H, W, CV_32F);
  lateral_.create(H, W, CV_32F);
  valid_.create(H, W, CV_8U);
  const double h = model_.mount_height_m;
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const cv::Point2f& q = uv[static_cast<size_t>(r) * static_cast<size_t>(W) + static_cast<size_t>(c)];
      const cv::Vec3d d = r_body_from_optical_ * cv::Vec3d(q.x, q.y, 1.0);
      const bool ok = d[2] < -1e-12;
      range_.at<float>(r, c) = ok ? static_cast<float>(h * d[0] / -d[2]) : nanf;
      lateral_.at<float>(r, c) = ok ? static_cast<float>(h * d[1] / -d[2]) : nanf;
      valid_.at<uchar>(r, c) = ok ? 255 : 0;
    }
  // Footprints by finite differences of the maps (one-sided at the borders).
  foot_lat_.create(H, W, CV_32F);
  foot_rng_.create(H, W, CV_32F);
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      const int c0 = std::max(c - 1, 0), c1 = std::min(c + 1, W - 1);
      const int r0 = std::max(r - 1, 0), r1 = std::min(r + 1, H - 1);
      const float dl =
          (lateral_.at<float>(r, c1) - lateral_.at<float>(r, c0)) / static_cast<float>(std::max(c1 - c0, 1));
      const float dr = (range_.at<float>(r1, c) - range_.at<float>(r0, c)) / static_cast<float>(std::max(r1 - r0, 1));
      foot_lat_.at<float>(r, c) = std::abs(dl);
      foot_rng_.at<float>(r, c) = std::abs(dr);
    }
}

cv::Point2d DirectDepth::normalised(double c, double r) const {
  if (!std::isfinite(c) || !std::isfinite(r)) fail("pixel", "coordinates must be finite");
  if (!model_.has_distortion()) return {(c - model_.cx) / model_.fx, (r - model_.cy) / model_.fy};
  const cv::Matx33d K(model_.fx, 0, model_.cx, 0, model_.fy, model_.cy, 0, 0, 1);
  const cv::Vec<double, 5> D(model_.k1, model_.k2, model_.p1, model_.p2, model_.k3);
  std::vector<cv::Point2d> in{{c, r}}, out;
  cv::undistortPoints(in, out, K, D);
  return out[0];
}

GroundPoint DirectDepth::ground(double c, double r) const {
  const cv::Point2d q = normalised(c, r);
  const cv::Vec3d d = r_body_from_optical_ * cv::Vec3d(q.x, q.y, 1.0);
  GroundPoint g;
  if (!(d[2] < -1e-12)) return g;
  const double h = model_.mount_height_m, t = h / -d[2];
  g.range_m = t * d[0];
  g.lateral_m = t * d[1];
  g.slant_m = t * cv::norm(d);
  g.valid = true;
  return g;
}

double DirectDepth::depression(double r) const {
  return model_.pitch_rad + std::atan((r - model_.cy) / model_.fy);
}

double DirectDepth::horizon_row() const {
  return model_.cy - model_.fy * std::tan(model_.pitch_rad);
}

ObjectSize DirectDepth::object_size(const cv::Rect& box, double assumed_depth_m) const {
  if (box.width <= 0 || box.height <= 0) fail("box", "must have positive width and height");
  if (!std::isfinite(assumed_depth_m)) fail("assumed_depth_m", "must be finite");
  ObjectSize s;
  // Pixel edges: left edge at x - 0.5, right edge at x + width - 0.5, bottom edge at
  // y + height - 0.5 (the ground contact line), top edge at y - 0.5.
  const double rb = box.y + box.height - 0.5, rt = box.y - 0.5;
  const double cl = box.x - 0.5, cr = box.x + box.width - 0.5;
  const double cmid = box.x + 0.5 * (box.width - 1);
  const GroundPoint gl = ground(cl, rb), gr = ground(cr, rb), gm = ground(cmid, rb);
  if (!gl.valid || !gr.valid || !gm.valid) return s;
  s.range_m = gm.range_m;
  s.width_m = std::abs(gl.lateral_m - gr.lateral_m);
  const double depth = assumed_depth_m < 0 ? s.width_m : assumed_depth_m;
  // Height of the top ray where it passes over the object: horizontal distance range + depth/2.
  const cv::Point2d q = normalised(cmid, rt);
  const cv::Vec3d d = r_body_from_optical_ * cv::Vec3d(q.x, q.y, 1.0);
  const double horiz = std::hypot(d[0], d[1]);
  const double dist = std::hypot(gm.range_m, gm.lateral_m) + 0.5 * depth;
  s.height_m = model_.mount_height_m + d[2] / horiz * dist;
  s.valid = true;
  return s;
}

double DirectDepth::range_error_exact(double r, double rows) const {
  const double a = canonical_range(model_.mount_height_m, model_.pitch_rad, std::atan((r - model_.cy) / model_.fy));
  const double b =
      canonical_range(model_.mount_height_m, model_.pitch_rad, std::atan((r + rows - model_.cy) / model_.fy));
  return std::abs(a - b);
}

double DirectDepth::range_error_linear(double r, double rows) const {
  const double beta = std::atan((r - model_.cy) / model_.fy);
  const double y = canonical_range(model_.mount_height_m, model_.pitch_rad, beta);
  if (!std::isfinite(y)) return kNaN;
  const double dv = r - model_.cy;
  const double dbeta = std::abs(rows) * model_.fy / (model_.fy * model_.fy + dv * dv);
  const double h = model_.mount_height_m;
  return (h * h + y * y) / h * dbeta;
}

std::optional<cv::Point2d> DirectDepth::project(double range_m, double lateral_m, double z_m) const {
  const cv::Vec3d p(range_m, lateral_m, z_m - model_.mount_height_m);
  const cv::Vec3d o = r_body_from_optical_.t() * p;
  if (!(o[2] > 1e-9)) return std::nullopt;
  // OpenCV's 5-coefficient distortion model (as cv::projectPoints), written out so that
  // projecting allocates nothing
  const double xn = o[0] / o[2], yn = o[1] / o[2];
  const double r2 = xn * xn + yn * yn;
  const double radial = 1.0 + r2 * (model_.k1 + r2 * (model_.k2 + r2 * model_.k3));
  const double xd = xn * radial + 2.0 * model_.p1 * xn * yn + model_.p2 * (r2 + 2.0 * xn * xn);
  const double yd = yn * radial + model_.p1 * (r2 + 2.0 * yn * yn) + 2.0 * model_.p2 * xn * yn;
  return cv::Point2d(model_.fx * xd + model_.cx, model_.fy * yd + model_.cy);
}

}  // namespace regolith::direct_depth
