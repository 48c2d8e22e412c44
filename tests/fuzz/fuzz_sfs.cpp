// libFuzzer target: shape from shading on hostile pixels, the stage after decoding in `regolith
// assess` and the `sfs` component. An input is a small header and the pixels:
//   byte 0: bits 0-1 method (Tsai-Shah marching, Tsai-Shah Jacobi, Pentland, Bichsel-Pentland),
//           bit 2 estimate the light (else the light below), bit 3 skip black pixels (marching),
//           bit 4 pixels as float 0..1 (from the bytes / 255) instead of 8-bit
//   byte 1, 2: width, height (16..79 px)
//   byte 3, 4: slant (0..89.9 deg), tilt (0..360 deg), 1/256 steps of the range
//   then the pixels, repeated when the input is shorter than the image.
// Properties: compute() either throws std::invalid_argument or returns; a solved result has the
// image's size and a finite height on every pixel it calls valid.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "regolith/sfs/sfs.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace regolith::sfs;
  if (size < 6) return 0;
  const unsigned flags = data[0];
  const int w = 16 + data[1] % 64, h = 16 + data[2] % 64;
  SfsParams p;
  p.iterations = 20;  // Jacobi / Bichsel-Pentland sweeps: enough to reach every code path
  switch (flags & 3u) {
    case 0: p.method = Method::kTsaiShah; break;
    case 1:
      p.method = Method::kTsaiShah;
      p.tsai_shah_scheme = TsaiShahScheme::kJacobi;
      break;
    case 2: p.method = Method::kPentland; break;
    default: p.method = Method::kBichselPentland; break;
  }
  p.estimate_light = (flags & 4u) != 0;
  p.tsai_shah_skip_black = (flags & 8u) != 0;
  std::optional<LightDirection> light;
  if (!p.estimate_light) light = LightDirection{data[3] / 256.0 * 89.9 * M_PI / 180.0, data[4] / 256.0 * 2.0 * M_PI};
  const std::uint8_t* px = data + 5;
  const std::size_t n = size - 5;
  cv::Mat img8(h, w, CV_8UC1);
  for (int i = 0; i < w * h; ++i) img8.data[i] = px[static_cast<std::size_t>(i) % n];
  cv::Mat img;
  if ((flags & 16u) != 0)
    img8.convertTo(img, CV_32F, 1.0 / 255.0);
  else
    img = img8;
  static SfsResult out;  // reused, as the component does
  try {
    ShapeFromShading solver(p);
    solver.compute(img, light, out);
  } catch (const std::invalid_argument&) {
    return 0;  // refused with a message
  }
  if (out.status != SfsStatus::kSolved) return 0;
  if (out.height.rows != h || out.height.cols != w || out.height.type() != CV_32F) __builtin_trap();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if ((out.valid.empty() || out.valid.at<std::uint8_t>(y, x) != 0) && !std::isfinite(out.height.at<float>(y, x)))
        __builtin_trap();
  return 0;
}
