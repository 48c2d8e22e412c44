// The intensity-contrast method |I - G_sigma * I| on constructed scenes, its input handling and
// parameter errors, and the sol grouping of the cross-validation folds.
#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "regolith/saliency/contrast.hpp"
#include "regolith/saliency/dataset.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/evaluate.hpp"

namespace rs = regolith::saliency;

namespace {

// Mid-grey textured ground (smoothed noise, sd ~0.02 after smoothing) with a bright disc and
// a dark disc larger than the default minimum area (1600 px): the bright one's box is
// (70..130, 90..150), the dark one's (254..306, 164..216).
cv::Mat two_blob_scene() {
  cv::Mat img(300, 400, CV_32F);
  cv::RNG rng(7);
  rng.fill(img, cv::RNG::NORMAL, 0.5, 0.06);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
  cv::circle(img, {100, 120}, 30, cv::Scalar(0.75), cv::FILLED);
  cv::circle(img, {280, 190}, 26, cv::Scalar(0.25), cv::FILLED);
  return img;
}

}  // namespace

TEST(Contrast, FindsABrightAndADarkBlobOnTexturedGroundWithTheRightBoxes) {
  const cv::Mat img = two_blob_scene();
  rs::ContrastSaliency contrast;  // defaults
  cv::Mat sal;
  contrast.compute(img, sal);
  ASSERT_EQ(sal.type(), CV_32FC1);
  ASSERT_EQ(sal.size(), img.size());
  double mn = 0.0, mx = 0.0;
  cv::minMaxLoc(sal, &mn, &mx);
  EXPECT_GE(mn, 0.0);
  EXPECT_NEAR(mx, 1.0, 1e-6);
  rs::BoxDetector det(rs::contrast_post_processing());
  std::vector<rs::Detection> out;
  det.detect(sal, out);
  ASSERT_EQ(out.size(), 2u);
  const cv::Rect bright(70, 90, 61, 61), dark(254, 164, 53, 53);
  const cv::Rect& b = rs::iou(out[0].box, bright) > rs::iou(out[1].box, bright) ? out[0].box : out[1].box;
  const cv::Rect& d = &b == &out[0].box ? out[1].box : out[0].box;
  // Each box holds its disc and is at most 5 px wider on each side (the smoothing of the
  // contrast map, sigma 8 px by default, spreads the edges a little): measured 3-4 px.
  for (const auto& [got, want] : {std::pair{b, bright}, std::pair{d, dark}}) {
    EXPECT_EQ(got & want, want) << got;
    EXPECT_LE(want.x - got.x, 5) << got;
    EXPECT_LE(want.y - got.y, 5) << got;
    EXPECT_LE(got.br().x - want.br().x, 5) << got;
    EXPECT_LE(got.br().y - want.br().y, 5) << got;
    EXPECT_GT(rs::iou(got, want), 0.75) << got;
  }
  for (const auto& r : out) {
    EXPECT_GT(r.score, 0.0);
    EXPECT_LE(r.score, 1.0);
  }
}

TEST(Contrast, SameMapForAnyDepthAndChannelCount) {
  const cv::Mat img = two_blob_scene();
  cv::Mat u8, u16, bgr, bgra;
  img.convertTo(u8, CV_8U, 255.0);
  u8.convertTo(u16, CV_16U, 257.0);
  cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(u8, bgra, cv::COLOR_GRAY2BGRA);
  rs::ContrastSaliency contrast;
  cv::Mat ref, m;
  contrast.compute(u8, ref);
  for (const cv::Mat* in : {&u16, &bgr, &bgra}) {
    contrast.compute(*in, m);
    EXPECT_LT(cv::norm(m, ref, cv::NORM_INF), 1e-4);
  }
  // A constant image has no contrast: an all-zero map and no box.
  contrast.compute(cv::Mat(50, 60, CV_8U, cv::Scalar(90)), m);
  EXPECT_EQ(cv::countNonZero(m), 0);
  std::vector<rs::Detection> out;
  rs::BoxDetector(rs::contrast_post_processing()).detect(m, out);
  EXPECT_TRUE(out.empty());
  // Tiny images are fine.
  contrast.compute(cv::Mat(1, 1, CV_8U, cv::Scalar(3)), m);
  EXPECT_EQ(m.size(), cv::Size(1, 1));
  EXPECT_THROW(contrast.compute(cv::Mat(), m), std::invalid_argument);
  EXPECT_THROW(contrast.compute(cv::Mat(10, 10, CV_8UC2), m), std::invalid_argument);
}

TEST(Contrast, DecimatedBlurMatchesTheGaussian) {
  const cv::Mat img = two_blob_scene();
  cv::Mat fast, exact;
  rs::DecimatedGaussian blur;
  for (double sigma : {2.0, 7.9, 8.0, 16.0, 33.0, 64.0, 2.0}) {  // the sigma changes, then returns
    blur.apply(img, fast, sigma);
    cv::GaussianBlur(img, exact, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT_101);
    ASSERT_EQ(fast.size(), img.size());
    // Undecimated (sigma < 8): the Gaussian itself, everywhere, up to float rounding.
    if (sigma < 8.0) {
      EXPECT_LT(cv::norm(fast, exact, cv::NORM_INF), 1e-6) << "sigma " << sigma;
      continue;
    }
    // Away from the border (4 sigma, where the reflected and the reduced borders differ)
    // within 0.5 % of the image's range (0.25 .. 0.75 = 0.5): the contrasts that matter are
    // 10-100x larger.
    const int m = std::min(static_cast<int>(4 * sigma), 60);
    const cv::Rect inner(m, m, img.cols - 2 * m, img.rows - 2 * m);
    const double err = cv::norm(fast(inner), exact(inner), cv::NORM_INF);
    EXPECT_LT(err, 0.0025) << "sigma " << sigma;
  }
  // Another size after the first: the tables are rebuilt.
  const cv::Mat half = img(cv::Rect(0, 0, img.cols / 2, img.rows / 2)).clone();
  blur.apply(half, fast, 2.0);
  cv::GaussianBlur(half, exact, cv::Size(0, 0), 2.0, 2.0, cv::BORDER_REFLECT_101);
  EXPECT_LT(cv::norm(fast, exact, cv::NORM_INF), 1e-6);
  EXPECT_THROW(blur.apply(img, fast, 0.0), std::invalid_argument);
  EXPECT_THROW(blur.apply(cv::Mat(4, 4, CV_8U), fast, 2.0), std::invalid_argument);
}

TEST(Contrast, BadParametersNameTheField) {
  const auto message = [](rs::ContrastParams p) {
    try {
      rs::ContrastSaliency c(p);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message({0.0, 1.0}).find("ContrastParams.sigma_px"), std::string::npos);
  EXPECT_NE(message({std::nan(""), 1.0}).find("sigma_px"), std::string::npos);
  EXPECT_NE(message({8.0, -1.0}).find("ContrastParams.smooth_sigma_px"), std::string::npos);
  EXPECT_EQ(message({8.0, 0.0}), "");  // smoothing off is valid
  EXPECT_NO_THROW(rs::contrast_post_processing().validate());
}

TEST(Folds, SolFromFileNames) {
  EXPECT_EQ(rs::sol_group("1044_1044MR0045730190204467E01_DXXX.jpg"), "1044");
  EXPECT_EQ(rs::sol_group("cr_078_0078MR0576042000E1_DXXX.jpg"), "78");
  EXPECT_EQ(rs::sol_group("331_0331MR0013390000301024E01_DXXX.jpg"), "331");
  EXPECT_EQ(rs::sol_group("cr_000_x.png"), "0");
  EXPECT_EQ(rs::sol_group("s0.png"), "s0.png");  // no sol: its own group
  EXPECT_EQ(rs::sol_group("12.png"), "12.png");  // the extension token is not a sol
}

TEST(Folds, GroupsStayTogetherAndFoldsAreBalanced) {
  // 9 groups: sizes 5, 3, 3, 2, 1 x 5 = 18 items.
  std::vector<std::string> g;
  const std::vector<std::pair<std::string, int>> sizes = {{"78", 5}, {"1101", 3}, {"1537", 3}, {"1044", 2}, {"7", 1},
                                                          {"8", 1},  {"9", 1},    {"10", 1},   {"11", 1}};
  for (const auto& [key, n] : sizes) g.insert(g.end(), static_cast<size_t>(n), key);
  std::rotate(g.begin(), g.begin() + 7, g.end());  // order of items does not matter
  const std::vector<int> f = rs::grouped_folds(g, 3);
  ASSERT_EQ(f.size(), g.size());
  std::vector<int> load(3, 0);
  for (size_t i = 0; i < g.size(); ++i) {
    ASSERT_GE(f[i], 0);
    ASSERT_LT(f[i], 3);
    ++load[static_cast<size_t>(f[i])];
    for (size_t j = 0; j < g.size(); ++j) {
      if (g[i] == g[j]) {
        EXPECT_EQ(f[i], f[j]) << g[i];
      }
    }
  }
  // Largest first into the emptiest fold (ties: lowest): 78 -> 0, 1101 -> 1, 1537 -> 2,
  // 1044 -> 1, then 7 -> 2, 8 -> 2, 9 -> 0, 10 -> 1, 11 -> 2: loads 6 / 6 / 6.
  EXPECT_EQ(load, (std::vector<int>{6, 6, 6}));
  const auto fold_of = [&](const char* key) {
    return f[static_cast<size_t>(std::find(g.begin(), g.end(), key) - g.begin())];
  };
  EXPECT_EQ(fold_of("78"), 0);
  EXPECT_EQ(fold_of("1101"), 1);
  EXPECT_EQ(fold_of("1537"), 2);
  EXPECT_EQ(fold_of("1044"), 1);
  EXPECT_EQ(fold_of("9"), 0);
  EXPECT_EQ(rs::grouped_folds(g, 3), f);  // deterministic
  EXPECT_THROW(rs::grouped_folds({"a", "a", "b"}, 3), std::invalid_argument);
  EXPECT_THROW(rs::grouped_folds({"a", "b"}, 1), std::invalid_argument);
}
