// libFuzzer target: the `assess` / rover terrain stages after decoding, on hostile pixels and a
// hostile camera: ground rectification + ground SfS + traversability layers
// (TraversabilityMapper::compute_from_image), the metric-height path (compute_from_metric) on
// heights that may be NaN or infinite, and SAMS (Itti + the structure channel of those heights)
// -> Otsu boxes -> each box ranged on the ground. An input is a small header and the pixels:
//   byte 0: bit 0 structure channel from the heights, bit 1 structure feature slope (else height),
//           bit 2 heights may be NaN / +-inf / 1e30 (bytes 0-3 of the pixels), bit 3 ground solver
//           Pentland (else Tsai-Shah marching), bit 4 camera lens distortion
//   byte 1, 2: width, height (16..79 px)
//   byte 3: camera pitch (-10..80 deg), byte 4: mount height (0.05..2.6 m),
//   byte 5: roll (-30..30 deg), byte 6: horizontal field of view (20..140 deg)
//   byte 7, 8: sun slant (0..89.9 deg), tilt (0..360 deg) in the image frame
//   byte 9: grid resolution (0.02..0.27 m) and map centre
//   then the pixels, repeated when the input is shorter than the image.
// Properties: every stage either throws std::invalid_argument (a refused camera or grid) or
// returns; layers have the grid's size, the traversability layers lie in [0, 1] or are NaN
// (unknown), confidence is finite in [0, 1]; the saliency map is finite in [0, 1] at the image's
// size; boxes lie inside the image; a ranged rock has finite range, width and height.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/ranging.hpp"
#include "regolith/traversability/traversability.hpp"

namespace {

using namespace regolith;

double span(std::uint8_t b, double lo, double hi) {
  return lo + (hi - lo) * b / 255.0;
}

void check_layers(const traversability::GridMap& m) {
  const int sx = m.size_x(), sy = m.size_y();
  if (m.data.size() != traversability::layer_names().size()) __builtin_trap();
  for (std::size_t k = 0; k < m.data.size(); ++k) {
    const cv::Mat& l = m.data[k];
    if (l.rows != sx || l.cols != sy || l.type() != CV_32F) __builtin_trap();
    const std::string& name = m.layers[k];
    const bool unit = name != "elevation";  // traversability_*, confidence: 0..1
    for (int i = 0; i < sx; ++i)
      for (int j = 0; j < sy; ++j) {
        const float v = l.at<float>(i, j);
        if (name == "confidence" && !(v >= 0.0f && v <= 1.0f)) __builtin_trap();
        if (std::isnan(v)) continue;  // unknown
        if (std::isinf(v)) __builtin_trap();
        if (unit && (v < 0.0f || v > 1.0f)) __builtin_trap();
      }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 11) return 0;
  const unsigned flags = data[0];
  const int w = 16 + data[1] % 64, h = 16 + data[2] % 64;

  direct_depth::CameraModel cam;
  cam.width = w;
  cam.height = h;
  const double hfov = span(data[6], 20.0, 140.0) * M_PI / 180.0;
  cam.fx = cam.fy = 0.5 * w / std::tan(0.5 * hfov);
  cam.cx = 0.5 * w;
  cam.cy = 0.5 * h;
  cam.pitch_rad = span(data[3], -10.0, 80.0) * M_PI / 180.0;
  cam.mount_height_m = span(data[4], 0.05, 2.6);
  cam.roll_rad = span(data[5], -30.0, 30.0) * M_PI / 180.0;
  if ((flags & 16u) != 0) {
    cam.k1 = span(data[9], -0.4, 0.4);
    cam.k2 = 0.05;
    cam.p1 = 0.001;
  }
  const sfs::LightDirection light{span(data[7], 0.0, 89.9) * M_PI / 180.0, span(data[8], 0.0, 360.0) * M_PI / 180.0};

  traversability::TraversabilityParams tp;
  tp.resolution_m = 0.02 + (data[9] % 16) * 0.0167;
  tp.length_x_m = tp.length_y_m = 2.0;
  tp.center_x_m = 0.5 + (data[9] >> 4) * 0.25;
  tp.detrend_sigma_px = 8.0;
  tp.rectify_resolution_m = 0.05;
  if ((flags & 8u) != 0) tp.ground_sfs.method = sfs::Method::kPentland;

  const std::uint8_t* px = data + 10;
  const std::size_t n = size - 10;
  cv::Mat gray(h, w, CV_8UC1);
  for (int i = 0; i < w * h; ++i) gray.data[i] = px[static_cast<std::size_t>(i) % n];
  // Heights in metres from the same bytes (signed, +-0.5 m), some made hostile on request.
  cv::Mat height(h, w, CV_32F);
  for (int i = 0; i < w * h; ++i) {
    const std::uint8_t b = gray.data[i];
    float v = (static_cast<float>(b) - 128.0f) / 256.0f;
    if ((flags & 4u) != 0) {
      if (b == 0)
        v = std::numeric_limits<float>::quiet_NaN();
      else if (b == 1)
        v = std::numeric_limits<float>::infinity();
      else if (b == 2)
        v = -std::numeric_limits<float>::infinity();
      else if (b == 3)
        v = 1e30f;
    }
    reinterpret_cast<float*>(height.data)[i] = v;
  }
  const cv::Mat valid = gray != 255;  // some pixels unknown

  std::optional<direct_depth::DirectDepth> depth;
  try {
    depth.emplace(cam);
  } catch (const std::invalid_argument&) {
    return 0;  // a refused camera (e.g. a distortion that folds the image)
  }

  // Terrain layers, both paths.
  try {
    traversability::TraversabilityMapper mapper(*depth, tp);
    static traversability::GridMap grid;  // reused, as the component does
    mapper.compute_from_image(gray, light, grid);
    check_layers(grid);
    mapper.compute_from_metric(height, valid, grid);
    check_layers(grid);
  } catch (const std::invalid_argument&) {
    // refused with a message (e.g. no pixel sees the grid)
  }

  // SAMS: a pyramid shallow enough for 16 px images, the structure channel on request.
  saliency::IttiParams ip;
  ip.centre_min = 1;
  ip.centre_max = 2;
  ip.delta_min = 1;
  ip.delta_max = 2;
  ip.map_level = 2;
  if ((flags & 1u) != 0) ip.weights.structure = 1.0;
  if ((flags & 2u) != 0) ip.structure_feature = saliency::StructureFeature::kSlope;
  static cv::Mat sal;
  try {
    saliency::IttiSaliency itti(ip);
    itti.compute(gray, (flags & 1u) != 0 ? height : cv::Mat(), sal);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  if (sal.rows != h || sal.cols != w || sal.type() != CV_32F) __builtin_trap();
  for (int i = 0; i < w * h; ++i) {
    const float v = reinterpret_cast<const float*>(sal.data)[i];
    if (!(v >= 0.0f && v <= 1.0f)) __builtin_trap();
  }
  saliency::PostProcessParams pp;
  pp.min_area = 4;
  pp.open_radius = pp.close_radius = 1;
  saliency::BoxDetector detector(pp);
  std::vector<saliency::Detection> boxes;
  detector.detect(sal, boxes);
  const saliency::GroundRanger ranger = [&depth](double u, double v) -> std::optional<saliency::GroundPoint> {
    const direct_depth::GroundPoint g = depth->ground(u - 0.5, v - 0.5);
    if (!g.valid) return std::nullopt;
    return saliency::GroundPoint{g.range_m, g.lateral_m};
  };
  for (const saliency::Detection& d : boxes) {
    if (d.box.x < 0 || d.box.y < 0 || d.box.width <= 0 || d.box.height <= 0 || d.box.x + d.box.width > w ||
        d.box.y + d.box.height > h)
      __builtin_trap();
    const saliency::RangedRock r = saliency::range_rock(d, ranger);
    if (r.ranged && !(std::isfinite(r.range_m) && std::isfinite(r.width_m) && std::isfinite(r.height_m)))
      __builtin_trap();
  }
  return 0;
}
