#pragma once
// Small PNG plot writer on OpenCV drawing: line/marker plots with axes, ticks, labels and a
// legend, and a colour-coded height map with a colour bar. Used for the sinkage profiles, the
// p-z curves and the track DTM written by run_soil_analysis().
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace regolith::soil {

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

/// Colour-coded map of a CV_32F height field (NaN shown grey) with a colour bar in `unit_label`
/// units after multiplying by `scale` (e.g. 1000 for mm).
cv::Mat render_height_map(const cv::Mat& height, const std::string& title,
                          const std::string& unit_label, double scale);

/// cv::imwrite with a clear std::runtime_error naming the file on failure.
void write_png(const std::filesystem::path& path, const cv::Mat& image);

/// "Nice" tick positions covering [lo, hi] (steps of 1, 2 or 5 x 10^k, about `target` ticks).
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

}  // namespace regolith::soil
