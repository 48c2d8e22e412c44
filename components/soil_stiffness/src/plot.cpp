#include "regolith/soil_stiffness/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace regolith::soil {
namespace {

std::string fmt_tick(double v, double step) {
  char buf[32];
  const int decimals = step >= 1.0 ? 0 : std::min(6, static_cast<int>(std::ceil(-std::log10(step))));
  if (std::abs(v) >= 1e5 || (std::abs(v) > 0.0 && std::abs(v) < 1e-4)) {
    std::snprintf(buf, sizeof buf, "%.2g", v);
  } else {
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  }
  return buf;
}

void put_text(cv::Mat& img, const std::string& s, cv::Point org, double scale = 0.45,
              int thick = 1, cv::Scalar col = {0, 0, 0}) {
  cv::putText(img, s, org, cv::FONT_HERSHEY_SIMPLEX, scale, col, thick, cv::LINE_AA);
}

cv::Size text_size(const std::string& s, double scale = 0.45, int thick = 1) {
  int base = 0;
  return cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, thick, &base);
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> t;
  if (!(hi > lo) || target < 2) return t;
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double r = raw / mag;
  const double step = (r < 1.5 ? 1.0 : r < 3.5 ? 2.0 : r < 7.5 ? 5.0 : 10.0) * mag;
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step) {
    t.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  }
  return t;
}

cv::Mat render_plot(const PlotSpec& spec, std::span<const PlotSeries> series) {
  cv::Mat img(std::max(200, spec.height_px), std::max(300, spec.width_px), CV_8UC3,
              cv::Scalar(255, 255, 255));
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin;
  double ymin = xmin, ymax = -xmin;
  for (const auto& s : series) {
    const std::size_t m = std::min(s.x.size(), s.y.size());
    for (std::size_t i = 0; i < m; ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xmin = std::min(xmin, s.x[i]);
      xmax = std::max(xmax, s.x[i]);
      ymin = std::min(ymin, s.y[i]);
      ymax = std::max(ymax, s.y[i]);
    }
  }
  const bool empty = !std::isfinite(xmin);
  if (empty) {
    xmin = 0.0; xmax = 1.0; ymin = 0.0; ymax = 1.0;
  }
  if (spec.y_from_zero) {
    ymin = std::min(ymin, 0.0);
    ymax = std::max(ymax, 0.0);
  }
  if (xmax - xmin < 1e-12) { xmin -= 0.5; xmax += 0.5; }
  if (ymax - ymin < 1e-12) { ymin -= 0.5; ymax += 0.5; }
  const double ypad = 0.05 * (ymax - ymin);
  if (!(spec.y_from_zero && ymin == 0.0)) ymin -= ypad;
  ymax += ypad;

  const int left = 90, right = 30, top = 50, bottom = 70;
  const cv::Rect area(left, top, img.cols - left - right, img.rows - top - bottom);
  auto px = [&](double x) {
    return area.x + static_cast<int>(std::lround((x - xmin) / (xmax - xmin) * area.width));
  };
  auto py = [&](double y) {
    return area.y + area.height -
           static_cast<int>(std::lround((y - ymin) / (ymax - ymin) * area.height));
  };
  // grid + ticks
  const auto xt = nice_ticks(xmin, xmax);
  const auto yt = nice_ticks(ymin, ymax);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
  const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double v : xt) {
    const int x = px(v);
    cv::line(img, {x, area.y}, {x, area.y + area.height}, {225, 225, 225}, 1);
    cv::line(img, {x, area.y + area.height}, {x, area.y + area.height + 6}, {0, 0, 0}, 1);
    const std::string s = fmt_tick(v, xstep);
    put_text(img, s, {x - text_size(s).width / 2, area.y + area.height + 22});
  }
  for (double v : yt) {
    const int y = py(v);
    cv::line(img, {area.x, y}, {area.x + area.width, y}, {225, 225, 225}, 1);
    cv::line(img, {area.x - 6, y}, {area.x, y}, {0, 0, 0}, 1);
    const std::string s = fmt_tick(v, ystep);
    put_text(img, s, {area.x - 10 - text_size(s).width, y + 5});
  }
  cv::rectangle(img, area, {0, 0, 0}, 1);
  // labels
  put_text(img, spec.title, {area.x, 30}, 0.65, 2);
  put_text(img, spec.x_label,
           {area.x + area.width / 2 - text_size(spec.x_label, 0.55).width / 2, img.rows - 18},
           0.55);
  {
    const cv::Size ts = text_size(spec.y_label, 0.55);
    cv::Mat lab(ts.height + 12, ts.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
    put_text(lab, spec.y_label, {2, ts.height + 4}, 0.55);
    cv::Mat rot;
    cv::rotate(lab, rot, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int y0 = std::max(0, area.y + area.height / 2 - rot.rows / 2);
    const int h = std::min(rot.rows, img.rows - y0);
    rot(cv::Rect(0, 0, rot.cols, h)).copyTo(img(cv::Rect(8, y0, rot.cols, h)));
  }
  if (empty) put_text(img, "no data", {area.x + area.width / 2 - 30, area.y + area.height / 2}, 0.7, 2);
  // series, then the legend on a box of its own (drawn last: no line crosses it), in the corner
  // of the plot that hides the fewest data points
  std::vector<cv::Point> drawn;
  for (const auto& s : series) {
    const std::size_t m = std::min(s.x.size(), s.y.size());
    std::vector<cv::Point> pts;
    auto flush = [&] {
      if (s.markers) {
        for (const auto& p : pts) cv::circle(img, p, 3, s.colour, cv::FILLED, cv::LINE_AA);
      } else if (s.dashed) {
        for (std::size_t i = 1; i < pts.size(); i += 2)
          cv::line(img, pts[i - 1], pts[i], s.colour, 2, cv::LINE_AA);
      } else if (pts.size() > 1) {
        cv::polylines(img, pts, false, s.colour, 2, cv::LINE_AA);
      }
      pts.clear();
    };
    for (std::size_t i = 0; i < m; ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        flush();
        continue;
      }
      pts.emplace_back(px(s.x[i]), py(s.y[i]));
      drawn.push_back(pts.back());
    }
    flush();
  }
  const int labelled = static_cast<int>(std::count_if(series.begin(), series.end(), [](const auto& s) { return !s.label.empty(); }));
  if (labelled > 0) {
    int text_w = 0;
    for (const auto& s : series)
      if (!s.label.empty()) text_w = std::max(text_w, text_size(s.label).width);
    const cv::Size box(std::min(area.width - 8, text_w + 56), 12 + 20 * labelled);
    cv::Rect best;
    std::size_t hidden_best = 0;
    for (const cv::Point corner : {cv::Point(area.x + area.width - 4 - box.width, area.y + 4),
                                   cv::Point(area.x + 4, area.y + 4),
                                   cv::Point(area.x + area.width - 4 - box.width, area.y + area.height - 4 - box.height),
                                   cv::Point(area.x + 4, area.y + area.height - 4 - box.height)}) {
      const cv::Rect r(corner, box);
      const auto hidden = static_cast<std::size_t>(
          std::count_if(drawn.begin(), drawn.end(), [&r](const cv::Point& p) { return r.contains(p); }));
      if (best.area() == 0 || hidden < hidden_best) {
        best = r;
        hidden_best = hidden;
      }
    }
    cv::rectangle(img, best, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(img, best, cv::Scalar(200, 200, 200), 1);
    const int lx = best.x + 8;
    int legend_y = best.y + 16;
    for (const auto& s : series) {
      if (s.label.empty()) continue;
      cv::line(img, {lx, legend_y - 5}, {lx + 30, legend_y - 5}, s.colour, 3);
      put_text(img, s.label, {lx + 38, legend_y});
      legend_y += 20;
    }
  }
  return img;
}

cv::Mat render_height_map(const cv::Mat& height, const std::string& title,
                          const std::string& unit_label, double scale) {
  if (height.empty() || height.type() != CV_32F)
    throw std::invalid_argument("height: expected a non-empty CV_32F map");
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int r = 0; r < height.rows; ++r) {
    const float* p = height.ptr<float>(r);
    for (int c = 0; c < height.cols; ++c) {
      if (!std::isfinite(p[c])) continue;
      lo = std::min(lo, static_cast<double>(p[c]));
      hi = std::max(hi, static_cast<double>(p[c]));
    }
  }
  if (!std::isfinite(lo)) { lo = 0.0; hi = 1.0; }
  if (hi - lo < 1e-12) hi = lo + 1e-12;
  cv::Mat grey(height.size(), CV_8U);
  cv::Mat invalid(height.size(), CV_8U, cv::Scalar(0));
  for (int r = 0; r < height.rows; ++r) {
    const float* p = height.ptr<float>(r);
    auto* g = grey.ptr<unsigned char>(r);
    for (int c = 0; c < height.cols; ++c) {
      if (!std::isfinite(p[c])) { g[c] = 0; invalid.at<unsigned char>(r, c) = 255; continue; }
      g[c] = cv::saturate_cast<unsigned char>((p[c] - lo) / (hi - lo) * 255.0);
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(128, 128, 128), invalid);
  const int target_h = 480;
  const double f = static_cast<double>(target_h) / std::max(1, colour.rows);
  cv::Mat big;
  cv::resize(colour, big, cv::Size(std::max(1, static_cast<int>(colour.cols * f)), target_h), 0, 0,
             cv::INTER_NEAREST);
  cv::Mat out(target_h + 70, big.cols + 150, CV_8UC3, cv::Scalar(255, 255, 255));
  big.copyTo(out(cv::Rect(10, 50, big.cols, big.rows)));
  put_text(out, title, {10, 30}, 0.6, 2);
  // colour bar
  const int bx = big.cols + 30, bw = 20;
  for (int i = 0; i < target_h; ++i) {
    cv::Mat v(1, 1, CV_8U, cv::Scalar(255 - i * 255 / (target_h - 1)));
    cv::Mat c;
    cv::applyColorMap(v, c, cv::COLORMAP_JET);
    cv::line(out, {bx, 50 + i}, {bx + bw, 50 + i}, c.at<cv::Vec3b>(0, 0), 1);
  }
  cv::rectangle(out, cv::Rect(bx, 50, bw, target_h), {0, 0, 0}, 1);
  const auto ticks = nice_ticks(lo * scale, hi * scale, 6);
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 1.0;
  for (double t : ticks) {
    const int y = 50 + target_h - 1 -
                  static_cast<int>(std::lround((t / scale - lo) / (hi - lo) * (target_h - 1)));
    cv::line(out, {bx + bw, y}, {bx + bw + 5, y}, {0, 0, 0}, 1);
    put_text(out, fmt_tick(t, step), {bx + bw + 8, y + 5}, 0.4);
  }
  put_text(out, unit_label, {bx - 5, 45}, 0.45);
  return out;
}

void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path.string() + ": cannot write PNG: " + e.what());
  }
  if (!ok) throw std::runtime_error(path.string() + ": cannot write PNG");
}

}  // namespace regolith::soil
