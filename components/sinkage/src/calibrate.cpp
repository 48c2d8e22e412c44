// Geometry calibration from one frame of the un-sunk wheel (allocates; offline use).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "regolith/sinkage/sinkage.hpp"

namespace regolith::sinkage {
namespace {

struct Blob {
  std::vector<cv::Point> pts;
  cv::Point2d centroid;
  cv::Point2d dir;  // unit
  bool touches_border = false;
};

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

cv::Mat segment_legs(const cv::Mat& bgr, const SinkageParams& p) {
  cv::Mat bin;
  cv::Mat hsv;
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV_FULL);  // H in [0, 255] for [0, 360)
  cv::Scalar mean_bgr = cv::mean(bgr);
  const double mean_v = std::max({mean_bgr[0], mean_bgr[1], mean_bgr[2]}) / 255.0;
  const bool adaptive =
      p.mode == SegmentationMode::kAdaptive || (p.mode == SegmentationMode::kAuto && mean_v < p.dark_mean_value);
  if (!adaptive) {
    const double k = 255.0 / 360.0;
    const double smin = p.sat_min * 255.0, vmin = p.val_min * 255.0;
    if (p.hue_min_deg <= p.hue_max_deg) {
      cv::inRange(hsv, cv::Scalar(p.hue_min_deg * k, smin, vmin), cv::Scalar(p.hue_max_deg * k, 255, 255), bin);
    } else {
      cv::Mat a, b;
      cv::inRange(hsv, cv::Scalar(p.hue_min_deg * k, smin, vmin), cv::Scalar(255, 255, 255), a);
      cv::inRange(hsv, cv::Scalar(0, smin, vmin), cv::Scalar(p.hue_max_deg * k, 255, 255), b);
      cv::bitwise_or(a, b, bin);
    }
  } else {
    std::vector<cv::Mat> ch;
    cv::split(bgr, ch);
    cv::Mat b16, g16, r16, chroma;
    ch[0].convertTo(b16, CV_32F);
    ch[1].convertTo(g16, CV_32F);
    ch[2].convertTo(r16, CV_32F);
    chroma = b16 - 0.5 * (g16 + r16);
    cv::Mat c8;
    chroma.convertTo(c8, CV_8U, 0.5, 128.0);
    cv::threshold(c8, bin, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  }
  if (p.open_kernel_px > 1) {
    cv::morphologyEx(bin, bin, cv::MORPH_OPEN,
                     cv::getStructuringElement(cv::MORPH_RECT, {p.open_kernel_px, p.open_kernel_px}));
  }
  if (p.close_kernel_px > 1) {
    cv::morphologyEx(bin, bin, cv::MORPH_CLOSE,
                     cv::getStructuringElement(cv::MORPH_RECT, {p.close_kernel_px, p.close_kernel_px}));
  }
  return bin;
}

// Throws std::invalid_argument for an image that is not 8-bit BGR, a non-finite encoder angle or hints out of range.
void check_inputs(const cv::Mat& bgr, double encoder_angle_rad, const CalibrationHints& hints) {
  if (bgr.empty()) throw std::invalid_argument("calibrate_from_unsunk_frame: bgr: empty image");
  if (bgr.type() != CV_8UC3) {
    throw std::invalid_argument("calibrate_from_unsunk_frame: bgr: expected CV_8UC3 (got type " +
                                std::to_string(bgr.type()) + ")");
  }
  if (!std::isfinite(encoder_angle_rad)) {
    throw std::invalid_argument("calibrate_from_unsunk_frame: angle: must be finite");
  }
  if (hints.leg_count < 1 || hints.leg_count > static_cast<int>(kMaxLegs)) {
    throw std::invalid_argument("CalibrationHints.leg_count: must be in [1, 16]");
  }
  if (!(hints.leg_spacing_rad > 0.0) || !std::isfinite(hints.leg_spacing_rad)) {
    throw std::invalid_argument("CalibrationHints.leg_spacing_rad: must be > 0");
  }
  if (hints.rotation_direction != 1 && hints.rotation_direction != -1) {
    throw std::invalid_argument("CalibrationHints.rotation_direction: must be +1 or -1");
  }
  hints.colour.validate();
}

// The blobs of the leg colour of at least hints.min_leg_area_px: their pixels and whether they touch the border.
std::vector<Blob> find_blobs(const cv::Mat& bgr, const CalibrationHints& hints) {
  const cv::Mat bin = segment_legs(bgr, hints.colour);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(bin, labels, stats, centroids, 8, CV_32S);
  std::vector<Blob> blobs;
  std::vector<int> index(static_cast<std::size_t>(n), -1);
  for (int i = 1; i < n; ++i) {
    if (stats.at<int>(i, cv::CC_STAT_AREA) < hints.min_leg_area_px) continue;
    index[static_cast<std::size_t>(i)] = static_cast<int>(blobs.size());
    Blob b;
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    b.touches_border = x <= 0 || y <= 0 || x + w >= bgr.cols || y + h >= bgr.rows;
    blobs.push_back(std::move(b));
  }
  for (int y = 0; y < labels.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    for (int x = 0; x < labels.cols; ++x) {
      const int bi = index[static_cast<std::size_t>(l[x])];
      if (bi >= 0) blobs[static_cast<std::size_t>(bi)].pts.emplace_back(x, y);
    }
  }
  return blobs;
}

// The legs: the elongated blobs, with their centroid and principal axis. Throws when there are fewer than two.
std::vector<Blob> find_legs(std::vector<Blob> blobs) {
  std::vector<Blob> legs;
  for (auto& b : blobs) {
    double mx = 0, my = 0;
    for (const auto& p : b.pts) {
      mx += p.x;
      my += p.y;
    }
    const double cnt = static_cast<double>(b.pts.size());
    mx /= cnt;
    my /= cnt;
    double sxx = 0, syy = 0, sxy = 0;
    for (const auto& p : b.pts) {
      sxx += (p.x - mx) * (p.x - mx);
      syy += (p.y - my) * (p.y - my);
      sxy += (p.x - mx) * (p.y - my);
    }
    const double a = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
    const double l1 = 0.5 * (sxx + syy) + std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
    const double l2 = sxx + syy - l1;
    if (l1 < 4.0 * std::max(l2, 1e-9)) continue;  // not elongated: not a leg
    b.centroid = {mx, my};
    b.dir = {std::cos(a), std::sin(a)};
    legs.push_back(std::move(b));
  }
  if (legs.size() < 2) {
    throw std::runtime_error("calibrate_from_unsunk_frame: found " + std::to_string(legs.size()) +
                             " leg(s) of the leg colour; need at least 2 to locate the hub");
  }
  return legs;
}

struct Hub {
  cv::Vec2d centre;
  double rms_px = 0;  // rms distance of the leg axes from the centre
};

// The hub: least-squares intersection of the leg axes. Throws when the axes are parallel.
Hub fit_hub(const std::vector<Blob>& legs) {
  cv::Matx22d A = cv::Matx22d::zeros();
  cv::Vec2d rhs(0, 0);
  for (const auto& l : legs) {
    const cv::Vec2d nrm(-l.dir.y, l.dir.x);
    const cv::Matx22d nn = nrm * nrm.t();
    A += nn;
    rhs += nn * cv::Vec2d(l.centroid.x, l.centroid.y);
  }
  if (std::abs(cv::determinant(A)) < 1e-6) {
    throw std::runtime_error("calibrate_from_unsunk_frame: leg axes are parallel; hub undefined");
  }
  const cv::Vec2d hub = A.inv() * rhs;
  double rms = 0;
  for (const auto& l : legs) {
    const cv::Vec2d nrm(-l.dir.y, l.dir.x);
    rms += std::pow(nrm.dot(hub - cv::Vec2d(l.centroid.x, l.centroid.y)), 2);
  }
  rms = std::sqrt(rms / static_cast<double>(legs.size()));
  return {hub, rms};
}

// Per-leg measurements, px (offsets: rad); lengths and feet only of the legs that do not touch the border.
struct LegMeasures {
  std::vector<double> lengths, widths, hub_radii, foot_widths, foot_thick, offsets;
};

// The leg's axial width profile: its pixels per 1 px bin of distance from the hub along `u` (none before the hub).
std::vector<double> axial_profile(const Blob& l, const cv::Vec2d& hub, const cv::Point2d& u) {
  std::vector<double> count;
  for (const auto& p : l.pts) {
    const double along = (p.x - hub[0]) * u.x + (p.y - hub[1]) * u.y;
    if (along < 0) continue;
    const auto bi = static_cast<std::size_t>(along);
    if (bi >= count.size()) count.resize(bi + 1, 0.0);
    count[bi] += 1.0;
  }
  return count;
}

// The foot in the profile `count` of a leg of shaft width `w` from bin r0 to the tip bin `end`: a run of bins clearly
// wider than the shaft ending within 3 bins of the tip (the last bins are partial). Adds its median width and its
// thickness to `m` (0 and 0 without a foot).
void measure_foot(const std::vector<double>& count, std::size_t r0, std::size_t end, double w, LegMeasures& m) {
  std::size_t fe = end;
  while (fe > r0 && fe + 3 > end && count[fe] <= 1.3 * w) --fe;
  std::size_t fs = fe + 1;
  while (fs > r0 && count[fs - 1] > 1.3 * w) --fs;
  if (count[fe] <= 1.3 * w) fs = end + 1;
  if (fs <= end) {
    std::vector<double> fw(count.begin() + static_cast<std::ptrdiff_t>(fs),
                           count.begin() + static_cast<std::ptrdiff_t>(fe + 1));
    m.foot_widths.push_back(median_of(fw));
    m.foot_thick.push_back(static_cast<double>(end + 1 - fs));
  } else {
    m.foot_widths.push_back(0.0);
    m.foot_thick.push_back(0.0);
  }
}

// Width, hub radius and angle offset of every leg with a profile; length and foot of those inside the image. Throws
// when no leg lies fully inside the image.
LegMeasures measure_legs(const std::vector<Blob>& legs, const cv::Vec2d& hub, double encoder_angle_rad,
                         const CalibrationHints& hints) {
  LegMeasures m;
  for (const auto& l : legs) {
    cv::Point2d u = l.dir;
    if (u.x * (l.centroid.x - hub[0]) + u.y * (l.centroid.y - hub[1]) < 0) u = -u;
    const std::vector<double> count = axial_profile(l, hub, u);
    if (count.size() < 8) continue;
    // the shaft: middle half of the occupied range
    std::size_t first = 0;
    while (first < count.size() && count[first] < 1.0) ++first;
    const std::size_t last = count.size() - 1;
    std::vector<double> mid(count.begin() + static_cast<std::ptrdiff_t>(first + (last - first) / 4),
                            count.begin() + static_cast<std::ptrdiff_t>(first + (last - first) / 2));
    const double w = median_of(mid);
    if (w < 2.0) continue;
    m.widths.push_back(w);
    std::size_t r0 = first;
    while (r0 < count.size() && count[r0] < 0.5 * w) ++r0;
    m.hub_radii.push_back(static_cast<double>(r0));
    m.offsets.push_back(std::atan2(u.x, u.y) - hints.rotation_direction * encoder_angle_rad);
    if (l.touches_border) continue;
    std::size_t end = last;
    while (end > r0 && count[end] < 0.5 * w) --end;
    m.lengths.push_back(static_cast<double>(end) + 1.0);
    measure_foot(count, r0, end, w, m);
  }
  if (m.lengths.empty() || m.widths.empty()) {
    throw std::runtime_error("calibrate_from_unsunk_frame: no leg lies fully inside the image; cannot measure length");
  }
  return m;
}

// The wheel geometry: the hints, the hub and the medians of the leg measurements (a foot no wider than the shaft is
// none), the angle offset their circular mean modulo the leg spacing.
WheelGeometry wheel_geometry(const LegMeasures& m, const cv::Vec2d& hub, const CalibrationHints& hints) {
  WheelGeometry g;
  g.hub_center_px = {hub[0], hub[1]};
  g.leg_count = hints.leg_count;
  g.leg_spacing_rad = hints.leg_spacing_rad;
  g.rotation_direction = hints.rotation_direction;
  g.leg_length_px = median_of(m.lengths);
  g.leg_width_px = median_of(m.widths);
  g.hub_radius_px = median_of(m.hub_radii);
  g.foot_width_px = median_of(m.foot_widths);
  g.foot_thickness_px = g.foot_width_px > 0 ? median_of(m.foot_thick) : 0.0;
  if (g.foot_width_px <= g.leg_width_px) {
    g.foot_width_px = 0;
    g.foot_thickness_px = 0;
  }
  // angle offset modulo the spacing: circular mean with period = spacing
  double cs = 0, sn = 0;
  const double k = 2.0 * std::numbers::pi / hints.leg_spacing_rad;
  for (double o : m.offsets) {
    cs += std::cos(k * o);
    sn += std::sin(k * o);
  }
  g.angle_offset_rad = std::atan2(sn, cs) / k;
  return g;
}

}  // namespace

CalibrationReport calibrate_from_unsunk_frame(const cv::Mat& bgr, double encoder_angle_rad,
                                              const CalibrationHints& hints) {
  check_inputs(bgr, encoder_angle_rad, hints);
  const std::vector<Blob> legs = find_legs(find_blobs(bgr, hints));
  const Hub hub = fit_hub(legs);
  CalibrationReport rep;
  rep.geometry = wheel_geometry(measure_legs(legs, hub.centre, encoder_angle_rad, hints), hub.centre, hints);
  rep.legs_used = static_cast<int>(legs.size());
  rep.hub_fit_rms_px = hub.rms_px;
  rep.geometry.validate();
  return rep;
}

}  // namespace regolith::sinkage
