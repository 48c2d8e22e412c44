// libFuzzer target: the retrospective soil analysis on hostile pixels (`regolith soil`, the
// `soil_stiffness` component after decoding): rectification, albedo normalisation, SfS, rut
// detection or the configured ruts, the profile source (rut template, photoclinometry or the SfS
// DTM), the fixed-n / joint / prior fits and the soil class. An input is a small header and the
// pixels:
//   byte 0: bits 0-1 profile source (template, photoclinometry, SfS DTM), bit 2 configured ruts
//           (else detected), bit 3 the configured ruts carry two loads (joint fit), bit 4 SfS
//           Tsai-Shah (else Pentland), bit 5 colour image, bit 6 no cast shadows
//   byte 1, 2: width, height (32..95 px)
//   byte 3: camera pitch (10..80 deg), byte 4: mount height (0.3..1.6 m)
//   byte 5, 6: sun azimuth (0..360 deg), elevation (0..89 deg) in the camera's ground frame
//   byte 7: the configured ruts' lateral positions
//   then the pixels, repeated when the input is shorter than the image.
// Properties: estimate() either throws std::invalid_argument or returns; no estimate carries a
// reason; an estimate has finite, positive k and finite n and std's; every profile sample is a
// finite sinkage or NaN; the rectified image and the DTM keep the grid's size.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "regolith/soil_stiffness/track_analysis.hpp"

namespace {

double span(std::uint8_t b, double lo, double hi) {
  return lo + (hi - lo) * b / 255.0;
}

bool finite_nonneg(double v) {
  return std::isfinite(v) && v >= 0.0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace regolith::soil;
  if (size < 9) return 0;
  const unsigned flags = data[0];
  const int w = 32 + data[1] % 64, h = 32 + data[2] % 64;

  CameraModel cam;
  cam.width = w;
  cam.height = h;
  cam.fx = cam.fy = w;  // 53 deg horizontal field of view (the development track scenes)
  cam.cx = 0.5 * w;
  cam.cy = 0.5 * h;
  cam.pitch_rad = span(data[3], 10.0, 80.0) * M_PI / 180.0;
  cam.mount_height_m = span(data[4], 0.3, 1.6);
  const SunDirection sun{span(data[5], 0.0, 360.0) * M_PI / 180.0, span(data[6], 0.0, 89.0) * M_PI / 180.0};

  RoverConfig rover;
  rover.wheel_width_m = 0.12;
  TrackAnalysisParams p;
  // A coarse grid and few bootstrap draws: every stage runs, each input in milliseconds.
  p.range_min_m = 0.6;
  p.range_max_m = 2.4;
  p.lateral_min_m = -0.6;
  p.lateral_max_m = 0.6;
  p.grid_res_m = 0.02;
  p.bootstrap_samples = 8;
  p.sfs_iterations = 20;
  p.rut_template.sinkage_step_m = 0.004;
  p.rut_template.centre_step_m = 0.006;
  p.rut_template.sample_step_m = 0.006;
  switch (flags & 3u) {
    case 0: p.profile_source = ProfileSource::kTemplate; break;
    case 1: p.profile_source = ProfileSource::kPhotoclinometry; break;
    default: p.profile_source = ProfileSource::kSfsDtm; break;
  }
  if ((flags & 4u) != 0) {
    const double off = span(data[7], 0.05, 0.4);
    const double load = (flags & 8u) != 0 ? 2.0 * rover.wheel_load_n() : 0.0;
    p.tracks = {TrackSpec{off, 0.0}, TrackSpec{-off, load}};
  }
  if ((flags & 16u) != 0) p.sfs_method = SfsMethod::kTsaiShah;
  p.use_shadows = (flags & 64u) == 0;

  const std::uint8_t* px = data + 8;
  const std::size_t n = size - 8;
  const int channels = (flags & 32u) != 0 ? 3 : 1;
  cv::Mat image(h, w, channels == 3 ? CV_8UC3 : CV_8UC1);
  for (int i = 0; i < w * h * channels; ++i) image.data[i] = px[static_cast<std::size_t>(i) % n];

  static SoilEstimate out;  // reused, as the component does
  try {
    SoilStiffnessEstimator estimator(cam, rover, p);
    estimator.estimate(image, sun, out);
    if (estimator.rectified().size() != estimator.dtm_m().size()) __builtin_trap();
  } catch (const std::invalid_argument&) {
    return 0;  // refused with a message (e.g. a camera that sees none of the region)
  }
  if (!out.ok) {
    if (out.reason.empty()) __builtin_trap();
    return 0;
  }
  if (!(std::isfinite(out.k) && out.k > 0.0 && std::isfinite(out.n) && finite_nonneg(out.k_std) &&
        finite_nonneg(out.n_std) && std::isfinite(out.mean_sinkage_m) && out.samples_used > 0))
    __builtin_trap();
  for (const TrackProfile& t : out.tracks) {
    if (t.range_m.size() != t.sinkage_m.size()) __builtin_trap();
    for (double z : t.sinkage_m)
      if (std::isinf(z)) __builtin_trap();
  }
  return 0;
}
