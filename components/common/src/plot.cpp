#include "regolith/common/plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace regolith::plot {
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

void put_text(cv::Mat& img, const std::string& s, cv::Point org, double scale = 0.45, int thick = 1,
              cv::Scalar col = {0, 0, 0}) {
  cv::putText(img, s, org, cv::FONT_HERSHEY_SIMPLEX, scale, col, thick, cv::LINE_AA);
}

cv::Size text_size(const std::string& s, double scale = 0.45, int thick = 1) {
  int base = 0;
  return cv::getTextSize(s, cv::FONT_HERSHEY_SIMPLEX, scale, thick, &base);
}

// Text turned 90 degrees counter-clockwise (read bottom to top), its left edge at x, centred on y.
void put_vertical_text(cv::Mat& img, const std::string& s, int x, int y_centre, double scale) {
  if (s.empty()) return;
  const cv::Size ts = text_size(s, scale);
  cv::Mat lab(ts.height + 12, ts.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
  put_text(lab, s, {2, ts.height + 4}, scale);
  cv::Mat rot;
  cv::rotate(lab, rot, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int y0 = std::clamp(y_centre - rot.rows / 2, 0, std::max(0, img.rows - rot.rows));
  const int h = std::min(rot.rows, img.rows - y0), w = std::min(rot.cols, img.cols - x);
  if (h > 0 && w > 0) rot(cv::Rect(0, 0, w, h)).copyTo(img(cv::Rect(x, y0, w, h)));
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

namespace {

// Where render_plot draws: the data bounds and the pixel rectangle they map onto.
struct PlotFrame {
  double xmin = 0.0, xmax = 1.0, ymin = 0.0, ymax = 1.0;
  cv::Rect area;
  bool empty = true;  // no finite point: the unit square
  int px(double x) const { return area.x + static_cast<int>(std::lround((x - xmin) / (xmax - xmin) * area.width)); }
  int py(double y) const {
    return area.y + area.height - static_cast<int>(std::lround((y - ymin) / (ymax - ymin) * area.height));
  }
};

// The bounds of the finite points (0 included when the spec asks, a degenerate range widened to
// 1, y padded by 5 %) and the plot area inside `image`'s margins.
PlotFrame plot_frame(const PlotSpec& spec, std::span<const PlotSeries> series, cv::Size image) {
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
  PlotFrame f;
  f.empty = !std::isfinite(xmin);
  if (!f.empty) {
    f.xmin = xmin;
    f.xmax = xmax;
    f.ymin = ymin;
    f.ymax = ymax;
  }
  if (spec.y_from_zero) {
    f.ymin = std::min(f.ymin, 0.0);
    f.ymax = std::max(f.ymax, 0.0);
  }
  if (f.xmax - f.xmin < 1e-12) {
    f.xmin -= 0.5;
    f.xmax += 0.5;
  }
  if (f.ymax - f.ymin < 1e-12) {
    f.ymin -= 0.5;
    f.ymax += 0.5;
  }
  const double ypad = 0.05 * (f.ymax - f.ymin);
  if (!(spec.y_from_zero && f.ymin == 0.0)) f.ymin -= ypad;
  f.ymax += ypad;
  const int left = 90, right = 30, top = 50, bottom = 70;
  f.area = cv::Rect(left, top, image.width - left - right, image.height - top - bottom);
  return f;
}

// Grid lines, ticks with their values, the frame, the title and the axis labels.
void draw_axes(cv::Mat& img, const PlotSpec& spec, const PlotFrame& f) {
  const cv::Rect& area = f.area;
  const auto xt = nice_ticks(f.xmin, f.xmax);
  const auto yt = nice_ticks(f.ymin, f.ymax);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
  const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double v : xt) {
    const int x = f.px(v);
    cv::line(img, {x, area.y}, {x, area.y + area.height}, {225, 225, 225}, 1);
    cv::line(img, {x, area.y + area.height}, {x, area.y + area.height + 6}, {0, 0, 0}, 1);
    const std::string s = fmt_tick(v, xstep);
    put_text(img, s, {x - text_size(s).width / 2, area.y + area.height + 22});
  }
  for (double v : yt) {
    const int y = f.py(v);
    cv::line(img, {area.x, y}, {area.x + area.width, y}, {225, 225, 225}, 1);
    cv::line(img, {area.x - 6, y}, {area.x, y}, {0, 0, 0}, 1);
    const std::string s = fmt_tick(v, ystep);
    put_text(img, s, {area.x - 10 - text_size(s).width, y + 5});
  }
  cv::rectangle(img, area, {0, 0, 0}, 1);
  put_text(img, spec.title, {area.x, 30}, 0.65, 2);
  put_text(img, spec.x_label, {area.x + area.width / 2 - text_size(spec.x_label, 0.55).width / 2, img.rows - 18}, 0.55);
  put_vertical_text(img, spec.y_label, 8, area.y + area.height / 2, 0.55);
  if (f.empty) put_text(img, "no data", {area.x + area.width / 2 - 30, area.y + area.height / 2}, 0.7, 2);
}

// Each series as markers, a dashed or a solid line (broken at non-finite points); returns every
// point drawn (the legend avoids them).
std::vector<cv::Point> draw_series(cv::Mat& img, std::span<const PlotSeries> series, const PlotFrame& f) {
  std::vector<cv::Point> drawn;
  for (const auto& s : series) {
    const std::size_t m = std::min(s.x.size(), s.y.size());
    std::vector<cv::Point> pts;
    auto flush = [&] {
      if (s.markers) {
        for (const auto& p : pts) cv::circle(img, p, 3, s.colour, cv::FILLED, cv::LINE_AA);
      } else if (s.dashed) {
        for (std::size_t i = 1; i < pts.size(); i += 2) cv::line(img, pts[i - 1], pts[i], s.colour, 2, cv::LINE_AA);
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
      pts.emplace_back(f.px(s.x[i]), f.py(s.y[i]));
      drawn.push_back(pts.back());
    }
    flush();
  }
  return drawn;
}

// The labelled series' legend on a box of its own (drawn last: no line crosses it), in the corner
// of the plot area that hides the fewest drawn points.
void draw_legend(cv::Mat& img, std::span<const PlotSeries> series, const cv::Rect& area,
                 const std::vector<cv::Point>& drawn) {
  const int labelled =
      static_cast<int>(std::count_if(series.begin(), series.end(), [](const auto& s) { return !s.label.empty(); }));
  if (labelled == 0) return;
  int text_w = 0;
  for (const auto& s : series)
    if (!s.label.empty()) text_w = std::max(text_w, text_size(s.label).width);
  const cv::Size box(std::min(area.width - 8, text_w + 56), 12 + 20 * labelled);
  cv::Rect best;
  std::size_t hidden_best = 0;
  for (const cv::Point corner :
       {cv::Point(area.x + area.width - 4 - box.width, area.y + 4), cv::Point(area.x + 4, area.y + 4),
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

}  // namespace

cv::Mat render_plot(const PlotSpec& spec, std::span<const PlotSeries> series) {
  cv::Mat img(std::max(200, spec.height_px), std::max(300, spec.width_px), CV_8UC3, cv::Scalar(255, 255, 255));
  const PlotFrame frame = plot_frame(spec, series, img.size());
  draw_axes(img, spec, frame);
  draw_legend(img, series, frame.area, draw_series(img, series, frame));
  return img;
}

void put_fitted_text(cv::Mat& img, const std::string& text, cv::Point org, int max_width_px, double scale,
                     int thickness, cv::Scalar colour) {
  while (scale > 0.3 && text_size(text, scale, thickness).width > max_width_px) scale *= 0.92;
  std::string shown = text;  // still too wide at the smallest readable size: cut, with "..."
  while (shown.size() > 3 && text_size(shown, scale, thickness).width > max_width_px)
    shown = shown.substr(0, shown.size() - 4) + "...";
  put_text(img, shown, org, scale, thickness, colour);
}

namespace {

// 2..98 % of the finite values (the colours of a map are not spent on a few outliers).
cv::Vec2d robust_range(const cv::Mat& values) {
  std::vector<float> v;
  v.reserve(values.total());
  for (int r = 0; r < values.rows; ++r) {
    const float* p = values.ptr<float>(r);
    for (int c = 0; c < values.cols; ++c)
      if (std::isfinite(p[c])) v.push_back(p[c]);
  }
  if (v.empty()) return {0.0, 1.0};
  std::sort(v.begin(), v.end());
  return {v[v.size() * 2 / 100], v[std::min(v.size() - 1, v.size() * 98 / 100)]};
}

// The palette's 256 colours, entry i for the value fraction i / 255 (one applyColorMap on a ramp).
std::array<cv::Vec3b, 256> palette_table(Palette p) {
  std::array<cv::Vec3b, 256> lut;
  if (p == Palette::score) {
    for (int i = 0; i < 256; ++i) {
      const double t = i / 255.0;
      lut[static_cast<std::size_t>(i)] = {40, static_cast<uchar>(std::lround(220 * t)),
                                          static_cast<uchar>(std::lround(220 * (1 - t)))};
    }
    return lut;
  }
  cv::Mat ramp(1, 256, CV_8U), colours;
  for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(i);
  cv::applyColorMap(ramp, colours, p == Palette::jet ? cv::COLORMAP_JET : cv::COLORMAP_TURBO);
  for (int i = 0; i < 256; ++i) lut[static_cast<std::size_t>(i)] = colours.at<cv::Vec3b>(0, i);
  return lut;
}

}  // namespace

cv::Mat render_map(const cv::Mat& values, const MapStyle& style, const cv::Mat& underlay) {
  if (values.empty() || values.type() != CV_32F)
    throw std::invalid_argument("render_map: expected a non-empty CV_32F image");
  if (!underlay.empty() &&
      (underlay.size() != values.size() || (underlay.type() != CV_8UC1 && underlay.type() != CV_8UC3)))
    throw std::invalid_argument("render_map: the underlay must be an 8-bit grey or BGR image of the values' size");
  cv::Vec2d range = style.range ? *style.range : robust_range(values);
  if (!(range[1] > range[0])) range[1] = range[0] + 1e-6;
  // Colours at the values' own size, from the palette's 256 entries.
  const std::array<cv::Vec3b, 256> lut = palette_table(style.palette);
  cv::Mat base;
  if (underlay.empty())
    base = cv::Mat(values.size(), CV_8UC3, cv::Scalar(128, 128, 128));
  else if (underlay.channels() == 1)
    cv::cvtColor(underlay, base, cv::COLOR_GRAY2BGR);
  else
    base = underlay.clone();
  bool any_unknown = false;
  for (int r = 0; r < values.rows; ++r) {
    const float* p = values.ptr<float>(r);
    auto* o = base.ptr<cv::Vec3b>(r);
    for (int c = 0; c < values.cols; ++c) {
      if (!std::isfinite(p[c])) {
        any_unknown = true;
        continue;
      }
      const double t = std::clamp((p[c] - range[0]) / (range[1] - range[0]), 0.0, 1.0);
      const cv::Vec3b col = lut[static_cast<std::size_t>(std::lround(255 * t))];
      if (underlay.empty())
        o[c] = col;
      else
        for (int k = 0; k < 3; ++k) o[c][k] = static_cast<uchar>((2 * col[k] + o[c][k]) / 3);  // 2/3 colour
    }
  }
  // Scaled to about the asked height (and at most 900 px wide): nearest for grid cells, area
  // averaging when a camera image shrinks.
  double f = static_cast<double>(std::max(50, style.image_height_px)) / values.rows;
  f = std::min(f, 900.0 / values.cols);
  cv::Mat big;
  cv::resize(base, big,
             cv::Size(std::max(1, static_cast<int>(std::lround(values.cols * f))),
                      std::max(1, static_cast<int>(std::lround(values.rows * f)))),
             0, 0, f < 1.0 ? cv::INTER_AREA : cv::INTER_NEAREST);
  const bool axes = style.axes.has_value();
  const bool note = any_unknown && !style.unknown_note.empty();
  const int left = axes ? 78 : 12, top = note ? 58 : 42, bottom = axes ? 56 : 14, bar_w = 18,
            right = style.colour_bar ? 100 : 12;
  cv::Mat out(top + big.rows + bottom, left + big.cols + right, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Rect area(left, top, big.cols, big.rows);
  big.copyTo(out(area));
  cv::rectangle(out, area, {0, 0, 0}, 1);
  put_fitted_text(out, style.title, {10, 26}, out.cols - 20, 0.6, 1);
  if (note) put_fitted_text(out, style.unknown_note, {10, 46}, out.cols - 20, 0.42, 1, {90, 90, 90});
  if (axes) {
    const MapAxes& a = *style.axes;
    const auto xt = nice_ticks(std::min(a.left, a.right), std::max(a.left, a.right), 6);
    const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
    for (double v : xt) {
      const int x = area.x + static_cast<int>(std::lround((v - a.left) / (a.right - a.left) * area.width));
      cv::line(out, {x, area.y + area.height}, {x, area.y + area.height + 5}, {0, 0, 0}, 1);
      const std::string s = fmt_tick(v, xstep);
      put_text(out, s, {x - text_size(s, 0.4).width / 2, area.y + area.height + 20}, 0.4);
    }
    put_text(out, a.x_label, {area.x + area.width / 2 - text_size(a.x_label, 0.45).width / 2, out.rows - 10}, 0.45);
    const auto yt = nice_ticks(std::min(a.top, a.bottom), std::max(a.top, a.bottom), 6);
    const double ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
    for (double v : yt) {
      const int y = area.y + static_cast<int>(std::lround((v - a.top) / (a.bottom - a.top) * area.height));
      cv::line(out, {area.x - 5, y}, {area.x, y}, {0, 0, 0}, 1);
      const std::string s = fmt_tick(v, ystep);
      put_text(out, s, {area.x - 8 - text_size(s, 0.4).width, y + 5}, 0.4);
    }
    put_vertical_text(out, a.y_label, 4, area.y + area.height / 2, 0.45);
  }
  if (!style.colour_bar) return out;
  // Colour bar beside the picture, value ticks in the style's unit.
  const int bx = area.x + area.width + 16;
  for (int i = 0; i < area.height; ++i) {
    const double t = 1.0 - static_cast<double>(i) / std::max(1, area.height - 1);
    cv::line(out, {bx, area.y + i}, {bx + bar_w, area.y + i}, lut[static_cast<std::size_t>(std::lround(255 * t))], 1);
  }
  cv::rectangle(out, cv::Rect(bx, area.y, bar_w, area.height), {0, 0, 0}, 1);
  const auto ticks = nice_ticks(range[0] * style.scale, range[1] * style.scale, 6);
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : 1.0;
  for (double t : ticks) {
    const double u = (t / style.scale - range[0]) / (range[1] - range[0]);
    const int y = area.y + area.height - 1 - static_cast<int>(std::lround(u * (area.height - 1)));
    cv::line(out, {bx + bar_w, y}, {bx + bar_w + 4, y}, {0, 0, 0}, 1);
    put_text(out, fmt_tick(t, step), {bx + bar_w + 7, y + 5}, 0.4);
  }
  put_fitted_text(out, style.unit_label, {bx - 4, area.y - 6}, out.cols - bx, 0.45);
  return out;
}

cv::Mat hillshade(const cv::Mat& height_m, double cell_m, double exaggeration) {
  if (height_m.empty() || height_m.type() != CV_32F)
    throw std::invalid_argument("hillshade: expected a non-empty CV_32F map");
  if (!(cell_m > 0) || !std::isfinite(exaggeration)) throw std::invalid_argument("hillshade: cell_m must be > 0");
  const int R = height_m.rows, C = height_m.cols;
  cv::Mat out(R, C, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  // The light in (right, up the picture, out of it): from the upper left, 45 deg above the ground.
  const double lx = -0.5, ly = 0.5, lz = std::sqrt(0.5);
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) {
      const float z = height_m.at<float>(i, j);
      if (!std::isfinite(z)) continue;
      const auto at = [&](int a, int b) {
        const float v = height_m.at<float>(std::clamp(a, 0, R - 1), std::clamp(b, 0, C - 1));
        return std::isfinite(v) ? static_cast<double>(v) : static_cast<double>(z);
      };
      const double gx = exaggeration * (at(i, j + 1) - at(i, j - 1)) / (2.0 * cell_m);
      const double gy = exaggeration * (at(i - 1, j) - at(i + 1, j)) / (2.0 * cell_m);  // up the picture
      const double shade = (-gx * lx - gy * ly + lz) / std::sqrt(gx * gx + gy * gy + 1.0);
      out.at<float>(i, j) = static_cast<float>(std::clamp(shade, 0.0, 1.0));
    }
  return out;
}

cv::Mat render_height_map(const cv::Mat& height, const std::string& title, const std::string& unit_label,
                          double scale) {
  if (height.empty() || height.type() != CV_32F) throw std::invalid_argument("height: expected a non-empty CV_32F map");
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int r = 0; r < height.rows; ++r) {
    const float* p = height.ptr<float>(r);
    for (int c = 0; c < height.cols; ++c)
      if (std::isfinite(p[c]))
        lo = std::min(lo, static_cast<double>(p[c])), hi = std::max(hi, static_cast<double>(p[c]));
  }
  MapStyle style;
  style.title = title;
  style.unit_label = unit_label;
  style.scale = scale;
  style.palette = Palette::jet;
  if (std::isfinite(lo)) style.range = cv::Vec2d(lo, hi);
  style.image_height_px = 480;
  return render_map(height, style);
}

namespace {
constexpr double kLegendScale = 0.42;
constexpr int kLegendGapPx = 14;

// Lays the entries out from x0 (baseline y0), calling put(entry, origin) for each; the lines used.
template <class Put>
int lay_out_legend(std::span<const LegendEntry> entries, int x0, int y0, int max_x, Put&& put) {
  int lines = entries.empty() ? 0 : 1;
  cv::Point at(x0, y0);
  for (const LegendEntry& e : entries) {
    int base = 0;
    const int w = cv::getTextSize(e.text, cv::FONT_HERSHEY_SIMPLEX, kLegendScale, 1, &base).width;
    if (at.x > x0 && at.x + w > max_x) {  // a new line; an entry wider than the line stays alone on its own
      at = cv::Point(x0, at.y + kLegendLinePx);
      ++lines;
    }
    put(e, at);
    at.x += w + kLegendGapPx;
  }
  return lines;
}
}  // namespace

int legend_lines(std::span<const LegendEntry> entries, int x0, int max_x) {
  return lay_out_legend(entries, x0, 0, max_x, [](const LegendEntry&, cv::Point) {});
}

int put_legend(cv::Mat& img, cv::Point org, std::span<const LegendEntry> entries, int max_x) {
  return lay_out_legend(
      entries, org.x, org.y, max_x < 0 ? img.cols - 10 : max_x, [&](const LegendEntry& e, cv::Point at) {
        cv::putText(img, e.text, at, cv::FONT_HERSHEY_SIMPLEX, kLegendScale, e.colour, 1, cv::LINE_AA);
      });
}

void put_scale_bar_and_north(cv::Mat& img, double px_per_m) {
  const cv::Scalar white(255, 255, 255);
  const int bar = static_cast<int>(std::lround(px_per_m));
  const cv::Point b0(15, img.rows - 20);
  cv::rectangle(img, b0, b0 + cv::Point(bar, 6), white, cv::FILLED);
  cv::putText(img, "1 m", b0 + cv::Point(0, -8), cv::FONT_HERSHEY_SIMPLEX, 0.5, white, 1, cv::LINE_AA);
  cv::arrowedLine(img, cv::Point(img.cols - 25, 50), cv::Point(img.cols - 25, 15), white, 2, cv::LINE_AA, 0, 0.3);
  cv::putText(img, "N", cv::Point(img.cols - 31, 66), cv::FONT_HERSHEY_SIMPLEX, 0.5, white, 1, cv::LINE_AA);
}

NorthUpFrame::NorthUpFrame(const cv::Mat& of_interest, cv::Point2d origin_m, double cell_m,
                           std::span<const cv::Point2d> keep_in_view, int margin_cells, int target_px)
    : origin_m_(origin_m), cell_m_(cell_m) {
  if (of_interest.empty() || of_interest.type() != CV_8U)
    throw std::invalid_argument("NorthUpFrame: expected a non-empty CV_8U mask of the grid");
  if (!(cell_m > 0)) throw std::invalid_argument("NorthUpFrame: cell_m must be > 0");
  const int R = of_interest.rows, C = of_interest.cols;
  int r0 = R, r1 = -1, c0 = C, c1 = -1;
  const auto take = [&](int i, int j) {
    r0 = std::min(r0, i), r1 = std::max(r1, i), c0 = std::min(c0, j), c1 = std::max(c1, j);
  };
  for (int i = 0; i < R; ++i) {
    const uchar* m = of_interest.ptr<uchar>(i);
    for (int j = 0; j < C; ++j)
      if (m[j]) take(i, j);
  }
  for (const cv::Point2d& p : keep_in_view) {
    const double i = std::round((p.y - origin_m.y) / cell_m), j = std::round((p.x - origin_m.x) / cell_m);
    if (std::isfinite(i) && std::isfinite(j))
      take(static_cast<int>(std::clamp(i, 0.0, R - 1.0)), static_cast<int>(std::clamp(j, 0.0, C - 1.0)));
  }
  if (r1 < r0) r0 = c0 = 0, r1 = R - 1, c1 = C - 1;
  margin_cells = std::max(0, margin_cells);
  rows_ = {std::max(0, r0 - margin_cells), std::min(R - 1, r1 + margin_cells) + 1};
  cols_ = {std::max(0, c0 - margin_cells), std::min(C - 1, c1 + margin_cells) + 1};
  scale_ = std::max(1, target_px / std::max(rows_.size(), cols_.size()));
}

cv::Rect NorthUpFrame::cell(int row, int col) const {
  return {(col - cols_.start) * scale_, (rows_.end - 1 - row) * scale_, scale_, scale_};
}

cv::Point NorthUpFrame::px(double x_m, double y_m) const {
  const double j = (x_m - origin_m_.x) / cell_m_ - cols_.start, i = (y_m - origin_m_.y) / cell_m_ - rows_.start;
  return {static_cast<int>(std::lround((j + 0.5) * scale_)),
          static_cast<int>(std::lround((rows_.size() - 1 - i + 0.5) * scale_))};
}

cv::Mat NorthUpFrame::shade(const cv::Mat& heights_m, double exaggeration) const {
  cv::Mat north_up, shaded;
  cv::flip(heights_m, north_up, 0);
  cv::flip(hillshade(north_up, cell_m_, exaggeration), shaded, 0);
  return shaded;
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

}  // namespace regolith::plot
