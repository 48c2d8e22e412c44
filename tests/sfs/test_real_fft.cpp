// RealFft2d (FFTW plans made once) against cv::dft, and its copy / move semantics.
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "regolith/sfs/real_fft.hpp"

namespace rs = regolith::sfs;

namespace {

double max_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  return cv::norm(a, b, cv::NORM_INF);
}

}  // namespace

TEST(RealFft, ForwardIsTheHalfOfCvDftsSpectrumAndInverseRoundTrips) {
  for (const cv::Size sz : {cv::Size(8, 6), cv::Size(7, 5), cv::Size(640, 480), cv::Size(243, 125)}) {
    cv::Mat x(sz, CV_32F);
    cv::randu(x, -1.0, 1.0);
    rs::RealFft2d fft(sz.height, sz.width);
    ASSERT_EQ(fft.rows(), sz.height);
    ASSERT_EQ(fft.cols(), sz.width);
    x.copyTo(fft.real());
    fft.forward();
    cv::Mat full;
    cv::dft(x, full, cv::DFT_COMPLEX_OUTPUT);
    const cv::Mat half = fft.spectrum();
    ASSERT_EQ(half.cols, sz.width / 2 + 1);
    ASSERT_EQ(half.type(), CV_32FC2);
    const double scale = std::sqrt(static_cast<double>(sz.area()));  // spectrum magnitude grows with sqrt(N)
    EXPECT_LT(max_abs_diff(half, full(cv::Rect(0, 0, half.cols, half.rows))), 1e-4 * scale) << sz;
    fft.inverse();
    cv::Mat back = fft.real() / static_cast<double>(sz.area());
    EXPECT_LT(max_abs_diff(back, x), 1e-5) << sz;
  }
}

TEST(RealFft, ResizeReplansCopiesMakeTheirOwnPlansAndBadSizesAreRefused) {
  rs::RealFft2d a(4, 6);
  rs::RealFft2d b = a;  // own buffers
  EXPECT_NE(a.real().data, b.real().data);
  EXPECT_EQ(b.rows(), 4);
  EXPECT_EQ(b.cols(), 6);
  const uchar* before = a.real().data;
  a.resize(4, 6);  // same size: nothing re-made
  EXPECT_EQ(a.real().data, before);
  a.resize(5, 9);
  EXPECT_EQ(a.spectrum().cols, 5);
  rs::RealFft2d c = std::move(a);
  EXPECT_EQ(c.rows(), 5);
  EXPECT_EQ(a.rows(), 0);  // NOLINT(bugprone-use-after-move): moved-from is empty by contract
  a.forward();             // an empty transform does nothing
  cv::Mat ones(5, 9, CV_32F, cv::Scalar(1.0f));
  ones.copyTo(c.real());
  c.forward();
  EXPECT_NEAR(c.spectrum().at<cv::Vec2f>(0, 0)[0], 45.0f, 1e-4);  // DC = sum
  EXPECT_THROW(c.resize(0, 3), std::invalid_argument);
  EXPECT_THROW(c.resize(3, -1), std::invalid_argument);
}
