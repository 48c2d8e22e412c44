#pragma once
// Small PNG picture writer on OpenCV drawing, one look for every picture the tools write:
//  * render_plot: line/marker plots with axes, ticks, labels and a legend (soil profiles, p-z);
//  * render_map: a value image (a grid layer, a height field, heights painted over a camera
//    image) with a title that fits, a colour bar with ticks in the given unit, metric axes
//    when the picture is metric, and unknown (NaN) cells grey or showing the image beneath.
// Offline tools only: these allocate freely and are never called inside a rate-group cycle.
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::plot {

struct PlotSeries {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  cv::Scalar colour{200, 60, 20};  ///< BGR
  bool markers = false;            ///< draw points instead of a polyline
  bool dashed = false;
};

struct PlotSpec {
  std::string title;
  std::string x_label;
  std::string y_label;
  int width_px = 900;
  int height_px = 600;
  bool y_from_zero = true;  ///< include 0 in the y range
};

/// Renders the series into a CV_8UC3 image. Empty/NaN points are skipped; if nothing is finite
/// the axes are drawn on the unit square with a "no data" note.
cv::Mat render_plot(const PlotSpec& spec, std::span<const PlotSeries> series);

/// Colour scales of render_map.
enum class Palette {
  turbo,  ///< heights (OpenCV's turbo: blue low .. red high)
  jet,    ///< heights, the soil DTM's historical scale
  score,  ///< 0..1 scores: red 0 (bad) .. green 1 (good)
};

/// Metric axes along the picture's edges: the value at the left and right edge of the image
/// (its columns) and at its top and bottom edge (its rows), in the axis's unit.
struct MapAxes {
  double left = 0.0, right = 1.0;
  double top = 1.0, bottom = 0.0;
  std::string x_label;  ///< e.g. "right of the camera (m)"
  std::string y_label;  ///< e.g. "forward (m)"
};

struct MapStyle {
  std::string title;
  std::string unit_label;  ///< above the colour bar, e.g. "cm"
  double scale = 1.0;      ///< colour-bar ticks show value x scale (100: m -> cm)
  Palette palette = Palette::turbo;
  std::optional<cv::Vec2d> range;              ///< value range of the colours; default: 2..98 % of the finite values
  std::optional<MapAxes> axes;                 ///< metric axes; none for an image in pixels
  int image_height_px = 400;                   ///< the value image is scaled (nearest) to about this height
  std::string unknown_note = "grey: unknown";  ///< said under the title when any value is NaN
  bool colour_bar = true;                      ///< false: a picture (the underlay) with a title, no scale
};

/// A CV_32F value image as a picture. With `underlay` (CV_8UC1 or CV_8UC3 of the same size) the
/// colours are blended over it and unknown values show it unchanged (heights on a camera image);
/// without, unknown values are grey. Throws std::invalid_argument on a wrong type or size.
cv::Mat render_map(const cv::Mat& values, const MapStyle& style, const cv::Mat& underlay = cv::Mat());

/// Colour-coded map of a CV_32F height field (NaN shown grey) with a colour bar in `unit_label`
/// units after multiplying by `scale` (e.g. 1000 for mm), full range, jet.
cv::Mat render_height_map(const cv::Mat& height, const std::string& title, const std::string& unit_label, double scale);

/// Hillshade of a CV_32F height field in picture orientation (row 0 at the top, columns to the
/// right; cells `cell_m` apart, heights in m): Lambertian shading lit from the upper left at 45 deg
/// elevation, heights exaggerated `exaggeration` times; CV_32F in 0..1, NaN where the height is
/// NaN (a NaN neighbour counts as the cell's own height).
cv::Mat hillshade(const cv::Mat& height_m, double cell_m, double exaggeration = 1.0);

/// Writes `text` at `org` scaled down (from `scale`) until it fits in `max_width_px`; below a
/// readable size (0.3) it is cut short and ends in "...".
void put_fitted_text(cv::Mat& img, const std::string& text, cv::Point org, int max_width_px, double scale = 0.5,
                     int thickness = 1, cv::Scalar colour = {0, 0, 0});

/// One entry of put_legend: a label, written in the colour it explains.
struct LegendEntry {
  const char* text;
  cv::Scalar colour;
};

/// Writes the entries left to right from `org` (the first one's baseline), each in its colour,
/// starting a new line kLegendLinePx lower before an entry that would pass `max_x` (< 0: 10 px
/// short of the image's right edge). Returns the number of lines written.
int put_legend(cv::Mat& img, cv::Point org, std::span<const LegendEntry> entries, int max_x = -1);
/// The lines put_legend takes for `entries` from x = `x0` within `max_x`.
int legend_lines(std::span<const LegendEntry> entries, int x0, int max_x);
inline constexpr int kLegendLinePx = 18;

/// The furniture of a north-up map picture drawn at `px_per_m`: a 1 m scale bar at its bottom
/// left and a north arrow at its top right, white.
void put_scale_bar_and_north(cv::Mat& img, double px_per_m);

/// The frame of a north-up picture of a metric grid whose row 0 is its south edge and whose cell
/// (0, 0) is centred at `origin_m` (a mapping::WorldMap layer, a drive's truth on it): the grid
/// cropped to the cells marked in `of_interest` (CV_8U, the grid's size; the whole grid when none
/// is marked) and the world points `keep_in_view` (a path that starts before the first seen cell),
/// with `margin_cells` around, clamped to the grid; every cell a square of scale() px, so that
/// the longer side of the picture is about `target_px` (at least 1 px per cell).
class NorthUpFrame {
 public:
  NorthUpFrame(const cv::Mat& of_interest, cv::Point2d origin_m, double cell_m,
               std::span<const cv::Point2d> keep_in_view = {}, int margin_cells = 10, int target_px = 700);
  cv::Size size() const { return {cols_.size() * scale_, rows_.size() * scale_}; }  ///< px
  int scale() const { return scale_; }                                              ///< px per cell
  double px_per_m() const { return scale_ / cell_m_; }
  cv::Range rows() const { return rows_; }  ///< the grid rows in the picture
  cv::Range cols() const { return cols_; }  ///< the grid columns in the picture
  /// The picture's square of grid cell (row, col), a cell of rows() x cols().
  cv::Rect cell(int row, int col) const;
  /// A world point (m) in the picture (a cell's centre is its square's centre).
  cv::Point px(double x_m, double y_m) const;
  /// hillshade() of a grid layer (heights in m) lit from the north-west of the picture, indexed
  /// like the grid (row 0 south).
  cv::Mat shade(const cv::Mat& heights_m, double exaggeration) const;

 private:
  cv::Point2d origin_m_;
  double cell_m_;
  cv::Range rows_, cols_;
  int scale_ = 1;
};

/// cv::imwrite with a clear std::runtime_error naming the file on failure.
void write_png(const std::filesystem::path& path, const cv::Mat& image);

/// "Nice" tick positions covering [lo, hi] (steps of 1, 2 or 5 x 10^k, about `target` ticks).
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

}  // namespace regolith::plot
