#include "regolith/mapping/shadow.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"

namespace regolith::mapping {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.shadow", field, why);
}

using common::fill;

}  // namespace

void ShadowParams::validate() const {
  if (!(dark_fraction > 0 && dark_fraction < 1)) fail("dark_fraction", "must be in (0, 1)");
  if (!std::isfinite(min_length_m) || min_length_m < 0) fail("min_length_m", "must be >= 0");
  if (!std::isfinite(max_height_m) || max_height_m <= 0) fail("max_height_m", "must be > 0");
  if (!(min_elevation_rad >= 0 && min_elevation_rad < max_elevation_rad && max_elevation_rad < 1.5708))
    fail("min_elevation_rad", "must satisfy 0 <= min_elevation_rad < max_elevation_rad < pi/2");
}

ShadowCue::ShadowCue(const direct_depth::RectifiedGrid& grid, const ShadowParams& params)
    : grid_((grid.validate(), grid)), p_((params.validate(), params)) {
  shadow_.create(grid_.rows, grid_.cols, CV_8U);
  for (cv::Mat* m : {&h_, &x_, &y_, &w_}) m->create(grid_.rows, grid_.cols, CV_32F);
  for (int i = 0; i < grid_.rows; ++i)
    for (int j = 0; j < grid_.cols; ++j) {
      const cv::Point2d c = grid_.center(i, j);
      x_.at<float>(i, j) = static_cast<float>(c.x);
      y_.at<float>(i, j) = static_cast<float>(c.y);
    }
}

int ShadowCue::compute(const cv::Mat& img, const cv::Mat& valid, const cv::Vec3d& sun) {
  fill(h_, kNaNf);
  fill(w_, 0.0f);
  fill(shadow_, uchar{0});
  const double horiz = std::hypot(sun[0], sun[1]);
  const double el = std::atan2(sun[2], horiz);
  if (!(el >= p_.min_elevation_rad && el <= p_.max_elevation_rad) || !(horiz > 0)) return 0;
  // Median brightness of the seen cells (histogram of 0..255).
  int hist[256] = {};
  int seen = 0;
  for (int i = 0; i < img.rows; ++i) {
    const float* v = img.ptr<float>(i);
    const uchar* ok = valid.ptr<uchar>(i);
    for (int j = 0; j < img.cols; ++j)
      if (ok[j]) ++hist[std::clamp(static_cast<int>(v[j]), 0, 255)], ++seen;
  }
  if (seen < 100) return 0;
  int median = 0;
  for (int acc = 0; median < 255 && (acc += hist[median]) * 2 < seen;) ++median;
  const float dark = static_cast<float>(p_.dark_fraction * median);
  for (int i = 0; i < img.rows; ++i) {
    const float* v = img.ptr<float>(i);
    const uchar* ok = valid.ptr<uchar>(i);
    uchar* s = shadow_.ptr<uchar>(i);
    for (int j = 0; j < img.cols; ++j) s[j] = (ok[j] && v[j] < dark) ? 255 : 0;
  }
  // Towards the sun in cell steps: rows run along -x, columns along -y.
  const double di = -sun[0] / horiz, dj = -sun[1] / horiz;
  const double res = grid_.resolution_m, tan_el = std::tan(el);
  const int max_steps = static_cast<int>(std::ceil(p_.max_height_m / tan_el / res));
  int casters = 0;
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j) {
      if (!shadow_.at<uchar>(i, j)) continue;
      double fi = i, fj = j;
      int n = 0, ei = -1, ej = -1;
      for (; n < max_steps; ++n) {
        fi += di, fj += dj;
        const int ri = static_cast<int>(std::lround(fi)), rj = static_cast<int>(std::lround(fj));
        if (ri < 0 || rj < 0 || ri >= img.rows || rj >= img.cols || !valid.at<uchar>(ri, rj)) break;  // left the view
        if (!shadow_.at<uchar>(ri, rj)) {
          ei = ri, ej = rj;
          break;
        }
      }
      if (ei < 0) continue;
      const double length = (n + 1) * res;
      if (length < p_.min_length_m) continue;
      float& h = h_.at<float>(ei, ej);
      const float z = static_cast<float>(std::min(p_.max_height_m, length * tan_el));
      if (!(h >= z)) {
        if (!std::isfinite(h)) ++casters;
        h = z;
        w_.at<float>(ei, ej) = 1.0f;
      }
    }
  return casters;
}

}  // namespace regolith::mapping
