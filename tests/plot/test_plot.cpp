// regolith::plot: the pictures the tools write. Colours land where the values are, unknown
// values are grey (or show the image beneath), the colour bar and metric axes are drawn, and
// titles are fitted to the picture.
#include <cmath>
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "regolith/common/plot.hpp"

namespace {

using namespace regolith;

// Pixels of `img` inside `r` that are neither white nor black (drawn colour or grey).
int non_white(const cv::Mat& img, cv::Rect r) {
  int n = 0;
  r &= cv::Rect(0, 0, img.cols, img.rows);
  for (int y = r.y; y < r.y + r.height; ++y)
    for (int x = r.x; x < r.x + r.width; ++x) {
      const cv::Vec3b v = img.at<cv::Vec3b>(y, x);
      n += (v[0] < 250 || v[1] < 250 || v[2] < 250) ? 1 : 0;
    }
  return n;
}

TEST(Plot, NiceTicksCoverTheRangeInRoundSteps) {
  const auto t = plot::nice_ticks(-0.083, 0.124, 6);
  ASSERT_GE(t.size(), 4u);
  EXPECT_NEAR(t[1] - t[0], 0.02, 1e-12);  // 0.207 / 6 = 0.035 -> 2 x 10^-2
  EXPECT_GE(t.front(), -0.083);
  EXPECT_LE(t.back(), 0.124);
  EXPECT_TRUE(plot::nice_ticks(1.0, 1.0).empty());
}

TEST(Plot, ScoreMapIsRedAtZeroGreenAtOneAndGreyWhereUnknown) {
  // 10 x 20 cells: left half 0 (hazard), right half 1 (good), one unknown cell in each half.
  cv::Mat v(10, 20, CV_32F, cv::Scalar(0.0f));
  v(cv::Rect(10, 0, 10, 10)).setTo(1.0f);
  v.at<float>(5, 2) = v.at<float>(5, 15) = std::numeric_limits<float>::quiet_NaN();
  plot::MapStyle s;
  s.title = "traversability: 0 hazard .. 1 good";
  s.palette = plot::Palette::score;
  s.range = cv::Vec2d(0, 1);
  s.image_height_px = 200;  // 20 px per cell
  const cv::Mat img = plot::render_map(v, s);
  ASSERT_EQ(img.type(), CV_8UC3);
  // Without axes the picture starts 12 px in, below a title and the unknown note (58 px).
  const auto cell = [&](int i, int j) { return img.at<cv::Vec3b>(58 + 20 * i + 10, 12 + 20 * j + 10); };
  const cv::Vec3b red = cell(1, 1), green = cell(1, 18), grey = cell(5, 2), grey2 = cell(5, 15);
  EXPECT_GT(red[2], 200);
  EXPECT_LT(red[1], 20);
  EXPECT_GT(green[1], 200);
  EXPECT_LT(green[2], 20);
  EXPECT_EQ(grey, cv::Vec3b(128, 128, 128));
  EXPECT_EQ(grey2, cv::Vec3b(128, 128, 128));
  // The colour bar right of the picture: green at its top, red at its bottom.
  const int bx = 12 + 400 + 16 + 9;
  EXPECT_GT(img.at<cv::Vec3b>(58 + 3, bx)[1], 200);
  EXPECT_GT(img.at<cv::Vec3b>(58 + 196, bx)[2], 200);
}

TEST(Plot, UnknownValuesShowTheUnderlayAndKnownOnesAreTintedOverIt) {
  cv::Mat under(40, 60, CV_8UC1, cv::Scalar(90));
  cv::Mat v(40, 60, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  v(cv::Rect(30, 0, 30, 40)).setTo(0.1f);  // right half known
  plot::MapStyle s;
  s.title = "elevation on the camera image";
  s.range = cv::Vec2d(0.0, 0.1);  // 0.1 = the top of turbo: dark red
  s.image_height_px = 40;         // pictures are drawn at least 50 px tall: x 1.25
  const cv::Mat img = plot::render_map(v, s, under);
  const cv::Vec3b left = img.at<cv::Vec3b>(58 + 20, 12 + 10), right = img.at<cv::Vec3b>(58 + 20, 12 + 50);
  EXPECT_EQ(left, cv::Vec3b(90, 90, 90));
  EXPECT_GT(right[2], right[0] + 30);  // reddish
  // A picture without a scale (hillshade, rectified image): no colour bar beside it.
  s.colour_bar = false;
  EXPECT_EQ(plot::render_map(v, s, under).cols, 12 + 75 + 12);  // drawn at least 50 px tall: 60 x 1.25
  EXPECT_THROW(plot::render_map(v, s, cv::Mat(10, 10, CV_8UC1)), std::invalid_argument);
  EXPECT_THROW(plot::render_map(cv::Mat(4, 4, CV_8U), s), std::invalid_argument);
}

TEST(Plot, MetricAxesGetTicksAndLabelsLeftAndBelow) {
  cv::Mat v(60, 80, CV_32F);
  cv::randu(v, 0.0, 1.0);
  plot::MapStyle s;
  s.title = "with axes";
  s.image_height_px = 240;
  plot::MapStyle a = s;
  a.axes = plot::MapAxes{1.0, -1.0, 5.0, 1.0, "y, left (m)", "x, forward (m)"};
  const cv::Mat plain = plot::render_map(v, s), axed = plot::render_map(v, a);
  EXPECT_GT(axed.cols, plain.cols);  // room for the y ticks and label
  EXPECT_GT(axed.rows, plain.rows);  // and the x ones
  // Tick labels and the axis names are drawn in the margins.
  EXPECT_GT(non_white(axed, cv::Rect(0, 42, 74, 240)), 100);
  EXPECT_GT(non_white(axed, cv::Rect(78, 42 + 240 + 2, 320, 50)), 100);
  EXPECT_LT(non_white(plain, cv::Rect(0, 42, 10, 240)), 5);
}

TEST(Plot, ATitleLongerThanThePictureIsShrunkToFit) {
  cv::Mat img(40, 200, CV_8UC3, cv::Scalar(255, 255, 255));
  plot::put_fitted_text(img, "a title far too long to fit on a picture only two hundred pixels wide", {4, 24}, 192,
                        0.6);
  EXPECT_GT(non_white(img, cv::Rect(0, 0, 200, 40)), 50);
  EXPECT_EQ(non_white(img, cv::Rect(197, 0, 3, 40)), 0);  // nothing spills past the right edge
}

TEST(Plot, HillshadeIsLitFromTheUpperLeftAndKeepsUnknownCellsUnknown) {
  // A ridge along the picture's diagonal: its face towards the upper left is lit brighter than
  // flat ground, its other face darker; flat ground gets cos 45 deg; NaN stays NaN.
  cv::Mat h(40, 40, CV_32F, cv::Scalar(0.0f));
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) h.at<float>(i, j) = static_cast<float>(0.02 * std::max(0, 10 - std::abs(i + j - 40)));
  h.at<float>(2, 2) = std::numeric_limits<float>::quiet_NaN();
  const cv::Mat s = plot::hillshade(h, 0.02);
  ASSERT_EQ(s.type(), CV_32F);
  EXPECT_NEAR(s.at<float>(35, 35), std::sqrt(0.5), 1e-5);  // flat
  EXPECT_GT(s.at<float>(15, 20), 0.9f);                    // rising towards the lower right: faces the light
  EXPECT_LT(s.at<float>(25, 20), 0.5f);                    // falling away from it
  EXPECT_TRUE(std::isnan(s.at<float>(2, 2)));
  EXPECT_NEAR(s.at<float>(2, 3), std::sqrt(0.5), 1e-5);  // a NaN neighbour counts as flat
  EXPECT_THROW(plot::hillshade(cv::Mat(4, 4, CV_8U), 0.02), std::invalid_argument);
  EXPECT_THROW(plot::hillshade(h, 0.0), std::invalid_argument);
}

TEST(Plot, ANorthUpFrameCropsToTheCellsAndThePathAndPutsNorthUp) {
  // A 100 x 80 grid of 5 cm cells, cell (0, 0) centred at (-1, 2) m; cells of interest in rows
  // 40..49, columns 30..39; a path from 1 m south of them.
  cv::Mat mask(100, 80, CV_8U, cv::Scalar(0));
  mask(cv::Rect(30, 40, 10, 10)).setTo(255);
  const cv::Point2d origin(-1.0, 2.0);
  const double cell = 0.05;
  const plot::NorthUpFrame only_cells(mask, origin, cell, {}, 5, 100);
  EXPECT_EQ(only_cells.rows().start, 35);
  EXPECT_EQ(only_cells.rows().end, 55);
  EXPECT_EQ(only_cells.cols().start, 25);
  EXPECT_EQ(only_cells.cols().end, 45);
  EXPECT_EQ(only_cells.scale(), 5);  // 100 px / 20 cells
  EXPECT_EQ(only_cells.size(), cv::Size(100, 100));
  EXPECT_DOUBLE_EQ(only_cells.px_per_m(), 100.0);
  // North up: the southernmost cell of the crop is the bottom row of squares.
  EXPECT_EQ(only_cells.cell(35, 25), cv::Rect(0, 95, 5, 5));
  EXPECT_EQ(only_cells.cell(54, 44), cv::Rect(95, 0, 5, 5));
  // A cell's centre is its square's centre.
  const cv::Point c = only_cells.px(origin.x + 30 * cell, origin.y + 40 * cell);
  EXPECT_TRUE(only_cells.cell(40, 30).contains(c));
  // The path's first point, 20 cells south of the marked ones, is in the picture.
  const std::vector<cv::Point2d> path{{origin.x + 35 * cell, origin.y + 20 * cell},
                                      {origin.x + 35 * cell, origin.y + 45 * cell}};
  const plot::NorthUpFrame with_path(mask, origin, cell, path, 5, 100);
  EXPECT_EQ(with_path.rows().start, 15);
  EXPECT_EQ(with_path.rows().end, 55);
  const cv::Point start = with_path.px(path[0].x, path[0].y);
  EXPECT_TRUE(cv::Rect(cv::Point(0, 0), with_path.size()).contains(start));
  // Points off the grid and a margin past its edge are clamped to the grid; nothing marked = all.
  const std::vector<cv::Point2d> far{{-50.0, -50.0}};
  const plot::NorthUpFrame clamped(mask, origin, cell, far, 5, 100);
  EXPECT_EQ(clamped.rows().start, 0);
  EXPECT_EQ(clamped.cols().start, 0);
  const plot::NorthUpFrame whole(cv::Mat(100, 80, CV_8U, cv::Scalar(0)), origin, cell, {}, 5, 700);
  EXPECT_EQ(whole.rows(), cv::Range(0, 100));
  EXPECT_EQ(whole.cols(), cv::Range(0, 80));
  EXPECT_EQ(whole.scale(), 7);
  // The shade is indexed like the grid: a step up towards the north (higher rows) faces south,
  // away from the north-west light, so the cells on the step are darker than flat ground.
  cv::Mat h(100, 80, CV_32F, cv::Scalar(0.0f));
  h.rowRange(50, 100).setTo(0.2f);
  const cv::Mat s = whole.shade(h, 1.0);
  EXPECT_NEAR(s.at<float>(10, 10), std::sqrt(0.5), 1e-5);
  EXPECT_LT(s.at<float>(50, 40), 0.5f);
  EXPECT_THROW(plot::NorthUpFrame(cv::Mat(4, 4, CV_32F), origin, cell), std::invalid_argument);
  EXPECT_THROW(plot::NorthUpFrame(mask, origin, 0.0), std::invalid_argument);
}

}  // namespace

TEST(Plot, ALegendWrapsWhereTheNextEntryWouldPassTheEdgeAndSaysHowManyLines) {
  const plot::LegendEntry legend[] = {{"corrected path", {0, 220, 0}},
                                      {"wheel odometry", {255, 120, 0}},
                                      {"hazard", {0, 0, 255}},
                                      {"rocks, 95 % ellipse", {0, 230, 255}}};
  EXPECT_EQ(plot::legend_lines(legend, 10, 700), 1);
  EXPECT_EQ(plot::legend_lines(legend, 10, 320), 2);
  EXPECT_EQ(plot::legend_lines(legend, 10, 40), 4);  // narrower than any entry: one per line
  EXPECT_EQ(plot::legend_lines(std::span<const plot::LegendEntry>(), 10, 320), 0);
  // What it draws: every line inside the image, nothing past the edge it was given.
  cv::Mat img(80, 330, CV_8UC3, cv::Scalar(0, 0, 0));
  EXPECT_EQ(plot::put_legend(img, {10, 18}, legend), 2);
  cv::Mat drawn;
  cv::cvtColor(img, drawn, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(cv::countNonZero(drawn(cv::Rect(img.cols - 9, 0, 9, img.rows))), 0);         // the 10 px margin
  EXPECT_GT(cv::countNonZero(drawn(cv::Rect(0, 4, img.cols, 18))), 0);                   // line 1
  EXPECT_GT(cv::countNonZero(drawn(cv::Rect(0, 4 + plot::kLegendLinePx, 120, 18))), 0);  // line 2
  EXPECT_EQ(cv::countNonZero(drawn(cv::Rect(0, 4 + 2 * plot::kLegendLinePx, img.cols, 18))), 0);
}
