// libFuzzer target: the drive-long mapper (DriveMapper::add_frame: wheel + visual odometry, both
// parallax searches, rock sightings and tracks, cast shadows, shading, the world map) on a hostile
// camera, sun and drive. The frames are rendered here from the input's camera and motion (a flat
// textured ground with dark patches, seen through DirectDepth's ground rays), so that the visual
// odometry locks and the parallax searches run with the fuzzer's geometry; a frame may also be
// black, saturated or noise, and the wheel odometry may jump, lag, or be NaN or infinite.
// An input is a header and five bytes per frame:
//   byte 0: bit 0-1 parallax mode (both / sweep / rectified / both), bit 2 odometry may be
//           non-finite, bit 3 capture times given (else NaN), bit 4 no vision (wheels only),
//           bit 5 every frame a keyframe candidate (keyframe_distance_m 0.05)
//   byte 1: camera pitch (0.15..1.4 rad), byte 2: mount height (0.25..1.6 m),
//   byte 3: horizontal field of view (30..130 deg), byte 4: width (48..200 px, height 3/4),
//   byte 5, 6: sun elevation (-10..85 deg) and azimuth (0..360 deg),
//   byte 7: camera roll (-0.1..0.1 rad), byte 8: texture seed, byte 9: frames (2..9)
//   per frame: forward step (int8 x 5 mm), yaw step (int8 x 2 mrad), the wheels' error (int8 x
//   0.5 %; its low bits pick a special reading when bit 2 is set), the frame's kind and time step.
// Properties: the mapper is built or refuses the camera with an exception; add_frame never throws
// on a frame of the camera's size; every reported pose and covariance is finite; after finish()
// the elevation is finite or NaN, the hazard in [0, 1] or NaN, the confidence >= 0.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/mapping/drive_mapper.hpp"

namespace {

using namespace regolith;
using namespace regolith::mapping;

double span(std::uint8_t b, double lo, double hi) {
  return lo + (hi - lo) * b / 255.0;
}

// A fixed random texture tiled over the ground (1 cm texels, bilinear), darker on discs of
// 0.1-0.3 m every ~1.5 m (rock-like blobs for the sightings).
class Ground {
 public:
  explicit Ground(std::uint8_t seed) : tex_(128, 128, CV_32F) {
    cv::RNG rng(seed + 1u);
    rng.fill(tex_, cv::RNG::UNIFORM, 60.0, 200.0);
  }
  float at(double x, double y) const {
    const double u = x / 0.01, v = y / 0.01;
    const double fu = std::floor(u), fv = std::floor(v);
    const int i = wrap(static_cast<long>(fv)), j = wrap(static_cast<long>(fu));
    const int i1 = (i + 1) & 127, j1 = (j + 1) & 127;
    const double a = u - fu, b = v - fv;
    const double top = tex_.at<float>(i, j) * (1 - a) + tex_.at<float>(i, j1) * a;
    const double bot = tex_.at<float>(i1, j) * (1 - a) + tex_.at<float>(i1, j1) * a;
    double g = top * (1 - b) + bot * b;
    const double cx = std::round(x / 1.5) * 1.5, cy = std::round(y / 1.5) * 1.5;
    if (std::hypot(x - cx - 0.2, y - cy + 0.1) < 0.1 + 0.2 * std::abs(std::sin(cx + 3 * cy))) g *= 0.35;
    return static_cast<float>(g);
  }

 private:
  static int wrap(long k) { return static_cast<int>(((k % 128) + 128) % 128); }
  cv::Mat tex_;
};

void render(const direct_depth::DirectDepth& dd, const Ground& ground, const Pose2& foot, cv::Mat& out) {
  const cv::Mat &range = dd.range_map(), &lateral = dd.lateral_map();
  const double c = std::cos(foot.yaw), s = std::sin(foot.yaw);
  for (int i = 0; i < out.rows; ++i)
    for (int j = 0; j < out.cols; ++j) {
      const float r = range.at<float>(i, j), l = lateral.at<float>(i, j);
      if (!std::isfinite(r) || !std::isfinite(l) || r > 30.0f) {
        out.at<uchar>(i, j) = 220;  // sky
        continue;
      }
      const double x = foot.x + c * r - s * l, y = foot.y + s * r + c * l;
      out.at<uchar>(i, j) = cv::saturate_cast<uchar>(ground.at(x, y));
    }
}

void check(bool ok) {
  if (!ok) __builtin_trap();
}

void check_pose(const FrameReport& f) {
  check(f.pose.finite());
  check(f.covariance.allFinite());
  for (int k = 0; k < 3; ++k) check(f.covariance(k, k) >= 0.0);
}

void check_map(const WorldMap& map) {
  const cv::Mat &elev = map.layer("elevation"), &hazard = map.layer("hazard"), &conf = map.layer("confidence");
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j) {
      const float e = elev.at<float>(i, j), h = hazard.at<float>(i, j), w = conf.at<float>(i, j);
      check(!std::isinf(e));
      check(std::isnan(h) || (h >= 0.0f && h <= 1.0f));
      check(!std::isnan(w) && w >= 0.0f && !std::isinf(w));
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kHeader = 10, kPerFrame = 5;
  if (size < kHeader) return 0;
  const std::uint8_t flags = data[0];
  direct_depth::CameraModel cam;
  cam.pitch_rad = span(data[1], 0.15, 1.4);
  cam.mount_height_m = span(data[2], 0.25, 1.6);
  const double hfov = span(data[3], 30.0, 130.0) * CV_PI / 180.0;
  cam.width = 48 + 4 * static_cast<int>(span(data[4], 0, 38));
  cam.height = cam.width * 3 / 4;
  cam.fx = cam.fy = cam.width / 2.0 / std::tan(hfov / 2.0);
  cam.cx = (cam.width - 1) / 2.0;
  cam.cy = (cam.height - 1) / 2.0;
  cam.roll_rad = span(data[7], -0.1, 0.1);
  const double el = span(data[5], -10.0, 85.0) * CV_PI / 180.0, az = span(data[6], 0.0, 360.0) * CV_PI / 180.0;
  const cv::Vec3d sun(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  const int frames = std::min(2 + data[9] % 8, static_cast<int>((size - kHeader) / kPerFrame));
  DriveMapperParams p;
  const int mode = flags & 3;
  p.parallax_mode = mode == 1 ? ParallaxMode::kSweep : mode == 2 ? ParallaxMode::kRectified : ParallaxMode::kBoth;
  p.use_vision = (flags & 16) == 0;
  if (flags & 32) p.keyframe_distance_m = 0.05;
  // Coarser grids than the defaults (each search's cells, the map's window) keep an input fast
  // under the sanitizers; the geometry and every code path are the same.
  p.map.length_x_m = p.map.length_y_m = 6.0;
  p.map.resolution_m = 0.08;
  p.parallax.resolution_m = 0.08;
  p.parallax.max_range_m = 4.0;
  p.parallax.half_width_m = 2.5;
  p.terrain.resolution_m = 0.1;
  p.terrain.rectify_resolution_m = 0.05;
  p.sweep.max_width_px = 100;
  std::optional<DriveMapper> dm;
  std::optional<direct_depth::DirectDepth> dd;
  try {
    dd.emplace(cam);
    dm.emplace(cam, CameraMount{}, sun, p, cv::Point2d(2.0, 0.0));
  } catch (const std::exception&) {
    return 0;  // a camera or sun the mapper refuses, with its reason
  }
  const Ground ground(data[8]);
  cv::Mat img(cam.height, cam.width, CV_8U);
  Pose2 truth{}, wheel{};
  double t = 0.0;
  const std::uint8_t* f = data + kHeader;
  for (int k = 0; k < frames; ++k, f += kPerFrame) {
    if (k) {
      const Pose2 step{static_cast<std::int8_t>(f[0]) * 0.005, 0.0, static_cast<std::int8_t>(f[1]) * 0.002};
      truth = compose(truth, step);
      const double err = 1.0 + static_cast<std::int8_t>(f[2]) * 0.005;
      wheel = compose(wheel, Pose2{step.x * err, 0.0, step.yaw * err});
    }
    Pose2 reading = wheel;
    if (flags & 4) {
      if ((f[2] & 15) == 1) reading.x = std::numeric_limits<double>::quiet_NaN();
      if ((f[2] & 15) == 2) reading.yaw = std::numeric_limits<double>::infinity();
      if ((f[2] & 15) == 3) reading.y += 1e6;
    }
    switch (f[3] & 7) {
      case 5: img.setTo(0); break;
      case 6: img.setTo(255); break;
      case 7: cv::randu(img, 0, 256); break;
      default: render(*dd, ground, truth, img);
    }
    t += (f[4] & 127) * 0.02;
    const double stamp = (flags & 8) ? (f[4] & 128 ? t - 1.0 : t) : std::numeric_limits<double>::quiet_NaN();
    try {
      check_pose(dm->add_frame(img, reading, stamp));
    } catch (const std::exception&) {
      __builtin_trap();  // a frame of the camera's size is never refused
    }
  }
  dm->map().finish();
  check_map(dm->map());
  return 0;
}
