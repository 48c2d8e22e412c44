// Camera previews (components/preview): boxes and overlay lines land where the results say, at the
// preview's scale, and the JPEG decodes to the preview's size.
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "regolith/preview/preview.hpp"

using namespace regolith;

namespace {

saliency::RangedRock rock(cv::Rect box, double score, bool hazard, double range_m) {
  saliency::RangedRock r;
  r.detection.box = box;
  r.detection.score = score;
  r.hazard = hazard;
  r.ranged = true;
  r.range_m = range_m;
  return r;
}

bool is_red(const cv::Vec3b& p) {
  return p[2] > 200 && p[1] < 60 && p[0] < 60;
}
bool is_yellow(const cv::Vec3b& p) {
  return p[2] > 200 && p[1] > 180 && p[0] < 60;
}
bool is_green(const cv::Vec3b& p) {
  return p[1] > 200 && p[0] < 60 && p[2] < 60;
}
bool is_grey(const cv::Vec3b& p, int v) {
  return p[0] == v && p[1] == v && p[2] == v;
}

}  // namespace

TEST(PreviewSize, KeepsTheAspectAndNeverEnlarges) {
  EXPECT_EQ(preview::preview_size({640, 480}, 320), cv::Size(320, 240));
  EXPECT_EQ(preview::preview_size({320, 240}, 640), cv::Size(320, 240));
  EXPECT_EQ(preview::preview_size({2048, 1536}, 400), cv::Size(400, 300));
  EXPECT_EQ(preview::preview_size({640, 480}, 1), cv::Size(16, 12));
}

TEST(PreviewRocks, HazardsRedOthersYellowAtThePreviewScale) {
  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(100));
  const std::array<saliency::RangedRock, 2> rocks = {rock({200, 120, 60, 40}, 0.9, true, 1.8),
                                                     rock({40, 160, 40, 30}, 0.5, false, 2.6)};
  cv::Mat out;
  preview::draw_rocks(grey, rocks, 160, out);  // half scale
  ASSERT_EQ(out.size(), cv::Size(160, 120));
  ASSERT_EQ(out.type(), CV_8UC3);
  // hazard box (200,120)-(260,160) -> (100,60)-(129,79): red edges, untouched grey inside
  EXPECT_TRUE(is_red(out.at<cv::Vec3b>(60, 115))) << out.at<cv::Vec3b>(60, 115);
  EXPECT_TRUE(is_red(out.at<cv::Vec3b>(70, 100))) << out.at<cv::Vec3b>(70, 100);
  EXPECT_TRUE(is_grey(out.at<cv::Vec3b>(70, 115), 100)) << out.at<cv::Vec3b>(70, 115);
  // the other box (40,160)-(80,190) -> (20,80)-(39,94): yellow
  EXPECT_TRUE(is_yellow(out.at<cv::Vec3b>(94, 30))) << out.at<cv::Vec3b>(94, 30);
  EXPECT_TRUE(is_yellow(out.at<cv::Vec3b>(87, 20))) << out.at<cv::Vec3b>(87, 20);
  // far from every box and below the caption: the frame
  EXPECT_TRUE(is_grey(out.at<cv::Vec3b>(110, 150), 100));
  // the caption band at the top is black behind white text
  EXPECT_EQ(out.at<cv::Vec3b>(1, 1), cv::Vec3b(0, 0, 0));
}

TEST(PreviewRocks, NoRocksIsTheFrameWithItsCaption) {
  cv::Mat bgr(120, 160, CV_8UC3, cv::Scalar(30, 60, 90)), out;
  preview::draw_rocks(bgr, {}, 160, out);
  ASSERT_EQ(out.size(), bgr.size());
  EXPECT_EQ(out.at<cv::Vec3b>(100, 100), cv::Vec3b(30, 60, 90));
}

TEST(PreviewRocks, BadFramesAreErrors) {
  cv::Mat out;
  EXPECT_THROW(preview::draw_rocks(cv::Mat(), {}, 320, out), std::invalid_argument);
  EXPECT_THROW(preview::draw_rocks(cv::Mat(10, 10, CV_32F), {}, 320, out), std::invalid_argument);
  EXPECT_THROW(preview::draw_sinkage(cv::Mat(10, 10, CV_8UC1), {}, {}, 320, out, out), std::invalid_argument);
}

TEST(PreviewSinkage, TheInterfaceLineIsDrawnWhereTheResultPutsIt) {
  const cv::Mat frame(480, 640, CV_8UC3, cv::Scalar(40, 40, 40));
  sinkage::WheelGeometry g;  // hub (320, 110), legs of 300 px
  sinkage::SinkageResult r;
  r.valid = true;
  r.sinkage_mm = 12.5;
  r.confidence = 0.9;
  r.leg_count = 1;
  r.deepest = 0;
  auto& leg = r.legs[0];
  leg.valid = true;
  leg.angle_rad = 0.0;  // straight down
  leg.interface_left_px = {300.0, 380.0};
  leg.interface_right_px = {340.0, 380.0};
  leg.tip_px = {320.0, 410.0};
  leg.sinkage_px = 30.0;
  cv::Mat scaled, out;
  preview::draw_sinkage(frame, g, r, 640, scaled, out);  // full size
  ASSERT_EQ(out.size(), frame.size());
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(380, 305))) << out.at<cv::Vec3b>(380, 305);  // (320, 380): the blue sinkage
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(380, 335))) << out.at<cv::Vec3b>(380, 335);
  preview::draw_sinkage(frame, g, r, 320, scaled, out);  // half size: drawn at the scaled positions
  ASSERT_EQ(out.size(), cv::Size(320, 240));
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(190, 153))) << out.at<cv::Vec3b>(190, 153);
  EXPECT_TRUE(is_green(out.at<cv::Vec3b>(190, 167))) << out.at<cv::Vec3b>(190, 167);
  EXPECT_FALSE(is_green(out.at<cv::Vec3b>(380 / 2 - 6, 153)));
}

TEST(PreviewJpeg, DecodesToThePreviewAndKeepsTheColours) {
  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(100));
  const std::array<saliency::RangedRock, 1> rocks = {rock({100, 100, 80, 60}, 0.8, true, 2.0)};
  cv::Mat out;
  preview::draw_rocks(grey, rocks, 320, out);
  std::vector<std::uint8_t> bytes;
  ASSERT_TRUE(preview::encode_jpeg(out, 80, bytes));
  EXPECT_GT(bytes.size(), 500u);
  EXPECT_LT(bytes.size(), 320u * 240u);  // compressed
  EXPECT_EQ(bytes[0], 0xFF);             // SOI marker
  EXPECT_EQ(bytes[1], 0xD8);
  const cv::Mat back = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(back.size(), out.size());
  const cv::Vec3b edge = back.at<cv::Vec3b>(100, 140), inside = back.at<cv::Vec3b>(130, 140);
  EXPECT_GT(edge[2], 150) << edge;
  EXPECT_LT(edge[1], 110) << edge;
  EXPECT_NEAR(inside[0], 100, 8);
  EXPECT_FALSE(preview::encode_jpeg(cv::Mat(), 80, bytes));
  EXPECT_FALSE(preview::encode_jpeg(grey, 80, bytes));  // not BGR
}

namespace {
direct_depth::CameraModel front_camera() {
  direct_depth::CameraModel m;  // the mocked rover's front camera: 320x240, 0.5 m up, 0.35 rad down
  m.fx = m.fy = 200.0988;
  m.cx = 159.5;
  m.cy = 119.5;
  m.width = 320;
  m.height = 240;
  m.mount_height_m = 0.5;
  m.pitch_rad = 0.35;
  return m;
}
}  // namespace

TEST(PreviewHazard, EveryPixelFindsTheCellItSeesAndOnlyThoseAreTinted) {
  const direct_depth::DirectDepth depth(front_camera());
  const common::GridGeometry grid{0.05, 3.0, 3.0, 2.5, 0.0};  // 1..4 m ahead, 3 m wide (the mock's)
  const cv::Mat cells = preview::grid_cell_lookup(depth, grid, {160, 120});
  ASSERT_EQ(cells.size(), cv::Size(160, 120));
  ASSERT_EQ(cells.type(), CV_32S);
  // a cell's centre projects to a preview pixel whose cell lies within that pixel's ground
  // footprint (2 camera pixels, up to 0.25 m along the range at 3.5 m) of it
  const int ny = grid.size_y();
  for (const auto& [i, j] : std::vector<std::pair<int, int>>{{10, 30}, {40, 20}, {50, 45}}) {
    const cv::Point2d c = grid.cell_center(i, j);
    const auto px = depth.project(c.x, c.y);
    ASSERT_TRUE(px.has_value());
    const int pr = static_cast<int>(px->y / 2), pc = static_cast<int>(px->x / 2);
    const int k = cells.at<int>(pr, pc);
    ASSERT_GE(k, 0) << i << "," << j;
    const cv::Point2d got = grid.cell_center(k / ny, k % ny);
    const double fr = depth.footprint_range_map().at<float>(2 * pr, 2 * pc);
    const double fl = depth.footprint_lateral_map().at<float>(2 * pr, 2 * pc);
    EXPECT_LE(std::abs(got.x - c.x), 2 * fr + grid.resolution_m) << i << "," << j;
    EXPECT_LE(std::abs(got.y - c.y), 2 * fl + grid.resolution_m) << i << "," << j;
  }
  EXPECT_EQ(cells.at<int>(0, 80), -1);  // above the horizon / beyond 4 m: no cell

  // one impassable block of cells (traversability 0), NaN elsewhere except a free block
  cv::Mat t(grid.size_x(), grid.size_y(), CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  t(cv::Rect(20, 30, 20, 20)).setTo(0.0f);  // cells i 30..49, j 20..39: ~ 1.5-2.5 m ahead, centre
  t(cv::Rect(0, 30, 10, 20)).setTo(1.0f);   // free, on the left
  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(100));
  cv::Mat out;
  preview::draw_rocks(grey, {}, 160, out, preview::HazardOverlay{&cells, &t});
  int tinted = 0, wrong = 0;
  for (int r = 30; r < out.rows; ++r)  // below the caption band
    for (int c = 0; c < out.cols; ++c) {
      const int k = cells.at<int>(r, c);
      const bool blocked = k >= 0 && t.at<float>(k / ny, k % ny) == 0.0f;
      const cv::Vec3b p = out.at<cv::Vec3b>(r, c);
      const bool red = p[2] > 150 && p[0] < 60;
      tinted += red ? 1 : 0;
      wrong += red != blocked ? 1 : 0;
    }
  EXPECT_GT(tinted, 100);
  EXPECT_EQ(wrong, 0);
  EXPECT_THROW(preview::draw_rocks(grey, {}, 320, out, preview::HazardOverlay{&cells, &t}), std::invalid_argument);
}
