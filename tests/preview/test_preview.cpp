// Camera previews (components/preview): boxes and overlay lines land where the results say, at the
// preview's scale, and the JPEG decodes to the preview's size.
#include <gtest/gtest.h>

#include <array>
#include <stdexcept>
#include <vector>

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

bool is_red(const cv::Vec3b& p) { return p[2] > 200 && p[1] < 60 && p[0] < 60; }
bool is_yellow(const cv::Vec3b& p) { return p[2] > 200 && p[1] > 180 && p[0] < 60; }
bool is_green(const cv::Vec3b& p) { return p[1] > 200 && p[0] < 60 && p[2] < 60; }
bool is_grey(const cv::Vec3b& p, int v) { return p[0] == v && p[1] == v && p[2] == v; }

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
  EXPECT_EQ(bytes[0], 0xFF);  // SOI marker
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
