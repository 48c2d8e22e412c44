#pragma once
// Device pixel formats -> regolith output formats (mono8 / bgr8). Shared by the V4L2 and libcamera
// backends; pure functions over memory, testable without a device.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "regolith/hal/frame.hpp"

namespace regolith::hal::v4l2 {

/// Device-side pixel layouts the backends can convert.
enum class DeviceFormat : std::uint8_t {
  kYuyv,   ///< YUV 4:2:2 packed Y0 U Y1 V (V4L2 'YUYV', libcamera YUYV)
  kUyvy,   ///< YUV 4:2:2 packed U Y0 V Y1 ('UYVY')
  kGrey,   ///< 8-bit luma ('GREY', libcamera R8)
  kRgb24,  ///< R G B bytes ('RGB3', libcamera BGR888 — libcamera names formats by word order)
  kBgr24,  ///< B G R bytes ('BGR3', libcamera RGB888)
  kMjpeg,  ///< JPEG per frame ('MJPG' / 'JPEG')
};

std::string_view to_string(DeviceFormat f);
/// V4L2 fourcc code of a format (V4L2_PIX_FMT_*).
std::uint32_t fourcc_of(DeviceFormat f);
/// Format from a fourcc code; false when the code is not convertible.
bool device_format_from_fourcc(std::uint32_t fourcc, DeviceFormat& out);
/// "YUYV" -> fourcc code. Throws std::invalid_argument unless exactly 4 printable characters.
std::uint32_t fourcc_from_string(std::string_view s);
/// fourcc code -> "YUYV" (non-printable bytes as '?').
std::string fourcc_to_string(std::uint32_t fourcc);

/// Minimum payload bytes of one frame (0 for compressed formats). `stride` 0 = packed.
std::size_t min_frame_bytes(DeviceFormat f, int width, int height, std::size_t stride = 0);

/// Preference order of device formats for an output format (cheapest conversion first).
std::vector<DeviceFormat> preferred_formats(PixelFormat out);

/// Convert one frame into `dst` (which must already be height x width of cv_type(out); it is never
/// reallocated for uncompressed formats). Returns false with `error` set (naming the problem and the
/// byte counts) when the payload is too short or cannot be decoded.
bool convert_frame(DeviceFormat f, const std::uint8_t* data, std::size_t bytes, int width, int height,
                   std::size_t stride, PixelFormat out, cv::Mat& dst, std::string& error);

}  // namespace regolith::hal::v4l2
