// libFuzzer target: the image path behind `regolith rocks` and `assess`: decode any bytes
// (PNG, JPEG, TIFF, BMP, PNM, WebP; 8 or 16 bit, grey or colour; the header's declared size
// checked first), then the contrast saliency map and the rock boxes on what decodes, up to
// 128 x 128 (larger images are decoded only: the detector's code paths are the same at that size,
// and at 512 x 512 it held the long run to ~250 executions / s).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "regolith/core/image_file.hpp"
#include "regolith/saliency/contrast.hpp"
#include "regolith/saliency/detect.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // as every file loader: known signatures only (regolith/core/image_file.hpp)
  const cv::Mat img = regolith::decode_image(data, size, cv::IMREAD_UNCHANGED);
  if (img.empty() || img.cols < 16 || img.rows < 16 || img.cols > 128 || img.rows > 128) return 0;
  static regolith::saliency::ContrastSaliency contrast({16.0, 2.0});
  static regolith::saliency::BoxDetector detector;
  cv::Mat map;
  std::vector<regolith::saliency::Detection> dets;
  try {
    contrast.compute(img, map);
    detector.detect(map, dets);
  } catch (const std::invalid_argument&) {
    // unsupported layout (e.g. 2 channels): refused with a message
  }
  return 0;
}
