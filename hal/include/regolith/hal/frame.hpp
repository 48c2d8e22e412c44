#pragma once
// Camera frames: pixels in a pre-allocated pool, passed to components by lease (no copy).
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include <opencv2/core/mat.hpp>

#include "regolith/core/channels.hpp"
#include "regolith/core/time.hpp"

namespace regolith::hal {

/// Output pixel formats of every Camera backend (device formats are converted to one of these).
enum class PixelFormat : std::uint8_t { kMono8, kBgr8 };

std::string_view to_string(PixelFormat f);                 ///< "mono8" / "bgr8" (ROS image_encodings)
PixelFormat pixel_format_from_string(std::string_view s);  ///< throws std::invalid_argument
inline int cv_type(PixelFormat f) {
  return f == PixelFormat::kMono8 ? CV_8UC1 : CV_8UC3;
}

struct Frame {
  cv::Mat image;                   ///< rows x cols, CV_8UC1 (mono8) or CV_8UC3 (bgr8); pool-owned
  TimeNs capture_time = 0;         ///< capture time on the process clock (ns)
  std::uint64_t sequence = 0;      ///< device sequence number (gaps = dropped frames)
  std::uint16_t camera_index = 0;  ///< index of the camera in the deployment
  bool corrupt = false;            ///< backend flagged the payload as damaged
};

using FramePool = LatestPool<Frame>;
using FrameLease = FramePool::Lease;

/// A pool of `max_readers + 2` frames of the given geometry, all allocated now.
std::unique_ptr<FramePool> make_frame_pool(int width, int height, PixelFormat fmt, std::size_t max_readers = 4);

}  // namespace regolith::hal
