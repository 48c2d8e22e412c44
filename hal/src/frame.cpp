#include "regolith/hal/frame.hpp"

#include <stdexcept>

#include "regolith/hal/camera.hpp"

namespace regolith::hal {

std::string_view to_string(PixelFormat f) {
  return f == PixelFormat::kMono8 ? "mono8" : "bgr8";
}

PixelFormat pixel_format_from_string(std::string_view s) {
  if (s == "mono8") return PixelFormat::kMono8;
  if (s == "bgr8") return PixelFormat::kBgr8;
  throw std::invalid_argument("unknown pixel format '" + std::string(s) + "' (expected mono8 or bgr8)");
}

std::unique_ptr<FramePool> make_frame_pool(int width, int height, PixelFormat fmt, std::size_t max_readers) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("frame pool: size must be positive");
  return std::make_unique<FramePool>(max_readers, [&] {
    Frame f;
    f.image.create(height, width, cv_type(fmt));
    f.image.setTo(0);
    return f;
  });
}

}  // namespace regolith::hal
