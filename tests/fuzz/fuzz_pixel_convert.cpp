// libFuzzer target: the V4L2 / libcamera pixel-format converters (YUYV, UYVY, GREY, RGB3, BGR3,
// MJPEG) with hostile sizes, strides and payload lengths; the output is pre-sized as the backends
// do, and a conversion either succeeds or says why.
#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "regolith/hal_v4l2/convert.hpp"

namespace v4l2 = regolith::hal::v4l2;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 6) return 0;
  const auto format = static_cast<v4l2::DeviceFormat>(data[0] % 6);
  const int width = 1 + data[1] % 64 + (data[2] & 1) * 200;  // 1..264 px
  const int height = 1 + data[3] % 48;
  const std::size_t stride = data[4] % 4 == 0 ? 0 : static_cast<std::size_t>(width) * (1 + data[4] % 4) + data[4] % 7;
  const auto out = (data[5] & 1) ? regolith::hal::PixelFormat::kBgr8 : regolith::hal::PixelFormat::kMono8;
  cv::Mat dst(height, width, out == regolith::hal::PixelFormat::kBgr8 ? CV_8UC3 : CV_8UC1);
  std::string error;
  const std::uint8_t* payload = data + 6;
  const std::size_t bytes = size - 6;
  if (!v4l2::convert_frame(format, payload, bytes, width, height, stride, out, dst, error) && error.empty())
    __builtin_trap();  // a refusal must say why
  return 0;
}
