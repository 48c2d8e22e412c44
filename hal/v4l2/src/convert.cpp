#include "regolith/hal_v4l2/convert.hpp"

#include <cstdint>
#include <stdexcept>

#include <linux/videodev2.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/core/image_file.hpp"

namespace regolith::hal::v4l2 {

std::string_view to_string(DeviceFormat f) {
  switch (f) {
    case DeviceFormat::kYuyv: return "YUYV";
    case DeviceFormat::kUyvy: return "UYVY";
    case DeviceFormat::kGrey: return "GREY";
    case DeviceFormat::kRgb24: return "RGB3";
    case DeviceFormat::kBgr24: return "BGR3";
    case DeviceFormat::kMjpeg: return "MJPG";
  }
  return "?";
}

std::uint32_t fourcc_of(DeviceFormat f) {
  switch (f) {
    case DeviceFormat::kYuyv: return V4L2_PIX_FMT_YUYV;
    case DeviceFormat::kUyvy: return V4L2_PIX_FMT_UYVY;
    case DeviceFormat::kGrey: return V4L2_PIX_FMT_GREY;
    case DeviceFormat::kRgb24: return V4L2_PIX_FMT_RGB24;
    case DeviceFormat::kBgr24: return V4L2_PIX_FMT_BGR24;
    case DeviceFormat::kMjpeg: return V4L2_PIX_FMT_MJPEG;
  }
  return 0;
}

bool device_format_from_fourcc(std::uint32_t fourcc, DeviceFormat& out) {
  switch (fourcc) {
    case V4L2_PIX_FMT_YUYV: out = DeviceFormat::kYuyv; return true;
    case V4L2_PIX_FMT_UYVY: out = DeviceFormat::kUyvy; return true;
    case V4L2_PIX_FMT_GREY: out = DeviceFormat::kGrey; return true;
    case V4L2_PIX_FMT_RGB24: out = DeviceFormat::kRgb24; return true;
    case V4L2_PIX_FMT_BGR24: out = DeviceFormat::kBgr24; return true;
    case V4L2_PIX_FMT_MJPEG:
    case V4L2_PIX_FMT_JPEG: out = DeviceFormat::kMjpeg; return true;
    default: return false;
  }
}

std::uint32_t fourcc_from_string(std::string_view s) {
  if (s.size() != 4) throw std::invalid_argument("fourcc '" + std::string(s) + "' must have exactly 4 characters");
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) {
    const auto c = static_cast<unsigned char>(s[static_cast<std::size_t>(i)]);
    if (c < 0x20 || c > 0x7e)
      throw std::invalid_argument("fourcc '" + std::string(s) + "' has a non-printable character");
    v = (v << 8) | c;
  }
  return v;
}

std::string fourcc_to_string(std::uint32_t fourcc) {
  std::string s(4, '?');
  for (std::size_t i = 0; i < 4; ++i) {
    const auto c = static_cast<char>((fourcc >> (8 * i)) & 0xFF);
    if (c >= 0x20 && c <= 0x7e) s[i] = c;
  }
  return s;
}

namespace {
std::size_t bytes_per_pixel(DeviceFormat f) {
  switch (f) {
    case DeviceFormat::kYuyv:
    case DeviceFormat::kUyvy: return 2;
    case DeviceFormat::kGrey: return 1;
    case DeviceFormat::kRgb24:
    case DeviceFormat::kBgr24: return 3;
    case DeviceFormat::kMjpeg: return 0;
  }
  return 0;
}
}  // namespace

std::size_t min_frame_bytes(DeviceFormat f, int width, int height, std::size_t stride) {
  const std::size_t bpp = bytes_per_pixel(f);
  if (bpp == 0 || width <= 0 || height <= 0) return 0;
  const std::size_t row = static_cast<std::size_t>(width) * bpp;
  const std::size_t s = stride == 0 ? row : stride;
  return s * static_cast<std::size_t>(height - 1) + row;
}

std::vector<DeviceFormat> preferred_formats(PixelFormat out) {
  if (out == PixelFormat::kMono8) {
    return {DeviceFormat::kGrey,  DeviceFormat::kYuyv,  DeviceFormat::kUyvy,
            DeviceFormat::kBgr24, DeviceFormat::kRgb24, DeviceFormat::kMjpeg};
  }
  return {DeviceFormat::kBgr24, DeviceFormat::kRgb24, DeviceFormat::kYuyv,
          DeviceFormat::kUyvy,  DeviceFormat::kMjpeg, DeviceFormat::kGrey};
}

bool convert_frame(DeviceFormat f, const std::uint8_t* data, std::size_t bytes, int width, int height,
                   std::size_t stride, PixelFormat out, cv::Mat& dst, std::string& error) {
  if (data == nullptr || width <= 0 || height <= 0) {
    error = "empty frame";
    return false;
  }
  if (dst.rows != height || dst.cols != width || dst.type() != cv_type(out)) {
    error = "destination is " + std::to_string(dst.cols) + "x" + std::to_string(dst.rows) + ", frame is " +
            std::to_string(width) + "x" + std::to_string(height);
    return false;
  }
  if (f == DeviceFormat::kMjpeg) {
    if (bytes < 4 || data[0] != 0xFF || data[1] != 0xD8 || data[2] != 0xFF) {
      error = "MJPEG payload of " + std::to_string(bytes) + " bytes does not start with a JPEG SOI marker";
      return false;
    }
    // only OpenCV's JPEG decoder may see it (FF D8 FF): other decoders, tried on bytes no decoder
    // claims, include GDCM, which aborts on some (found by tests/fuzz: corpus/pixel_convert/gdcm_abort)
    // A frame header of another size is refused before anything is decoded (a corrupt frame may
    // declare up to regolith's image bound, 2^26 pixels, all of which the decoder would allocate).
    const regolith::ImageExtent declared = regolith::declared_image_extent(data, bytes);
    if (declared.known() && (declared.width != static_cast<std::uint64_t>(width) ||
                             declared.height != static_cast<std::uint64_t>(height))) {
      error = "MJPEG frame declares " + std::to_string(declared.width) + "x" + std::to_string(declared.height) +
              ", expected " + std::to_string(width) + "x" + std::to_string(height);
      return false;
    }
    std::string why;
    const cv::Mat decoded =
        regolith::decode_image(data, bytes, out == PixelFormat::kMono8 ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR, &why);
    if (decoded.empty()) {
      error = "MJPEG payload of " + std::to_string(bytes) + " bytes could not be decoded: " + why;
      return false;
    }
    if (decoded.rows != height || decoded.cols != width) {
      error = "MJPEG frame decodes to " + std::to_string(decoded.cols) + "x" + std::to_string(decoded.rows) +
              ", expected " + std::to_string(width) + "x" + std::to_string(height);
      return false;
    }
    decoded.copyTo(dst);
    return true;
  }
  // A stride shorter than one row (a driver's bytesperline, a configuration) would make rows
  // overlap: refused (found by tests/fuzz, corpus/pixel_convert/short_stride).
  const std::size_t row_bytes = static_cast<std::size_t>(width) * bytes_per_pixel(f);
  if (stride != 0 && stride < row_bytes) {
    error = std::string(to_string(f)) + " stride of " + std::to_string(stride) + " bytes is shorter than a row of " +
            std::to_string(width) + " px (" + std::to_string(row_bytes) + " bytes)";
    return false;
  }
  const std::size_t need = min_frame_bytes(f, width, height, stride);
  if (bytes < need) {
    error = std::string(to_string(f)) + " frame has " + std::to_string(bytes) + " bytes, " + std::to_string(need) +
            " needed for " + std::to_string(width) + "x" + std::to_string(height);
    return false;
  }
  const std::size_t step = stride == 0 ? static_cast<std::size_t>(width) * bytes_per_pixel(f) : stride;
  auto* p = const_cast<std::uint8_t*>(data);
  switch (f) {
    case DeviceFormat::kYuyv:
    case DeviceFormat::kUyvy: {
      const cv::Mat src(height, width, CV_8UC2, p, step);
      const bool yuyv = f == DeviceFormat::kYuyv;
      if (out == PixelFormat::kMono8) {
        cv::cvtColor(src, dst, yuyv ? cv::COLOR_YUV2GRAY_YUYV : cv::COLOR_YUV2GRAY_UYVY);
      } else {
        cv::cvtColor(src, dst, yuyv ? cv::COLOR_YUV2BGR_YUYV : cv::COLOR_YUV2BGR_UYVY);
      }
      return true;
    }
    case DeviceFormat::kGrey: {
      const cv::Mat src(height, width, CV_8UC1, p, step);
      if (out == PixelFormat::kMono8) {
        src.copyTo(dst);
      } else {
        cv::cvtColor(src, dst, cv::COLOR_GRAY2BGR);
      }
      return true;
    }
    case DeviceFormat::kRgb24:
    case DeviceFormat::kBgr24: {
      const cv::Mat src(height, width, CV_8UC3, p, step);
      const bool rgb = f == DeviceFormat::kRgb24;
      if (out == PixelFormat::kMono8) {
        cv::cvtColor(src, dst, rgb ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
      } else if (rgb) {
        cv::cvtColor(src, dst, cv::COLOR_RGB2BGR);
      } else {
        src.copyTo(dst);
      }
      return true;
    }
    case DeviceFormat::kMjpeg: break;
  }
  error = "unsupported format";
  return false;
}

}  // namespace regolith::hal::v4l2
