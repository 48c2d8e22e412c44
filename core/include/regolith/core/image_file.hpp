#pragma once
// Reading image files from outside (camera dumps, datasets, users): only formats regolith reads,
// recognised by their signature before any decoder sees the bytes. cv::imread / cv::imdecode
// otherwise offer unknown bytes to every decoder OpenCV was built with; on Debian 12 that includes
// GDAL and GDCM, and GDCM aborts the process on some inputs (found by tests/fuzz: a 46-byte frame
// starting FF D8 but not FF D8 FF). The size an image declares is read from its header and
// bounded before it is decoded: a 389 KB PNG declaring 20000 x 20000 pixels otherwise became
// 400 MB of pixels and gigabytes of working maps in `assess` / `rocks` (an OpenCV out-of-memory
// error, or the kernel's OOM killer on a small board). OpenCV's own limit (2^30 pixels) is read from
// the environment when its library loads, before main(), so it cannot be lowered from here.
// Header-only; callers link opencv_imgcodecs as they did.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "regolith/core/image_limits.hpp"

namespace regolith {

/// True when the first bytes are those of PNG, JPEG (FF D8 FF), TIFF, BMP, PNM (P1-P6) or WebP.
inline bool known_image_signature(const unsigned char* p, std::size_t n) {
  auto starts = [&](const char* sig, std::size_t len) { return n >= len && std::memcmp(p, sig, len) == 0; };
  if (starts("\x89PNG\r\n\x1a\n", 8)) return true;
  if (starts("\xFF\xD8\xFF", 3)) return true;
  if (starts("II*\0", 4) || starts("MM\0*", 4)) return true;
  if (starts("BM", 2)) return true;
  if (n >= 3 && p[0] == 'P' && p[1] >= '1' && p[1] <= '6' &&
      (p[2] == ' ' || p[2] == '\n' || p[2] == '\r' || p[2] == '\t'))
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

/// Largest image file read whole (`read_image_file`).
inline constexpr std::uint64_t kMaxImageFileBytes = std::uint64_t{512} << 20;

/// Width and height an image's header declares; both 0 when the header does not say (then the
/// decoder judges the image).
struct ImageExtent {
  std::uint64_t width = 0, height = 0;
  bool known() const { return width > 0 && height > 0; }
  bool exceeds(std::uint64_t max_pixels) const { return known() && width > max_pixels / height; }
};

/// The extent declared by the header of a PNG (IHDR), JPEG (the first SOF marker), BMP (core or
/// info header), PNM (P1-P6), WebP (VP8, VP8L, VP8X) or little / big-endian TIFF (the first
/// IFD's ImageWidth and ImageLength) in `p[0..n)`.
inline ImageExtent declared_image_extent(const unsigned char* p, std::size_t n) {
  const auto be16 = [&](std::size_t i) { return std::uint64_t{p[i]} << 8 | p[i + 1]; };
  const auto be32 = [&](std::size_t i) { return be16(i) << 16 | be16(i + 2); };
  const auto le16 = [&](std::size_t i) { return std::uint64_t{p[i + 1]} << 8 | p[i]; };
  const auto le32 = [&](std::size_t i) { return le16(i + 2) << 16 | le16(i); };
  const auto starts = [&](const char* sig, std::size_t len) { return n >= len && std::memcmp(p, sig, len) == 0; };
  ImageExtent e;
  if (starts("\x89PNG\r\n\x1a\n", 8)) {
    if (n >= 24 && std::memcmp(p + 12, "IHDR", 4) == 0) e = {be32(16), be32(20)};
  } else if (starts("\xFF\xD8", 2)) {
    // As libjpeg's next_marker(): bytes before a marker are skipped (libjpeg only warns about
    // "extraneous bytes", so a header must not end the search where the decoder goes on), then
    // FF fill bytes; FF 00 is a stuffed byte, not a marker.
    for (std::size_t i = 2; i + 1 < n;) {
      while (i < n && p[i] != 0xFF) ++i;
      while (i < n && p[i] == 0xFF) ++i;
      if (i >= n) break;
      const unsigned m = p[i++];
      if (m == 0x00 || m == 0x01 || (m >= 0xD0 && m <= 0xD8)) continue;  // no length
      if (m == 0xD9 || m == 0xDA || i + 2 > n) break;                    // end of image, scan: no frame header first
      const std::uint64_t len = be16(i);
      const bool sof = m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
      if (sof) {
        if (i + 7 <= n) e = {be16(i + 5), be16(i + 3)};
        break;
      }
      // A length below 2 cannot cover its own two bytes: libjpeg skips nothing and scans on for the
      // next marker right after the length (tests/fuzz: an APP0 of length 0 before a 65455 x 12496
      // frame header made the decoder allocate 2.4 GB while this search had stopped at it).
      i += len < 2 ? 2 : static_cast<std::size_t>(len);
    }
  } else if (starts("BM", 2)) {
    if (n >= 26) {
      const std::uint64_t dib = le32(14);
      const auto abs32 = [](std::uint64_t v) {  // a signed 32-bit field (negative: rows top-down)
        const auto s = static_cast<std::int64_t>(v) - (v >= (std::uint64_t{1} << 31) ? (std::int64_t{1} << 32) : 0);
        return static_cast<std::uint64_t>(s < 0 ? -s : s);
      };
      if (dib == 12)
        e = {le16(18), le16(20)};
      else if (dib >= 40)
        e = {abs32(le32(18)), abs32(le32(22))};
    }
  } else if (n >= 3 && p[0] == 'P' && p[1] >= '1' && p[1] <= '6') {
    // Read as OpenCV's PxM decoder reads it: before a number, whitespace and comments ('#' to the
    // end of the line, '\n' or '\r'); a number ends at any byte that is not a digit, and that byte
    // is consumed (so "2222\xff444444" is 2222 x 444444 to OpenCV, though not to the PNM standard).
    const auto space = [](unsigned char ch) {
      return ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n' || ch == '\v' || ch == '\f';
    };
    std::size_t i = 2;
    std::uint64_t v[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
      while (i < n && (space(p[i]) || p[i] == '#')) {
        if (p[i] == '#')
          while (i < n && p[i] != '\n' && p[i] != '\r') ++i;
        else
          ++i;
      }
      int digits = 0;
      for (; i < n && p[i] >= '0' && p[i] <= '9'; ++i)
        if (++digits <= 12) v[k] = v[k] * 10 + (p[i] - '0');
      if (digits == 0) return {};
      if (digits > 12) v[k] = std::uint64_t{1} << 40;  // absurd: more than any limit
      ++i;                                             // the byte that ended the number
    }
    e = {v[0], v[1]};
  } else if (n >= 32 && std::memcmp(p, "RIFF", 4) == 0 &&
             std::memcmp(p + 8, "WEBP", 4) == 0) {  // VP8X reads to byte 30
    if (std::memcmp(p + 12, "VP8 ", 4) == 0)
      e = {le16(26) & 0x3FFF, le16(28) & 0x3FFF};
    else if (std::memcmp(p + 12, "VP8L", 4) == 0) {
      const std::uint64_t b = le32(21);
      e = {(b & 0x3FFF) + 1, ((b >> 14) & 0x3FFF) + 1};
    } else if (std::memcmp(p + 12, "VP8X", 4) == 0) {
      e = {(le32(24) & 0xFFFFFF) + 1, (le32(27) & 0xFFFFFF) + 1};
    }
  } else if (starts("II*\0", 4) || starts("MM\0*", 4)) {
    const bool le = p[0] == 'I';
    const auto u16 = [&](std::size_t i) { return le ? le16(i) : be16(i); };
    const auto u32 = [&](std::size_t i) { return le ? le32(i) : be32(i); };
    if (n < 8) return {};
    const std::uint64_t ifd = u32(4);
    if (ifd + 2 > n) return {};
    const std::uint64_t count = u16(static_cast<std::size_t>(ifd));
    for (std::uint64_t k = 0; k < count; ++k) {
      const std::uint64_t at = ifd + 2 + 12 * k;
      if (at + 12 > n) break;
      const std::size_t a = static_cast<std::size_t>(at);
      const std::uint64_t tag = u16(a), type = u16(a + 2);
      const std::uint64_t value = type == 3 ? u16(a + 8) : type == 4 ? u32(a + 8) : 0;
      if (tag == 256) e.width = value;
      if (tag == 257) e.height = value;
    }
  }
  return e;
}

/// Why an image declaring `e` is not decoded, or "" when it may be.
inline std::string oversized_image(const ImageExtent& e) {
  if (!e.exceeds(kMaxImagePixels)) return {};
  return "it declares " + std::to_string(e.width) + " x " + std::to_string(e.height) +
         " pixels, more than regolith decodes in one image (" + std::to_string(kMaxImagePixels) +
         ", e.g. 8192 x 8192): scale it down first";
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
/// for anything else: a missing file, an unknown format, a truncated JPEG or PNG, more pixels
/// than kMaxImagePixels, a file over kMaxImageFileBytes, a decoder exception or refusal (e.g.
/// more pixels than OpenCV's limit). `why`, when given, says which. The file is read whole and
/// decoded from memory (decode_image), so one header is checked and one set of bytes decoded.
inline cv::Mat read_image_file(const std::string& path, int flags, std::string* why = nullptr);

/// cv::imdecode with the same guards (a camera's MJPEG frame cut short is refused too).
inline cv::Mat decode_image(const unsigned char* data, std::size_t size, int flags, std::string* why = nullptr) {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return cv::Mat();
  };
  if (!known_image_signature(data, size)) return fail("not an image regolith reads (PNG, JPEG, TIFF, BMP, PNM, WebP)");
  // A known first signature is not enough: when OpenCV's own decoder for that format declines the
  // header (a WebP whose chunk sizes disagree), cv::imdecode offers the bytes to the next decoder
  // that claims them, and GDCM claims anything with "DICM" at byte 128 (tests/fuzz: 136 bytes
  // starting RIFF....WEBP with DICM at 128 made GDCM allocate 2.7 GB).
  if (size >= 132 && std::memcmp(data + 128, "DICM", 4) == 0)
    return fail("not an image regolith reads (it carries a DICOM signature at byte 128)");
  if (size > static_cast<std::size_t>(INT32_MAX)) return fail("larger than 2 GiB");
  const std::size_t n_tail = std::min(size, kImageTailBytes);
  if (const std::string t = truncated_image(data, std::min<std::size_t>(size, 16), data + size - n_tail, n_tail);
      !t.empty())
    return fail(t);
  if (const std::string t = oversized_image(declared_image_extent(data, size)); !t.empty()) return fail(t);
  try {
    cv::Mat img = cv::imdecode(cv::Mat(1, static_cast<int>(size), CV_8UC1, const_cast<unsigned char*>(data)), flags);
    if (img.empty()) return fail("the decoder refused it (corrupt, or more pixels than it allows)");
    return img;
  } catch (const cv::Exception& e) {
    return fail(decoder_failure(e));
  }
}

inline cv::Mat read_image_file(const std::string& path, int flags, std::string* why) {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return cv::Mat();
  };
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return fail("it is a directory, not an image file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot open it");
  unsigned char head[16] = {};
  in.read(reinterpret_cast<char*>(head), sizeof head);
  if (!known_image_signature(head, static_cast<std::size_t>(in.gcount())))
    return fail("not an image regolith reads (PNG, JPEG, TIFF, BMP, PNM, WebP)");
  in.clear();
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return fail("cannot read it");
  if (static_cast<std::uint64_t>(size) > kMaxImageFileBytes)
    return fail("larger than " + std::to_string(kMaxImageFileBytes >> 20) + " MiB");
  std::string bytes(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  in.read(bytes.data(), size);
  if (in.gcount() != size) return fail("cannot read it (it changed while being read?)");
  return decode_image(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), flags, why);
}

/// The image with 8-bit samples and the same channels (an 8-bit image is returned as it is, not
/// copied). 16-bit samples are scaled by the bit depth the image uses: the smallest of 8..16 bits
/// that holds its largest sample. A 12-bit camera's image stored in a 16-bit PNG or TIFF maps 4095
/// to 255 (OpenCV's 8-bit reads shift right by 8 and make it 0..15, nearly black), a 16-bit file
/// holding 8-bit values keeps them, a full 16-bit one maps 65535 to 255. Floating-point samples:
/// 0..1 maps to 0..255, an image whose largest sample is above 1 is scaled by it, NaN and negative
/// samples become 0. Empty for signed integer samples.
inline cv::Mat to_8bit(const cv::Mat& image) {
  if (image.empty() || image.depth() == CV_8U) return image;
  cv::Mat out;
  if (image.depth() == CV_16U) {
    double largest = 0.0;
    cv::minMaxLoc(image.reshape(1), nullptr, &largest);
    int bits = 8;
    while (bits < 16 && largest > static_cast<double>((1 << bits) - 1)) ++bits;
    image.convertTo(out, CV_8U, 255.0 / static_cast<double>((1 << bits) - 1));
    return out;
  }
  if (image.depth() == CV_32F || image.depth() == CV_64F) {
    cv::Mat f;
    image.convertTo(f, CV_32F);
    cv::patchNaNs(f, 0.0);
    f = cv::max(f, 0.0);
    f = cv::min(f, static_cast<double>(std::numeric_limits<float>::max()));  // +inf
    double largest = 0.0;
    cv::minMaxLoc(f.reshape(1), nullptr, &largest);
    f.convertTo(out, CV_8U, largest > 1.0 ? 255.0 / largest : 255.0);
    return out;
  }
  return out;
}

/// read_image_file into 8-bit samples: `flags` is cv::IMREAD_GRAYSCALE or cv::IMREAD_COLOR (one or
/// three channels, EXIF orientation applied, as those flags do); a 16-bit image is decoded at full
/// depth and scaled by to_8bit instead of OpenCV's shift by 8. 8-bit files decode exactly as with
/// `flags` alone.
inline cv::Mat read_image_8bit(const std::string& path, int flags, std::string* why = nullptr) {
  cv::Mat img = read_image_file(path, flags | cv::IMREAD_ANYDEPTH, why);
  if (img.empty() || img.depth() == CV_8U) return img;
  cv::Mat out = to_8bit(img);
  if (out.empty() && why) *why = "samples of a type regolith does not read (depth " + std::to_string(img.depth()) + ")";
  return out;
}

}  // namespace regolith
