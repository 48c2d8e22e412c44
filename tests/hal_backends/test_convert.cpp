// Pixel-format conversions of the V4L2 / libcamera backends, against hand-computed ground truth.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/hal_v4l2/convert.hpp"

using namespace regolith::hal;
using namespace regolith::hal::v4l2;

namespace {

// BT.601 limited-range YCbCr -> RGB, the definition OpenCV's COLOR_YUV2BGR_YUYV implements.
void yuv_to_rgb(int y, int u, int v, double& r, double& g, double& b) {
  const double c = 1.164 * (y - 16), d = u - 128, e = v - 128;
  r = std::clamp(c + 1.596 * e, 0.0, 255.0);
  g = std::clamp(c - 0.391 * d - 0.813 * e, 0.0, 255.0);
  b = std::clamp(c + 2.018 * d, 0.0, 255.0);
}

}  // namespace

TEST(Convert, FourccTextRoundTrip) {
  EXPECT_EQ(fourcc_to_string(fourcc_from_string("YUYV")), "YUYV");
  EXPECT_EQ(fourcc_from_string("YUYV"), fourcc_of(DeviceFormat::kYuyv));
  EXPECT_EQ(fourcc_from_string("MJPG"), fourcc_of(DeviceFormat::kMjpeg));
  DeviceFormat f{};
  ASSERT_TRUE(device_format_from_fourcc(fourcc_from_string("RGB3"), f));
  EXPECT_EQ(f, DeviceFormat::kRgb24);
  EXPECT_FALSE(device_format_from_fourcc(fourcc_from_string("NV12"), f));
  try {
    fourcc_from_string("YUY");
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("exactly 4 characters"), std::string::npos) << e.what();
  }
}

TEST(Convert, MinFrameBytesHonoursStride) {
  EXPECT_EQ(min_frame_bytes(DeviceFormat::kYuyv, 640, 480), 640u * 480u * 2u);
  EXPECT_EQ(min_frame_bytes(DeviceFormat::kRgb24, 4, 2, 16), 16u + 12u);  // last row unpadded
  EXPECT_EQ(min_frame_bytes(DeviceFormat::kMjpeg, 640, 480), 0u);
}

TEST(Convert, YuyvToBgrAndMonoMatchBt601) {
  const int w = 4, h = 2;
  // two macro-pixels per row with distinct chroma: (Y0 U Y1 V)
  const std::vector<std::uint8_t> yuyv = {81,  90,  145, 240, 41,  240, 210, 110,  // row 0
                                          235, 128, 16,  128, 128, 54,  128, 34};  // row 1
  cv::Mat bgr(h, w, CV_8UC3), mono(h, w, CV_8UC1);
  std::string err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kYuyv, yuyv.data(), yuyv.size(), w, h, 0, PixelFormat::kBgr8, bgr, err))
      << err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kYuyv, yuyv.data(), yuyv.size(), w, h, 0, PixelFormat::kMono8, mono, err))
      << err;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t base = static_cast<std::size_t>(y * w * 2 + (x / 2) * 4);
      const int Y = yuyv[base + (x % 2 ? 2 : 0)], U = yuyv[base + 1], V = yuyv[base + 3];
      double r, g, b;
      yuv_to_rgb(Y, U, V, r, g, b);
      const auto px = bgr.at<cv::Vec3b>(y, x);
      EXPECT_NEAR(px[0], b, 2.0) << x << "," << y;
      EXPECT_NEAR(px[1], g, 2.0) << x << "," << y;
      EXPECT_NEAR(px[2], r, 2.0) << x << "," << y;
      EXPECT_EQ(mono.at<std::uint8_t>(y, x), Y) << "mono8 from YUYV is the luma plane";
    }
  }
}

TEST(Convert, UyvyIsYuyvWithSwappedBytes) {
  const std::vector<std::uint8_t> yuyv = {81, 90, 145, 240, 41, 240, 210, 110};
  std::vector<std::uint8_t> uyvy(yuyv.size());
  for (std::size_t i = 0; i < yuyv.size(); i += 2) {
    uyvy[i] = yuyv[i + 1];
    uyvy[i + 1] = yuyv[i];
  }
  cv::Mat a(1, 4, CV_8UC3), b(1, 4, CV_8UC3);
  std::string err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kYuyv, yuyv.data(), yuyv.size(), 4, 1, 0, PixelFormat::kBgr8, a, err));
  ASSERT_TRUE(convert_frame(DeviceFormat::kUyvy, uyvy.data(), uyvy.size(), 4, 1, 0, PixelFormat::kBgr8, b, err));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

TEST(Convert, Rgb24SwapsToBgrAndStrideIsSkipped) {
  const int w = 2, h = 2;
  const std::size_t stride = 8;  // 6 bytes of pixels + 2 padding bytes per row
  const std::vector<std::uint8_t> rgb = {10, 20, 30, 40,  50,  60,  0xEE, 0xEE,  //
                                         70, 80, 90, 100, 110, 120, 0xEE, 0xEE};
  cv::Mat bgr(h, w, CV_8UC3), mono(h, w, CV_8UC1);
  std::string err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kRgb24, rgb.data(), rgb.size(), w, h, stride, PixelFormat::kBgr8, bgr, err))
      << err;
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  EXPECT_EQ(bgr.at<cv::Vec3b>(1, 1), cv::Vec3b(120, 110, 100));
  ASSERT_TRUE(
      convert_frame(DeviceFormat::kRgb24, rgb.data(), rgb.size(), w, h, stride, PixelFormat::kMono8, mono, err));
  // ITU-R 601 luma weights 0.299 R + 0.587 G + 0.114 B
  EXPECT_NEAR(mono.at<std::uint8_t>(0, 0), 0.299 * 10 + 0.587 * 20 + 0.114 * 30, 1.0);
  EXPECT_NEAR(mono.at<std::uint8_t>(1, 1), 0.299 * 100 + 0.587 * 110 + 0.114 * 120, 1.0);
  // BGR24 is already in output order
  ASSERT_TRUE(convert_frame(DeviceFormat::kBgr24, rgb.data(), rgb.size(), w, h, stride, PixelFormat::kBgr8, bgr, err));
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 1), cv::Vec3b(40, 50, 60));
}

TEST(Convert, GreyToBothOutputs) {
  const std::vector<std::uint8_t> grey = {0, 64, 128, 255};
  cv::Mat mono(2, 2, CV_8UC1), bgr(2, 2, CV_8UC3);
  std::string err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kGrey, grey.data(), 4, 2, 2, 0, PixelFormat::kMono8, mono, err));
  ASSERT_TRUE(convert_frame(DeviceFormat::kGrey, grey.data(), 4, 2, 2, 0, PixelFormat::kBgr8, bgr, err));
  EXPECT_EQ(mono.at<std::uint8_t>(1, 0), 128);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 1), cv::Vec3b(64, 64, 64));
}

TEST(Convert, NeverReallocatesTheDestination) {
  std::vector<std::uint8_t> yuyv(64 * 48 * 2, 128);
  cv::Mat bgr(48, 64, CV_8UC3);
  const auto* before = bgr.data;
  std::string err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kYuyv, yuyv.data(), yuyv.size(), 64, 48, 0, PixelFormat::kBgr8, bgr, err));
  EXPECT_EQ(bgr.data, before);
}

TEST(Convert, MjpegDecodesWithinJpegError) {
  cv::Mat truth(48, 64, CV_8UC3);
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x)
      truth.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<std::uint8_t>(4 * x), static_cast<std::uint8_t>(5 * y), 100);
  std::vector<std::uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", truth, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95}));
  cv::Mat bgr(48, 64, CV_8UC3), mono(48, 64, CV_8UC1);
  std::string err;
  ASSERT_TRUE(convert_frame(DeviceFormat::kMjpeg, jpeg.data(), jpeg.size(), 64, 48, 0, PixelFormat::kBgr8, bgr, err))
      << err;
  EXPECT_LT(cv::norm(bgr, truth, cv::NORM_L1) / static_cast<double>(truth.total() * 3), 3.0);
  ASSERT_TRUE(convert_frame(DeviceFormat::kMjpeg, jpeg.data(), jpeg.size(), 64, 48, 0, PixelFormat::kMono8, mono, err))
      << err;
  cv::Mat truth_grey;
  cv::cvtColor(truth, truth_grey, cv::COLOR_BGR2GRAY);
  EXPECT_LT(cv::norm(mono, truth_grey, cv::NORM_L1) / static_cast<double>(truth.total()), 3.0);
  // wrong geometry is reported, not silently resized
  cv::Mat other(24, 32, CV_8UC3);
  EXPECT_FALSE(
      convert_frame(DeviceFormat::kMjpeg, jpeg.data(), jpeg.size(), 32, 24, 0, PixelFormat::kBgr8, other, err));
  EXPECT_NE(err.find("MJPEG frame declares 64x48, expected 32x24"), std::string::npos) << err;
}

TEST(Convert, DamagedPayloadsAreReportedWithByteCounts) {
  cv::Mat bgr(480, 640, CV_8UC3);
  std::vector<std::uint8_t> short_frame(1000);
  std::string err;
  EXPECT_FALSE(convert_frame(DeviceFormat::kYuyv, short_frame.data(), short_frame.size(), 640, 480, 0,
                             PixelFormat::kBgr8, bgr, err));
  EXPECT_NE(err.find("YUYV frame has 1000 bytes, 614400 needed for 640x480"), std::string::npos) << err;
  std::vector<std::uint8_t> not_jpeg(100, 0x55);
  EXPECT_FALSE(
      convert_frame(DeviceFormat::kMjpeg, not_jpeg.data(), not_jpeg.size(), 640, 480, 0, PixelFormat::kBgr8, bgr, err));
  EXPECT_NE(err.find("SOI marker"), std::string::npos) << err;
  std::vector<std::uint8_t> truncated = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x10};
  EXPECT_FALSE(convert_frame(DeviceFormat::kMjpeg, truncated.data(), truncated.size(), 640, 480, 0, PixelFormat::kBgr8,
                             bgr, err));
  EXPECT_NE(err.find("could not be decoded"), std::string::npos) << err;
  cv::Mat wrong(10, 10, CV_8UC1);
  std::vector<std::uint8_t> ok(640 * 480 * 2);
  EXPECT_FALSE(convert_frame(DeviceFormat::kYuyv, ok.data(), ok.size(), 640, 480, 0, PixelFormat::kBgr8, wrong, err));
  EXPECT_NE(err.find("destination is 10x10"), std::string::npos) << err;
  // A stride shorter than a row (found by tests/fuzz: OpenCV threw from inside the converter).
  cv::Mat small(2, 4, CV_8UC1);
  std::vector<std::uint8_t> rgb(64, 7);
  EXPECT_FALSE(convert_frame(DeviceFormat::kBgr24, rgb.data(), rgb.size(), 4, 2, 5, PixelFormat::kMono8, small, err));
  EXPECT_NE(err.find("stride of 5 bytes is shorter than a row of 4 px (12 bytes)"), std::string::npos) << err;
}

TEST(Convert, PreferenceOrderPicksCheapestPath) {
  EXPECT_EQ(preferred_formats(PixelFormat::kMono8).front(), DeviceFormat::kGrey);
  EXPECT_EQ(preferred_formats(PixelFormat::kBgr8).front(), DeviceFormat::kBgr24);
  EXPECT_EQ(preferred_formats(PixelFormat::kBgr8).back(), DeviceFormat::kGrey);
}
