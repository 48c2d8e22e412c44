// Diagnostic overlay (thesis Fig 4.5 colours): template red, interface green, sinkage blue.
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "regolith/sinkage/sinkage.hpp"

namespace regolith::sinkage {

void draw_overlay(const cv::Mat& bgr, const WheelGeometry& g, const SinkageResult& result, cv::Mat& out) {
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    throw std::invalid_argument("draw_overlay: bgr: expected a non-empty CV_8UC3 image");
  }
  bgr.copyTo(out);
  const cv::Scalar red(0, 0, 255), green(0, 255, 0), blue(255, 64, 0), white(255, 255, 255);
  constexpr int kShift = 4;
  const double sc = 1 << kShift;
  auto fp = [&](cv::Point2d p) {
    return cv::Point(static_cast<int>(std::lround(p.x * sc)), static_cast<int>(std::lround(p.y * sc)));
  };
  for (std::size_t i = 0; i < result.leg_count; ++i) {
    const LegSinkage& l = result.legs[i];
    const cv::Point2d c = g.hub_center_px;
    const cv::Point2d d{std::sin(l.angle_rad), std::cos(l.angle_rad)};
    const cv::Point2d n{std::cos(l.angle_rad), -std::sin(l.angle_rad)};
    const double hw = 0.5 * g.leg_width_px;
    const double fw = g.half_width_at(g.leg_length_px);
    const double fs = g.leg_length_px - g.foot_thickness_px;
    const double r0 = g.hub_radius_px, r1 = g.leg_length_px;
    // template outline (shaft + foot)
    const cv::Point poly[8] = {fp(c + r0 * d - hw * n), fp(c + fs * d - hw * n), fp(c + fs * d - fw * n),
                               fp(c + r1 * d - fw * n), fp(c + r1 * d + fw * n), fp(c + fs * d + fw * n),
                               fp(c + fs * d + hw * n), fp(c + r0 * d + hw * n)};
    const cv::Point* pts = poly;
    const int npts = 8;
    cv::polylines(out, &pts, &npts, 1, true, red, 1, cv::LINE_AA, kShift);
    if (l.valid) {
      cv::line(out, fp(l.interface_left_px), fp(l.interface_right_px), green, 2, cv::LINE_AA, kShift);
      if (l.sinkage_px > 0.0) {
        cv::line(out, fp(l.tip_px), fp(l.tip_px - cv::Point2d(0, l.sinkage_px)), blue, 2, cv::LINE_AA, kShift);
      }
    }
  }
  char text[128];
  if (result.valid) {
    std::snprintf(text, sizeof text, "sinkage %.1f mm  conf %.2f%s", result.sinkage_mm, result.confidence,
                  result.used_adaptive ? "  (adaptive)" : "");
  } else {
    std::snprintf(text, sizeof text, "invalid: %s", to_string(result.reason));
  }
  cv::putText(out, text, {10, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.6, white, 1, cv::LINE_AA);
}

}  // namespace regolith::sinkage
