#pragma once
// Reading image files from outside (camera dumps, datasets, users): only formats regolith reads,
// recognised by their signature before any decoder sees the bytes. cv::imread / cv::imdecode
// otherwise offer unknown bytes to every decoder OpenCV was built with; on Debian 12 that includes
// GDAL and GDCM, and GDCM aborts the process on some inputs (found by tests/fuzz: a 46-byte frame
// starting FF D8 but not FF D8 FF). Header-only; callers link opencv_imgcodecs as they did.
#include <cstddef>
#include <cstring>
#include <fstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace regolith {

/// True when the first bytes are those of PNG, JPEG (FF D8 FF), TIFF, BMP, PNM (P1-P6) or WebP.
inline bool known_image_signature(const unsigned char* p, std::size_t n) {
  auto starts = [&](const char* sig, std::size_t len) { return n >= len && std::memcmp(p, sig, len) == 0; };
  if (starts("\x89PNG\r\n\x1a\n", 8)) return true;
  if (starts("\xFF\xD8\xFF", 3)) return true;
  if (starts("II*\0", 4) || starts("MM\0*", 4)) return true;
  if (starts("BM", 2)) return true;
  if (n >= 3 && p[0] == 'P' && p[1] >= '1' && p[1] <= '6' && (p[2] == ' ' || p[2] == '\n' || p[2] == '\r' || p[2] == '\t'))
    return true;
  if (n >= 12 && std::memcmp(p, "RIFF", 4) == 0 && std::memcmp(p + 8, "WEBP", 4) == 0) return true;
  return false;
}

/// cv::imread for files of a known image format; an empty Mat (as cv::imread's own failure) for
/// anything else, a missing file or a decoder exception.
inline cv::Mat read_image_file(const std::string& path, int flags) {
  unsigned char head[16] = {};
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  in.read(reinterpret_cast<char*>(head), sizeof head);
  if (!known_image_signature(head, static_cast<std::size_t>(in.gcount()))) return {};
  try {
    return cv::imread(path, flags);
  } catch (const cv::Exception&) {
    return {};
  }
}

/// cv::imdecode with the same guard.
inline cv::Mat decode_image(const unsigned char* data, std::size_t size, int flags) {
  if (!known_image_signature(data, size) || size > static_cast<std::size_t>(INT32_MAX)) return {};
  try {
    return cv::imdecode(cv::Mat(1, static_cast<int>(size), CV_8UC1, const_cast<unsigned char*>(data)), flags);
  } catch (const cv::Exception&) {
    return {};
  }
}

}  // namespace regolith
