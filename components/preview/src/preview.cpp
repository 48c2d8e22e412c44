#include "regolith/preview/preview.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace regolith::preview {

cv::Size preview_size(cv::Size source, int width) {
  const int w = std::clamp(width, 16, std::max(16, source.width));
  const int h = source.width > 0 ? std::max(1, (source.height * w + source.width / 2) / source.width) : 1;
  return {w, h};
}

namespace {

// `frame` scaled into `out` as BGR: area averaging when shrinking (no aliasing of fine texture).
void scaled_bgr(const cv::Mat& frame, int width, cv::Mat& out, cv::Mat& grey_scaled) {
  const cv::Size size = preview_size(frame.size(), width);
  if (frame.channels() == 1) {
    cv::resize(frame, grey_scaled, size, 0, 0, cv::INTER_AREA);
    cv::cvtColor(grey_scaled, out, cv::COLOR_GRAY2BGR);
  } else {
    cv::resize(frame, out, size, 0, 0, cv::INTER_AREA);
  }
}

void caption(cv::Mat& out, const char* text) {
  const double scale = std::clamp(out.cols / 640.0, 0.35, 0.8);
  int base = 0;
  const cv::Size ts = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &base);
  cv::rectangle(out, {0, 0}, {std::min(out.cols, ts.width + 8), ts.height + base + 6}, cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(out, text, {4, ts.height + 3}, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
}

}  // namespace

cv::Mat grid_cell_lookup(const direct_depth::DirectDepth& depth, const common::GridGeometry& grid, cv::Size preview) {
  const cv::Size cam = depth.range_map().size();
  cv::Mat cell(preview, CV_32S, cv::Scalar(-1));
  if (cam.width <= 0 || preview.width <= 0) return cell;
  const double s = static_cast<double>(cam.width) / preview.width;  // camera px per preview px
  const int ny = grid.size_y();
  for (int r = 0; r < preview.height; ++r)
    for (int c = 0; c < preview.width; ++c) {
      // the camera pixel at this preview pixel's centre (pixel centres at integers in direct_depth)
      const direct_depth::GroundPoint g = depth.ground((c + 0.5) * s - 0.5, (r + 0.5) * s - 0.5);
      int i = 0, j = 0;
      if (g.valid && grid.cell_of(g.range_m, g.lateral_m, i, j)) cell.at<int>(r, c) = i * ny + j;
    }
  return cell;
}

void draw_rocks(const cv::Mat& frame, std::span<const saliency::RangedRock> rocks, int width, cv::Mat& out,
                const HazardOverlay& hazard) {
  if (frame.empty() || (frame.type() != CV_8UC1 && frame.type() != CV_8UC3))
    throw std::invalid_argument("draw_rocks: frame: expected a non-empty CV_8UC1 or CV_8UC3 image");
  cv::Mat grey_scaled;
  scaled_bgr(frame, width, out, grey_scaled);
  if (hazard.cell != nullptr && hazard.traversability != nullptr) {
    const cv::Mat& cell = *hazard.cell;
    const cv::Mat& t = *hazard.traversability;
    if (cell.size() != out.size() || cell.type() != CV_32S || t.type() != CV_32F || !t.isContinuous())
      throw std::invalid_argument(
          "draw_rocks: hazard overlay: the cell lookup must be CV_32S of the preview's size "
          "and the layer a continuous CV_32F matrix");
    const int n = static_cast<int>(t.total());
    const float* tv = t.ptr<float>(0);  // continuous (a grid layer)
    for (int r = 0; r < out.rows; ++r) {
      const int* cr = cell.ptr<int>(r);
      cv::Vec3b* o = out.ptr<cv::Vec3b>(r);
      for (int c = 0; c < out.cols; ++c) {
        if (cr[c] < 0 || cr[c] >= n) continue;
        const float v = tv[cr[c]];
        if (!(v < 1.0f)) continue;  // free, or NaN (unknown)
        const float a = 0.6f * std::clamp(1.0f - v, 0.0f, 1.0f);
        o[c][0] = cv::saturate_cast<uchar>((1.0f - a) * o[c][0]);
        o[c][1] = cv::saturate_cast<uchar>((1.0f - a) * o[c][1]);
        o[c][2] = cv::saturate_cast<uchar>((1.0f - a) * o[c][2] + a * 255.0f);
      }
    }
  }
  const double s = static_cast<double>(out.cols) / frame.cols;
  const cv::Scalar red(0, 0, 255), yellow(0, 220, 255);
  double nearest = -1.0;
  std::size_t hazards = 0;
  for (std::size_t i = rocks.size(); i-- > 0;) {  // the first (best-scored) drawn last, on top
    const saliency::RangedRock& r = rocks[i];
    if (r.hazard) ++hazards;
    const cv::Rect& b = r.detection.box;
    const cv::Point p0(static_cast<int>(b.x * s), static_cast<int>(b.y * s));
    const cv::Point p1(std::max(p0.x + 1, static_cast<int>((b.x + b.width) * s) - 1),
                       std::max(p0.y + 1, static_cast<int>((b.y + b.height) * s) - 1));
    cv::rectangle(out, p0, p1, r.hazard ? red : yellow, r.hazard ? 3 : 2,
                  cv::LINE_8);  // 1 px does not survive JPEG chroma
    char label[32];
    std::snprintf(label, sizeof label, "%.2f", r.detection.score);
    cv::putText(out, label, {p0.x, std::max(8, p0.y - 2)}, cv::FONT_HERSHEY_PLAIN, 0.7, r.hazard ? red : yellow, 1,
                cv::LINE_AA);
    if (r.ranged && (nearest < 0.0 || r.range_m < nearest)) nearest = r.range_m;
  }
  char text[96];
  if (nearest >= 0.0)
    std::snprintf(text, sizeof text, "rocks %zu  hazards %zu  nearest %.1f m", rocks.size(), hazards, nearest);
  else
    std::snprintf(text, sizeof text, "rocks %zu  hazards %zu", rocks.size(), hazards);
  caption(out, text);
}

void draw_sinkage(const cv::Mat& frame, const sinkage::WheelGeometry& geometry, const sinkage::SinkageResult& result,
                  int width, cv::Mat& scaled, cv::Mat& out) {
  if (frame.empty() || frame.type() != CV_8UC3)
    throw std::invalid_argument("draw_sinkage: frame: expected a non-empty CV_8UC3 image");
  // Scale first and draw the geometry scaled: thin lines drawn at full size and then averaged
  // down fade into the frame.
  cv::resize(frame, scaled, preview_size(frame.size(), width), 0, 0, cv::INTER_AREA);
  const double s = static_cast<double>(scaled.cols) / frame.cols;
  sinkage::WheelGeometry g = geometry;
  g.hub_center_px *= s;
  g.leg_length_px *= s;
  g.leg_width_px *= s;
  g.hub_radius_px *= s;
  g.foot_width_px *= s;
  g.foot_thickness_px *= s;
  sinkage::SinkageResult r = result;
  for (auto& leg : r.legs) {
    leg.interface_left_px *= s;
    leg.interface_right_px *= s;
    leg.tip_px *= s;
    leg.visible_length_px *= s;
    leg.sinkage_px *= s;
  }
  sinkage::draw_overlay(scaled, g, r, out);
}

bool encode_jpeg(const cv::Mat& bgr, int quality, std::vector<std::uint8_t>& bytes) {
  if (bgr.empty() || bgr.type() != CV_8UC3) return false;
  const std::vector<int> params{cv::IMWRITE_JPEG_QUALITY, std::clamp(quality, 1, 100)};
  try {
    return cv::imencode(".jpg", bgr, bytes, params);
  } catch (const cv::Exception&) {
    return false;
  }
}

}  // namespace regolith::preview
