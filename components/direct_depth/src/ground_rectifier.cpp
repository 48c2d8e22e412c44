#include "regolith/direct_depth/ground_rectifier.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "regolith/core/error.hpp"

namespace regolith::direct_depth {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("direct_depth", field, why);
}

template <class T>
void resample_into(const cv::Mat& gray, cv::Mat& out, const cv::Mat& src, const cv::Mat& frac, const cv::Mat& valid,
                   double outside) {
  const T fill = cv::saturate_cast<T>(outside);
  for (int i = 0; i < out.rows; ++i) {
    T* o = out.ptr<T>(i);
    const uchar* v = valid.ptr<uchar>(i);
    const cv::Vec4i* s = src.ptr<cv::Vec4i>(i);
    const cv::Vec2f* f = frac.ptr<cv::Vec2f>(i);
    for (int j = 0; j < out.cols; ++j) {
      if (!v[j]) {
        o[j] = fill;
        continue;
      }
      const uchar* top = gray.ptr<uchar>(s[j][0]);
      const uchar* bot = gray.ptr<uchar>(s[j][2]);
      const float fx = f[j][0], fy = f[j][1];
      const float a = top[s[j][1]] + fx * static_cast<float>(top[s[j][3]] - top[s[j][1]]);
      const float b = bot[s[j][1]] + fx * static_cast<float>(bot[s[j][3]] - bot[s[j][1]]);
      o[j] = cv::saturate_cast<T>(a + fy * (b - a));
    }
  }
}

}  // namespace

void RectifiedGrid::validate() const {
  if (!std::isfinite(resolution_m) || resolution_m <= 0) fail("resolution_m", "must be > 0 m");
  if (rows < 1 || cols < 1) fail("rows/cols", "the rectified grid needs at least one cell");
  if (rows > 4096 || cols > 4096) fail("rows/cols", "more than 4096 rectified cells per side");
  if (!std::isfinite(x_far_m) || !std::isfinite(y_left_m)) fail("x_far_m/y_left_m", "must be finite");
  if (!(max_range_m > 0)) fail("max_range_m", "must be > 0 m");
}

GroundRectifier::GroundRectifier(const DirectDepth& depth, const RectifiedGrid& grid)
    : grid_((grid.validate(), grid)), image_size_(depth.model().width, depth.model().height) {
  const int rx = grid_.rows, ry = grid_.cols;
  src_.create(rx, ry, CV_32SC4);
  frac_.create(rx, ry, CV_32FC2);
  x_.create(rx, ry, CV_32F);
  y_.create(rx, ry, CV_32F);
  valid_.create(rx, ry, CV_8U);
  support_.create(rx, ry, CV_32F);
  const cv::Size sz = image_size_;
  const cv::Mat& fl = depth.footprint_lateral_map();
  const cv::Mat& fr = depth.footprint_range_map();
  const double res = grid_.resolution_m;
  for (int i = 0; i < rx; ++i)
    for (int j = 0; j < ry; ++j) {
      const cv::Point2d p = grid_.center(i, j);
      x_.at<float>(i, j) = static_cast<float>(p.x);
      y_.at<float>(i, j) = static_cast<float>(p.y);
      src_.at<cv::Vec4i>(i, j) = {0, 0, 0, 0};
      frac_.at<cv::Vec2f>(i, j) = {0.0f, 0.0f};
      valid_.at<uchar>(i, j) = 0;
      support_.at<float>(i, j) = 0.0f;
      if (p.x <= 0.0 || std::hypot(p.x, p.y) > grid_.max_range_m) continue;
      const auto px = depth.project(p.x, p.y, 0.0);
      if (!px || !(px->x >= 0.0 && px->y >= 0.0 && px->x <= sz.width - 1.0 && px->y <= sz.height - 1.0)) continue;
      const int c = static_cast<int>(std::lround(px->x)), r = static_cast<int>(std::lround(px->y));
      const double a = static_cast<double>(fl.at<float>(r, c)) * static_cast<double>(fr.at<float>(r, c));
      if (!(a > 0.0)) continue;  // pixel at or above the horizon
      const int c0 = std::min(static_cast<int>(px->x), sz.width - 1),
                r0 = std::min(static_cast<int>(px->y), sz.height - 1);
      src_.at<cv::Vec4i>(i, j) = {r0, c0, std::min(r0 + 1, sz.height - 1), std::min(c0 + 1, sz.width - 1)};
      frac_.at<cv::Vec2f>(i, j) = {static_cast<float>(px->x - c0), static_cast<float>(px->y - r0)};
      valid_.at<uchar>(i, j) = 255;
      support_.at<float>(i, j) = static_cast<float>(std::min(1.0, res * res / a));  // pixels in this cell
      ++visible_;
    }
}

void GroundRectifier::resample(const cv::Mat& gray, cv::Mat& out, double outside, const char* what) const {
  if (gray.empty()) fail(what, "empty image");
  if (gray.type() != CV_8UC1) fail(what, "must be CV_8UC1 (8-bit grey)");
  if (gray.size() != image_size_)
    fail(what, "size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                   " differs from the camera model " + std::to_string(image_size_.width) + "x" +
                   std::to_string(image_size_.height));
  const int type = (out.type() == CV_8UC1 && !out.empty()) ? CV_8UC1 : CV_32FC1;
  out.create(grid_.rows, grid_.cols, type);
  if (type == CV_8UC1)
    resample_into<uchar>(gray, out, src_, frac_, valid_, outside);
  else
    resample_into<float>(gray, out, src_, frac_, valid_, outside);
}

}  // namespace regolith::direct_depth
