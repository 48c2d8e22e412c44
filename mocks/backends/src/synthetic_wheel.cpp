// Camera "synthetic_wheel" and encoders "synthetic_wheel": frames of the wheel-leg scene
// (regolith::wheel_scene) rendered at configure time for a scripted wheel angle, and encoders that
// report exactly the angles the frames were rendered at. Give both devices the same mapping.
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"
#include "script.hpp"

namespace regolith::mocks {
namespace detail {
namespace {

struct WheelSpec {
  hal::CameraFormat fmt;
  int frames = 0;
  bool loop = true;
  double sample_rate_hz = 100.0;
  TimeNs max_extrapolation = 0;
  std::string wheel;
  ScriptedMotion motion;
  double sinkage_mm = 0.0;
  wheel_scene::SceneParams scene;
  /// rad the wheel turns per loop of the frames when that is a whole number of leg spacings (the
  /// first frame then shows the wheel exactly as one frame after the last would): the encoders
  /// keep counting across loops. 0 otherwise: the angle repeats with the frames (a jump back).
  double turn_per_loop = 0.0;

  /// Scene time (s) shown at `t` seconds after start: frames repeat (loop) or the last one stays.
  double scene_time(double t) const {
    const double period = frames / fmt.rate_hz;
    if (loop) return t - std::floor(t / period) * period;
    return std::min(t, (frames - 1) / fmt.rate_hz);
  }
};

// Both backends read every key so that one mapping serves the camera and the encoders.
WheelSpec read_spec(Params& p, const hal::DeviceContext& ctx) {
  WheelSpec s;
  s.fmt.rate_hz = p.get<double>(
      "rate_hz", 10.0, {.unit = "Hz", .min = 0.0, .max = 10000.0, .min_exclusive = true, .doc = "camera frame rate"});
  s.fmt.format = hal::pixel_format_from_string(
      p.get<std::string>("format", "bgr8", {.choices = {"mono8", "bgr8"}, .doc = "camera pixel format"}));
  s.fmt.width = p.get<int>("width", 640, {.unit = "px", .min = 64, .max = 4096, .doc = "image width"});
  s.fmt.height = p.get<int>("height", 480, {.unit = "px", .min = 64, .max = 4096, .doc = "image height"});
  s.frames = p.get<int>("frames", 50, {.min = 1, .max = 10000, .doc = "frames rendered at configure"});
  detail::check_preload(p, "frames", static_cast<std::uint64_t>(s.frames), {s.fmt.width, s.fmt.height},
                        s.fmt.format == hal::PixelFormat::kBgr8 ? 3 : 1);
  s.loop = p.get<bool>("loop", true, {.doc = "repeat the frames (angles repeat too); else the last one stays"});
  s.sample_rate_hz = read_sample_rate(p, "encoder report rate");
  s.max_extrapolation = read_max_extrapolation(p);
  s.wheel = p.get<std::string>("wheel", "wheel", {.doc = "wheel name reported by the encoders"});
  s.motion = ScriptedMotion::from_params(p, ctx, {s.wheel});
  if (s.motion.wheels().size() != 1) p.fail("profile_csv", "the wheel scene needs exactly one wheel column");
  s.sinkage_mm =
      p.get<double>("sinkage_mm", 20.0,
                    {.unit = "mm", .min = 0.0, .max = 1000.0, .doc = "depth of the deepest leg tip below the soil"});
  s.scene.size = cv::Size(s.fmt.width, s.fmt.height);
  s.scene.seed = static_cast<std::uint32_t>(p.get<int>("seed", 1, {.min = 0, .doc = "texture / noise seed"}));
  s.scene.misalignment_rad = p.get<double>(
      "misalignment_rad", 0.0, {.unit = "rad", .min = -3.2, .max = 3.2, .doc = "true legs minus encoder prediction"});
  const std::string light =
      p.get<std::string>("illumination", "normal", {.choices = {"normal", "poor"}, .doc = "lighting preset"});
  s.scene.light = light == "poor" ? wheel_scene::Illumination::poor() : wheel_scene::Illumination::normal();
  // Keep the wheel geometry proportional to the image (defaults are for 640 x 480).
  const double k = s.fmt.width / 640.0;
  s.scene.wheel.hub_center_px = {s.fmt.width / 2.0, s.fmt.height * 110.0 / 480.0};
  s.scene.wheel.leg_length_px *= k;
  s.scene.wheel.leg_width_px *= k;
  s.scene.wheel.hub_radius_px *= k;
  s.scene.wheel.foot_width_px *= k;
  s.scene.wheel.foot_thickness_px *= k;
  s.scene.wheel.mm_per_px /= k;
  try {
    s.scene.validate();
  } catch (const std::invalid_argument& e) {
    p.fail({}, std::string("invalid wheel scene: ") + e.what());
  }
  if (s.loop) {
    const double turn = s.motion.angle(0, s.frames / s.fmt.rate_hz) - s.motion.angle(0, 0.0);
    const double spacing = 2.0 * 3.14159265358979323846 / s.scene.wheel.leg_count;
    if (turn != 0.0 && std::abs(turn / spacing - std::round(turn / spacing)) < 1e-6) s.turn_per_loop = turn;
  }
  return s;
}

class SyntheticWheelEncoders final : public LazyEncoders {
 public:
  SyntheticWheelEncoders(const hal::DeviceContext& ctx, WheelSpec spec)
      : LazyEncoders(ctx, {spec.wheel}, spec.max_extrapolation), spec_(std::move(spec)), grid_(spec_.sample_rate_hz) {}

 protected:
  std::int64_t index_at(std::size_t, TimeNs rel) const override { return grid_.index(rel); }
  hal::AngleSample sample(std::size_t, std::int64_t g) const override {
    const TimeNs stamp = grid_.offset(g);
    const double t = to_seconds(stamp);
    const double loops = spec_.loop ? std::floor(t * spec_.fmt.rate_hz / spec_.frames) : 0.0;
    return {stamp, spec_.motion.angle(0, spec_.scene_time(t)) + loops * spec_.turn_per_loop};
  }

 private:
  WheelSpec spec_;
  TimeGrid grid_;
};

}  // namespace
}  // namespace detail

std::unique_ptr<hal::Camera> make_synthetic_wheel_camera(Params& p, const hal::DeviceContext& ctx) {
  const detail::WheelSpec spec = detail::read_spec(p, ctx);
  std::vector<cv::Mat> images;
  try {
    wheel_scene::WheelSceneGenerator gen(spec.scene);
    if (!ctx.open_devices) {  // `config check`: parameters validated, nothing rendered
      images.emplace_back(spec.fmt.height, spec.fmt.width, hal::cv_type(spec.fmt.format), cv::Scalar::all(0));
      return std::make_unique<detail::PreloadedCamera>(ctx, spec.fmt, std::move(images), spec.loop);
    }
    for (int k = 0; k < spec.frames; ++k) {
      cv::Mat bgr;
      gen.render_with_sinkage(spec.motion.angle(0, k / spec.fmt.rate_hz), spec.sinkage_mm, bgr);
      if (spec.fmt.format == hal::PixelFormat::kMono8) {
        cv::Mat gray;
        cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
        bgr = gray;
      }
      images.push_back(bgr.isContinuous() ? bgr : bgr.clone());
    }
  } catch (const std::invalid_argument& e) {
    p.fail({}, std::string("invalid wheel scene: ") + e.what());
  }
  return std::make_unique<detail::PreloadedCamera>(ctx, spec.fmt, std::move(images), spec.loop);
}

std::unique_ptr<hal::WheelEncoders> make_synthetic_wheel_encoders(Params& p, const hal::DeviceContext& ctx) {
  return std::make_unique<detail::SyntheticWheelEncoders>(ctx, detail::read_spec(p, ctx));
}

}  // namespace regolith::mocks
