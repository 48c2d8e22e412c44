#pragma once
// Reading image files from outside (camera dumps, datasets, users): only formats regolith reads,
// recognised by their signature before any decoder sees the bytes. cv::imread / cv::imdecode
// otherwise offer unknown bytes to every decoder OpenCV was built with; on Debian 12 that includes
// GDAL and GDCM, and GDCM aborts the process on some inputs (found by tests/fuzz: a 46-byte frame
// starting FF D8 but not FF D8 FF). Header-only; callers link opencv_imgcodecs as they did.
#include <algorithm>
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

/// Why an image whose first bytes are `head` and last bytes `tail` is cut short, or "" when it
/// is not: libjpeg and libpng decode a file that ends early with only a warning on stderr and
/// grey (JPEG) or missing rows, so a truncated file must be caught before. JPEG: no End Of Image
/// marker (FF D9) among the last bytes; PNG: no IEND chunk there.
inline std::string truncated_image(const unsigned char* head, std::size_t n_head, const unsigned char* tail,
                                   std::size_t n_tail) {
  const std::string t(reinterpret_cast<const char*>(tail), n_tail);
  if (n_head >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF && t.find("\xFF\xD9") == std::string::npos)
    return "truncated JPEG (the data ends before its end-of-image marker)";
  if (n_head >= 8 && std::memcmp(head, "\x89PNG\r\n\x1a\n", 8) == 0 && t.find("IEND") == std::string::npos)
    return "truncated PNG (the data ends before its IEND chunk)";
  return {};
}

/// A decoder exception in words (OpenCV's own text is the assertion it failed).
inline std::string decoder_failure(const cv::Exception& e) {
  if (e.err.find("CV_IO_MAX_IMAGE_PIXELS") != std::string::npos)
    return "it declares more pixels than the decoder allows (OpenCV's CV_IO_MAX_IMAGE_PIXELS, 2^30 by default)";
  return "the decoder failed: " + e.err;
}

/// Bytes of the end of an image searched for its end marker (JPEG allows padding after it).
inline constexpr std::size_t kImageTailBytes = 64;

/// cv::imread for whole files of a known image format; an empty Mat (as cv::imread's own failure)
/// for anything else: a missing file, an unknown format, a truncated JPEG or PNG, a decoder
/// exception or refusal (e.g. more pixels than OpenCV's limit). `why`, when given, says which.
inline cv::Mat read_image_file(const std::string& path, int flags, std::string* why = nullptr) {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return cv::Mat();
  };
  unsigned char head[16] = {};
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot open it");
  in.read(reinterpret_cast<char*>(head), sizeof head);
  const auto n_head = static_cast<std::size_t>(in.gcount());
  if (!known_image_signature(head, n_head)) return fail("not an image regolith reads (PNG, JPEG, TIFF, BMP, PNM, WebP)");
  in.clear();
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff n_tail = std::min<std::streamoff>(size, static_cast<std::streamoff>(kImageTailBytes));
  unsigned char tail[kImageTailBytes] = {};
  in.seekg(size - n_tail);
  in.read(reinterpret_cast<char*>(tail), n_tail);
  if (const std::string t = truncated_image(head, n_head, tail, static_cast<std::size_t>(in.gcount())); !t.empty())
    return fail(t);
  try {
    cv::Mat img = cv::imread(path, flags);
    if (img.empty()) return fail("the decoder refused it (corrupt, or more pixels than it allows)");
    return img;
  } catch (const cv::Exception& e) {
    return fail(decoder_failure(e));
  }
}

/// cv::imdecode with the same guards (a camera's MJPEG frame cut short is refused too).
inline cv::Mat decode_image(const unsigned char* data, std::size_t size, int flags, std::string* why = nullptr) {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return cv::Mat();
  };
  if (!known_image_signature(data, size)) return fail("not an image regolith reads (PNG, JPEG, TIFF, BMP, PNM, WebP)");
  if (size > static_cast<std::size_t>(INT32_MAX)) return fail("larger than 2 GiB");
  const std::size_t n_tail = std::min(size, kImageTailBytes);
  if (const std::string t = truncated_image(data, std::min<std::size_t>(size, 16), data + size - n_tail, n_tail); !t.empty())
    return fail(t);
  try {
    cv::Mat img = cv::imdecode(cv::Mat(1, static_cast<int>(size), CV_8UC1, const_cast<unsigned char*>(data)), flags);
    if (img.empty()) return fail("the decoder refused it (corrupt, or more pixels than it allows)");
    return img;
  } catch (const cv::Exception& e) {
    return fail(decoder_failure(e));
  }
}

}  // namespace regolith
