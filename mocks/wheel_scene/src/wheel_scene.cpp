#include "regolith/wheel_scene/wheel_scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace regolith::wheel_scene {
namespace {

[[noreturn]] void bad(const char* field, const std::string& what, double got) {
  std::ostringstream os;
  os << field << ": " << what << " (got " << got << ')';
  throw std::invalid_argument(os.str());
}

void finite(const char* field, double v) {
  if (!std::isfinite(v)) bad(field, "must be finite", v);
}

double wrap_pi(double a) {
  const double two_pi = 2.0 * std::numbers::pi;
  a = std::fmod(a + std::numbers::pi, two_pi);
  if (a <= 0.0) a += two_pi;
  return a - std::numbers::pi;
}

constexpr int kSuper = 4;  // supersampling factor of the leg / hub coverage

/// Band-limited texture in [-1, 1]-ish: sum of blurred Gaussian noise at two scales.
cv::Mat make_noise(cv::Size size, cv::RNG& rng, double fine_sigma, double coarse_sigma) {
  cv::Mat a(size, CV_32F), b(size, CV_32F);
  rng.fill(a, cv::RNG::NORMAL, 0.0, 1.0);
  rng.fill(b, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(a, a, {0, 0}, fine_sigma);
  cv::GaussianBlur(b, b, {0, 0}, coarse_sigma);
  cv::Scalar ma, sa, mb, sb;
  cv::meanStdDev(a, ma, sa);
  cv::meanStdDev(b, mb, sb);
  cv::Mat out = 0.6 * (a / sa[0]) + 0.4 * (b / sb[0]);
  return out;
}

}  // namespace

void WheelModel::validate() const {
  finite("WheelModel.hub_center_px.x", hub_center_px.x);
  finite("WheelModel.hub_center_px.y", hub_center_px.y);
  if (leg_count < 1 || leg_count > 16) bad("WheelModel.leg_count", "must be in [1, 16]", leg_count);
  finite("WheelModel.leg_spacing_rad", leg_spacing_rad);
  if (leg_spacing_rad <= 0) bad("WheelModel.leg_spacing_rad", "must be > 0", leg_spacing_rad);
  finite("WheelModel.hub_radius_px", hub_radius_px);
  if (hub_radius_px < 0) bad("WheelModel.hub_radius_px", "must be >= 0", hub_radius_px);
  finite("WheelModel.leg_length_px", leg_length_px);
  if (leg_length_px <= hub_radius_px) {
    bad("WheelModel.leg_length_px", "must exceed hub_radius_px", leg_length_px);
  }
  finite("WheelModel.leg_width_px", leg_width_px);
  if (leg_width_px <= 0) bad("WheelModel.leg_width_px", "must be > 0", leg_width_px);
  finite("WheelModel.foot_width_px", foot_width_px);
  if (foot_width_px < 0) bad("WheelModel.foot_width_px", "must be >= 0", foot_width_px);
  finite("WheelModel.foot_thickness_px", foot_thickness_px);
  if (foot_thickness_px < 0 || foot_thickness_px > leg_length_px) {
    bad("WheelModel.foot_thickness_px", "must be in [0, leg_length_px]", foot_thickness_px);
  }
  finite("WheelModel.angle_offset_rad", angle_offset_rad);
  if (rotation_direction != 1 && rotation_direction != -1) {
    bad("WheelModel.rotation_direction", "must be +1 or -1", rotation_direction);
  }
  finite("WheelModel.mm_per_px", mm_per_px);
  if (mm_per_px <= 0) bad("WheelModel.mm_per_px", "must be > 0", mm_per_px);
}

void Illumination::validate() const {
  finite("Illumination.gain", gain);
  if (gain <= 0) bad("Illumination.gain", "must be > 0", gain);
  finite("Illumination.noise_sigma", noise_sigma);
  if (noise_sigma < 0) bad("Illumination.noise_sigma", "must be >= 0", noise_sigma);
  finite("Illumination.blur_sigma_px", blur_sigma_px);
  if (blur_sigma_px < 0) bad("Illumination.blur_sigma_px", "must be >= 0", blur_sigma_px);
  finite("Illumination.motion_blur_px", motion_blur_px);
  if (motion_blur_px < 0) bad("Illumination.motion_blur_px", "must be >= 0", motion_blur_px);
}

void SceneParams::validate() const {
  if (size.width < 16 || size.height < 16) bad("SceneParams.size", "must be >= 16x16", size.width);
  wheel.validate();
  light.validate();
  finite("SceneParams.soil_texture_contrast", soil_texture_contrast);
  if (soil_texture_contrast < 0 || soil_texture_contrast > 1) {
    bad("SceneParams.soil_texture_contrast", "must be in [0, 1]", soil_texture_contrast);
  }
  finite("SceneParams.sand_on_leg_fraction", sand_on_leg_fraction);
  if (sand_on_leg_fraction < 0 || sand_on_leg_fraction > 0.5) {
    bad("SceneParams.sand_on_leg_fraction", "must be in [0, 0.5]", sand_on_leg_fraction);
  }
  finite("SceneParams.misalignment_rad", misalignment_rad);
}

WheelSceneGenerator::WheelSceneGenerator(const SceneParams& params) : params_(params), rng_(params.seed) {
  params_.validate();
  cv::RNG rng(params_.seed * 7919U + 17U);
  const cv::Size sz = params_.size;
  // sand: two-scale texture + sparse dark / bright grains
  const cv::Mat n = make_noise(sz, rng, 1.0, 5.0);
  cv::Mat grains(sz, CV_32F);
  rng.fill(grains, cv::RNG::UNIFORM, 0.0, 1.0);
  soil_tex_.create(sz, CV_32FC3);
  back_tex_.create(sz, CV_32FC3);
  const cv::Mat nb = make_noise(sz, rng, 2.0, 12.0);
  const double c = params_.soil_texture_contrast;
  for (int y = 0; y < sz.height; ++y) {
    const float* np = n.ptr<float>(y);
    const float* gp = grains.ptr<float>(y);
    const float* bp = nb.ptr<float>(y);
    auto* sp = soil_tex_.ptr<cv::Vec3f>(y);
    auto* wp = back_tex_.ptr<cv::Vec3f>(y);
    const double wall_shade = 0.8 + 0.4 * y / static_cast<double>(sz.height);
    for (int x = 0; x < sz.width; ++x) {
      double f = 1.0 + c * np[x];
      if (gp[x] < 0.015)
        f *= 0.45;  // dark grain
      else if (gp[x] > 0.99)
        f *= 1.35;  // bright grain
      const double fw = wall_shade * (1.0 + 0.08 * bp[x]);
      for (int ch = 0; ch < 3; ++ch) {
        sp[x][ch] = static_cast<float>(params_.soil_bgr[ch] * f);
        wp[x][ch] = static_cast<float>(params_.background_bgr[ch] * fw);
      }
    }
  }
  radiance_.create(sz, CV_32FC3);
  cover_.create(sz * kSuper, CV_8UC1);
  hub_cover_.create(sz * kSuper, CV_8UC1);
}

void WheelSceneGenerator::set_illumination(const Illumination& l) {
  l.validate();
  params_.light = l;
}

double WheelSceneGenerator::leg_angle(int k, double encoder_angle_rad) const {
  const WheelModel& w = params_.wheel;
  return wrap_pi(w.rotation_direction * encoder_angle_rad + w.angle_offset_rad + params_.misalignment_rad +
                 k * w.leg_spacing_rad);
}

double WheelSceneGenerator::lowest_tip_y(double encoder_angle_rad, int* leg) const {
  const WheelModel& w = params_.wheel;
  double best = -1e300;
  int best_k = -1;
  for (int k = 0; k < w.leg_count; ++k) {
    const double y = w.hub_center_px.y + w.leg_length_px * std::cos(leg_angle(k, encoder_angle_rad));
    if (y > best) {
      best = y;
      best_k = k;
    }
  }
  if (leg != nullptr) *leg = best_k;
  return best;
}

FrameTruth WheelSceneGenerator::render_with_sinkage(double encoder_angle_rad, double sinkage_mm, cv::Mat& bgr) {
  if (!std::isfinite(sinkage_mm) || sinkage_mm < 0) {
    bad("render_with_sinkage: sinkage_mm", "must be finite and >= 0", sinkage_mm);
  }
  const double soil_y = lowest_tip_y(encoder_angle_rad) - sinkage_mm / params_.wheel.mm_per_px;
  return render_at_soil_level(encoder_angle_rad, soil_y, bgr);
}

FrameTruth WheelSceneGenerator::render_at_soil_level(double encoder_angle_rad, double soil_y_px, cv::Mat& bgr) {
  finite("render: encoder_angle_rad", encoder_angle_rad);
  finite("render: soil_y_px", soil_y_px);
  const WheelModel& w = params_.wheel;
  const cv::Size sz = params_.size;

  FrameTruth t;
  t.encoder_angle_rad = encoder_angle_rad;
  t.leg0_angle_rad = leg_angle(0, encoder_angle_rad);
  t.soil_y_px = soil_y_px;
  const double tip_y = lowest_tip_y(encoder_angle_rad, &t.deepest_leg);
  t.sinkage_px = std::max(0.0, tip_y - soil_y_px);
  t.sinkage_mm = t.sinkage_px * w.mm_per_px;

  // --- coverage of legs and hub, supersampled ---
  cover_.setTo(0);
  hub_cover_.setTo(0);
  constexpr int kShift = 4;
  const double sc = kSuper * (1 << kShift);
  // pixel centres are at integer coordinates: the supersampled pixel (i, j) covers
  // [(i - (kSuper-1)/2) / kSuper ...] -> map continuous x to super coords x*kSuper + (kSuper-1)/2
  const double off = 0.5 * (kSuper - 1);
  auto fp = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround((x * kSuper + off) * (1 << kShift))),
                     static_cast<int>(std::lround((y * kSuper + off) * (1 << kShift))));
  };
  (void)sc;
  const double hw = 0.5 * w.leg_width_px;
  const double fw = std::max(hw, 0.5 * w.foot_width_px);
  const double fs = w.leg_length_px - w.foot_thickness_px;
  const double r0 = 0.5 * w.hub_radius_px;
  for (int k = 0; k < w.leg_count; ++k) {
    const double phi = leg_angle(k, encoder_angle_rad);
    const double dx = std::sin(phi), dy = std::cos(phi);
    const double nx = std::cos(phi), ny = -std::sin(phi);
    const double cx = w.hub_center_px.x, cy = w.hub_center_px.y;
    auto P = [&](double s, double tt) { return fp(cx + s * dx + tt * nx, cy + s * dy + tt * ny); };
    const cv::Point shaft[4] = {P(r0, -hw), P(w.leg_length_px, -hw), P(w.leg_length_px, hw), P(r0, hw)};
    cv::fillConvexPoly(cover_, shaft, 4, cv::Scalar(255), cv::LINE_8, kShift);
    if (w.foot_width_px > 0 && w.foot_thickness_px > 0) {
      const cv::Point foot[4] = {P(fs, -fw), P(w.leg_length_px, -fw), P(w.leg_length_px, fw), P(fs, fw)};
      cv::fillConvexPoly(cover_, foot, 4, cv::Scalar(255), cv::LINE_8, kShift);
    }
  }
  if (w.hub_radius_px > 0) {
    cv::circle(hub_cover_, fp(w.hub_center_px.x, w.hub_center_px.y),
               static_cast<int>(std::lround(w.hub_radius_px * kSuper * (1 << kShift))), cv::Scalar(255), cv::FILLED,
               cv::LINE_8, kShift);
  }
  cv::Mat leg_a, hub_a;
  cv::resize(cover_, leg_a, sz, 0, 0, cv::INTER_AREA);
  cv::resize(hub_cover_, hub_a, sz, 0, 0, cv::INTER_AREA);

  // --- compose radiance ---
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const int shift = static_cast<int>(std::lround(std::abs(encoder_angle_rad) * 0.3 * w.leg_length_px)) % sz.width;
  for (int y = 0; y < sz.height; ++y) {
    const double a_soil = std::clamp(y + 0.5 - soil_y_px, 0.0, 1.0);
    const auto* sp = soil_tex_.ptr<cv::Vec3f>(y);
    const auto* bp = back_tex_.ptr<cv::Vec3f>(y);
    const std::uint8_t* lp = leg_a.ptr<std::uint8_t>(y);
    const std::uint8_t* hp = hub_a.ptr<std::uint8_t>(y);
    auto* rp = radiance_.ptr<cv::Vec3f>(y);
    for (int x = 0; x < sz.width; ++x) {
      cv::Vec3f soil = sp[(x + shift) % sz.width];
      cv::Vec3f v = bp[x];
      const float al = static_cast<float>(lp[x]) / 255.0F;
      if (al > 0.0F) {
        cv::Vec3f leg(static_cast<float>(params_.leg_bgr[0]), static_cast<float>(params_.leg_bgr[1]),
                      static_cast<float>(params_.leg_bgr[2]));
        if (a_soil < 1.0 && params_.sand_on_leg_fraction > 0 && uni(rng_) < params_.sand_on_leg_fraction) {
          leg = soil;  // a sand grain stuck on the leg
        }
        v = v * (1.0F - al) + leg * al;
      }
      const float ah = static_cast<float>(hp[x]) / 255.0F;
      if (ah > 0.0F) {
        const cv::Vec3f hub(static_cast<float>(params_.hub_bgr[0]), static_cast<float>(params_.hub_bgr[1]),
                            static_cast<float>(params_.hub_bgr[2]));
        v = v * (1.0F - ah) + hub * ah;
      }
      const auto as = static_cast<float>(a_soil);
      rp[x] = v * (1.0F - as) + soil * as;
    }
  }
  // --- camera: gain, optical / motion blur, sensor noise, quantisation ---
  const Illumination& L = params_.light;
  cv::Mat img = radiance_ * L.gain;
  if (L.blur_sigma_px > 0) cv::GaussianBlur(img, img, {0, 0}, L.blur_sigma_px);
  if (L.motion_blur_px >= 1.0) {
    const int k = std::max(1, static_cast<int>(std::lround(L.motion_blur_px)));
    cv::blur(img, img, {k, 1});
  }
  if (L.noise_sigma > 0) {
    cv::Mat noise(sz, CV_32FC3);
    cv::RNG rng(static_cast<std::uint64_t>(rng_()));
    rng.fill(noise, cv::RNG::NORMAL, 0.0, L.noise_sigma);
    img += noise;
  }
  img.convertTo(bgr, CV_8UC3);
  return t;
}

double SequenceSpec::profile_mm(int i) const {
  const double u = frames > 1 ? static_cast<double>(i) / (frames - 1) : 0.0;
  if (u < 0.1) return 0.0;
  if (u < 0.5) return max_sinkage_mm * (u - 0.1) / 0.4 * 0.85;
  const double osc = std::sin(2.0 * std::numbers::pi * (u - 0.5) / 0.5);
  return max_sinkage_mm * (0.85 + 0.15 * osc);
}

void SequenceSpec::validate() const {
  if (frames < 1) bad("SequenceSpec.frames", "must be >= 1", frames);
  finite("SequenceSpec.start_angle_rad", start_angle_rad);
  finite("SequenceSpec.angle_step_rad", angle_step_rad);
  finite("SequenceSpec.max_sinkage_mm", max_sinkage_mm);
  if (max_sinkage_mm < 0) bad("SequenceSpec.max_sinkage_mm", "must be >= 0", max_sinkage_mm);
}

std::vector<SequenceFrame> make_sequence(WheelSceneGenerator& gen, const SequenceSpec& spec) {
  spec.validate();
  std::vector<SequenceFrame> out(static_cast<std::size_t>(spec.frames));
  for (int i = 0; i < spec.frames; ++i) {
    const double a = spec.start_angle_rad + i * spec.angle_step_rad;
    auto& f = out[static_cast<std::size_t>(i)];
    f.truth = gen.render_with_sinkage(a, spec.profile_mm(i), f.bgr);
  }
  return out;
}

}  // namespace regolith::wheel_scene
