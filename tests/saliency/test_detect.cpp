// Otsu threshold and the box post-processing on constructed images with known
// answers.
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/evaluate.hpp"

namespace rs = regolith::saliency;

TEST(Otsu, TwoPeaksSplitBetweenThem) {
  std::array<double, 256> h{};
  h[40] = 300;
  h[200] = 100;
  const int t = rs::otsu_threshold(h);
  EXPECT_GE(t, 40);
  EXPECT_LT(t, 200);
  // Constant histogram: no split.
  std::array<double, 256> c{};
  c[77] = 10;
  EXPECT_EQ(rs::otsu_threshold(c), 0);
}

TEST(Otsu, AgreesWithOpenCvOnNoisyBimodalImages) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    cv::Mat img(120, 160, CV_8U);
    std::normal_distribution<double> dark(60 + 5 * trial, 12), bright(170 - 3 * trial, 20);
    for (int y = 0; y < img.rows; ++y) {
      for (int x = 0; x < img.cols; ++x) {
        const bool fg = (x - 80) * (x - 80) + (y - 60) * (y - 60) < 35 * 35;
        img.at<uchar>(y, x) = cv::saturate_cast<uchar>(fg ? bright(rng) : dark(rng));
      }
    }
    cv::Mat dummy;
    const double ocv = cv::threshold(img, dummy, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
    EXPECT_EQ(rs::otsu_threshold(img), static_cast<int>(ocv)) << "trial " << trial;
  }
}

TEST(Otsu, KnownValueOfTheCriterion) {
  // Values 0 (x2), 10 (x1), 100 (x1): candidate splits after 0 or after 10.
  // T=0: w0=.5 w1=.5 mu0=0 mu1=55 -> 756.25; T=10: w0=.75 w1=.25 mu0=3.33
  // mu1=100 -> 1752.08.
  std::array<double, 256> h{};
  h[0] = 2;
  h[10] = 1;
  h[100] = 1;
  const int t = rs::otsu_threshold(h);
  EXPECT_GE(t, 10);
  EXPECT_LT(t, 100);
}

TEST(BoxDetector, FindsKnownBlobsWithTightBoxes) {
  cv::Mat sal = cv::Mat::zeros(200, 300, CV_32F);
  cv::circle(sal, {50, 60}, 20, cv::Scalar(1.0),
             cv::FILLED);  // box x 30..70, y 40..80
  cv::rectangle(sal, cv::Rect(150, 100, 60, 40), cv::Scalar(0.5), cv::FILLED);
  cv::circle(sal, {260, 30}, 3, cv::Scalar(0.8),
             cv::FILLED);  // ~29 px < min area
  rs::PostProcessParams p;
  p.open_radius = 1;
  p.close_radius = 1;
  p.min_area = 100;
  rs::BoxDetector det(p);
  std::vector<rs::Detection> out;
  const int thr = det.detect(sal, out);
  EXPECT_LT(thr, 127);  // the background (0) against everything else
  ASSERT_EQ(out.size(), 2u);
  // Sorted by score: the disc (1.0 over pi/4 of its box, mean 0.75) first.
  EXPECT_NEAR(rs::iou(out[0].box, cv::Rect(30, 40, 41, 41)), 1.0, 0.08);
  EXPECT_EQ(out[1].box, cv::Rect(150, 100, 60, 40));
  EXPECT_NEAR(out[1].score, 0.5, 0.01);
  EXPECT_GT(out[0].score, out[1].score);
  EXPECT_GT(out[0].area, 1100);  // pi * 20^2 = 1257
  // The rectangle is in the binary mask except the 4 corner pixels the opening
  // rounds off.
  EXPECT_EQ(cv::countNonZero(det.mask()(cv::Rect(150, 100, 60, 40))), 60 * 40 - 4);
}

TEST(BoxDetector, MaxDetectionsKeepsBestAndEmptyMapGivesNothing) {
  cv::Mat sal = cv::Mat::zeros(100, 100, CV_32F);
  for (int k = 0; k < 4; ++k) {
    sal(cv::Rect(5 + 24 * k, 40, 15, 15)).setTo(0.2f * static_cast<float>(k + 1));
  }
  rs::PostProcessParams p;
  p.max_detections = 2;
  p.min_area = 10;
  p.threshold_scale = 0.1;  // keep all four squares above threshold
  rs::BoxDetector det(p);
  std::vector<rs::Detection> out;
  det.detect(sal, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].box.x, 5 + 24 * 3);
  EXPECT_EQ(out[1].box.x, 5 + 24 * 2);
  det.detect(cv::Mat::zeros(100, 100, CV_32F), out);
  EXPECT_TRUE(out.empty());
}

TEST(BoxDetector, BadParametersAndInputNameTheField) {
  rs::PostProcessParams p;
  p.threshold_scale = std::nan("");
  try {
    rs::BoxDetector d(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("threshold_scale"), std::string::npos);
  }
  p = {};
  p.min_area = 0;
  EXPECT_THROW(rs::BoxDetector{p}, std::invalid_argument);
  rs::BoxDetector d;
  std::vector<rs::Detection> out;
  EXPECT_THROW(d.detect(cv::Mat(), out), std::invalid_argument);
  EXPECT_THROW(d.detect(cv::Mat::zeros(10, 10, CV_32FC3), out), std::invalid_argument);
}
