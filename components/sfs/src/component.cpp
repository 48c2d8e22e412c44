// Component "sfs": camera frame -> grey -> vignetting correction -> shape from shading -> shared
// DTM ("terrain/dtm"). Everything is sized in configure(); step() reuses the buffers.
#include "regolith/sfs/component.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "regolith/hal/camera.hpp"
#include "regolith/runtime/application.hpp"

namespace regolith::sfs {

direct_depth::CameraModel read_camera_model(Params p, int width, int height) {
  direct_depth::CameraModel m;
  m.width = p.get<int>("width", width, {.unit = "px", .min = 8, .max = 16384, .doc = "image width (must match the camera)"});
  m.height = p.get<int>("height", height, {.unit = "px", .min = 8, .max = 16384, .doc = "image height (must match the camera)"});
  if (m.width != width || m.height != height)
    p.fail("width", "camera_model is " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                        " px but the image is " + std::to_string(width) + "x" + std::to_string(height) + " px");
  m.fx = p.require<double>("fx", {.unit = "px", .min = 0.0, .min_exclusive = true, .doc = "focal length x"});
  m.fy = p.get<double>("fy", m.fx, {.unit = "px", .min = 0.0, .min_exclusive = true,
                                    .doc = "focal length y (default fx)"});
  m.cx = p.get<double>("cx", 0.5 * (width - 1), {.unit = "px", .doc = "principal point column (default centre)"});
  m.cy = p.get<double>("cy", 0.5 * (height - 1), {.unit = "px", .doc = "principal point row (default centre)"});
  m.k1 = p.get<double>("k1", 0.0, {.doc = "radial distortion (OpenCV model)"});
  m.k2 = p.get<double>("k2", 0.0, {.doc = "radial distortion (OpenCV model)"});
  m.p1 = p.get<double>("p1", 0.0, {.doc = "tangential distortion (OpenCV model)"});
  m.p2 = p.get<double>("p2", 0.0, {.doc = "tangential distortion (OpenCV model)"});
  m.k3 = p.get<double>("k3", 0.0, {.doc = "radial distortion (OpenCV model)"});
  m.mount_height_m = p.require<double>("mount_height_m", {.unit = "m", .min = 0.0, .min_exclusive = true,
                                                         .doc = "optical centre above the ground"});
  m.pitch_rad = p.get<double>("pitch_rad", 0.0, {.unit = "rad", .min = -1.5707, .max = 1.5707,
                                                 .doc = "optical axis below the horizontal (down positive)"});
  m.roll_rad = p.get<double>("roll_rad", 0.0, {.unit = "rad", .min = -1.5707, .max = 1.5707,
                                               .doc = "rotation about the optical axis"});
  p.finish();
  try {
    m.validate();
  } catch (const FieldError& e) {
    p.fail(e);
  }
  return m;
}

namespace {

class SfsComponent final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    cam_ = &ctx.camera(p, "camera");
    const hal::CameraFormat fmt = cam_->format();
    size_ = cv::Size(fmt.width, fmt.height);

    SfsParams sp;
    // Default Tsai-Shah (marching): the only method whose per-frame solve does no heap allocation
    // (cv::dft inside Pentland allocates), as step() requires.
    const std::string method = p.get<std::string>(
        "method", "tsai_shah",
        {.choices = {"tsai_shah", "pentland", "bichsel_pentland"}, .doc = "shape-from-shading method"});
    sp.method = method_from_string(method);
    sp.iterations = p.get<int>("iterations", sp.iterations, {.min = 1, .max = 100000,
                                                            .doc = "max iterations (Tsai-Shah, Bichsel-Pentland)"});
    sp.tolerance = p.get<double>("tolerance", sp.tolerance, {.unit = "px", .min = 0.0,
                                                            .doc = "stop when the mean |dZ| per iteration is below"});
    sp.saturation_level = p.get<double>("saturation_level", sp.saturation_level,
                                        {.min = 0.0, .max = 1.0, .min_exclusive = true,
                                         .doc = "normalised brightness at/above which a pixel is masked"});
    sp.shadow_level = p.get<double>("shadow_level", sp.shadow_level,
                                    {.min = 0.0, .max = 1.0, .doc = "normalised brightness at/below which a pixel is masked"});
    const std::string source = p.get<std::string>(
        "light_source", "config",
        {.choices = {"config", "estimate"},
         .doc = "config: sun_slant_rad/sun_tilt_rad (camera image frame); estimate: moment estimator"});
    if (source == "config") {
      LightDirection l;
      l.slant_rad = p.require<double>("sun_slant_rad", {.unit = "rad",
          .doc = "sun angle from the line of sight back to the camera, [0, pi/2)"});
      l.tilt_rad = p.require<double>("sun_tilt_rad", {.unit = "rad",
          .doc = "sun direction in the image from +x (columns) towards +y (rows)"});
      try {
        l.validate("sun");
      } catch (const std::invalid_argument& e) {
        p.fail("sun_slant_rad", std::string(e.what()) + " (sun at or below the image plane)");
      }
      light_ = l;
    } else {
      sp.estimate_light = true;
      sp.min_light_confidence = p.get<double>("min_light_confidence", sp.min_light_confidence,
                                              {.min = 0.0, .max = 1.0,
                                               .doc = "estimates below this confidence are rejected (frame skipped)"});
    }
    sp.vignetting.a2 = p.get<double>("vignetting_a2", 0.0, {.doc = "radial vignetting V(r) = 1 + a2 r^2 + a4 r^4 + a6 r^6"});
    sp.vignetting.a4 = p.get<double>("vignetting_a4", 0.0, {.doc = "see vignetting_a2"});
    sp.vignetting.a6 = p.get<double>("vignetting_a6", 0.0, {.doc = "see vignetting_a2"});
    const std::string flat = p.get<std::string>("flat_field", "", {.doc = "flat-field image (overrides the polynomial); relative to the config file"});
    if (!flat.empty()) {
      std::filesystem::path fp(flat);
      if (fp.is_relative() && !ctx.config_dir().empty()) fp = std::filesystem::path(ctx.config_dir()) / fp;
      cv::Mat ff = cv::imread(fp.string(), cv::IMREAD_GRAYSCALE);
      if (ff.empty()) p.fail("flat_field", "cannot read image '" + fp.string() + "'");
      sp.vignetting.flat_field = ff;
    }
    sp.vignetting.enabled = !flat.empty() || sp.vignetting.a2 != 0.0 || sp.vignetting.a4 != 0.0 ||
                            sp.vignetting.a6 != 0.0;
    if (p.has("camera_model")) {
      model_ = std::make_unique<direct_depth::CameraModel>(read_camera_model(p.child("camera_model"), fmt.width, fmt.height));
    }
    try {
      sfs_ = std::make_unique<ShapeFromShading>(sp);
    } catch (const FieldError& e) {
      p.fail(e);
    }
    input_ = &watch_input("camera", from_seconds(2.0 / std::max(0.1, fmt.rate_hz)) + kNsPerSec);

    // Allocate every buffer now: a warm-up solve on a shaded synthetic frame of the right size.
    gray_.create(size_, CV_8U);
    for (int r = 0; r < size_.height; ++r)
      for (int c = 0; c < size_.width; ++c)
        gray_.at<uchar>(r, c) = static_cast<uchar>(120 + 40 * std::sin(0.05 * c) * std::cos(0.07 * r));
    sfs_->compute(gray_, light_ ? light_ : std::optional<LightDirection>(LightDirection{0.5, 0.5}), res_);
    const cv::Size sz = size_;
    const direct_depth::CameraModel* model = model_.get();
    out_ = &ctx.channel<DtmFrame>(kDtmChannel, 4, [sz, model] {
      DtmFrame f;
      f.gray.create(sz, CV_8U);
      f.height.create(sz, CV_32F);
      f.valid.create(sz, CV_8U);
      f.camera = model;
      return f;
    });
  }

  void step(const runtime::CycleInfo& c) override {
    hal::FrameLease lease;
    if (!cam_->latest(c.now, lease)) return;
    const hal::Frame& fr = *lease;
    if (have_last_ && fr.sequence == last_seq_) return;
    have_last_ = true;
    last_seq_ = fr.sequence;
    input_updated(*input_, c.now);
    if (fr.corrupt || fr.image.empty() || fr.image.size() != size_ ||
        (fr.image.type() != CV_8UC1 && fr.image.type() != CV_8UC3)) {
      count_error();
      set_status(fr.corrupt ? "corrupt frame skipped" : "frame size/type differs from the camera format");
      return;
    }
    try {
      if (fr.image.type() == CV_8UC3) cv::cvtColor(fr.image, gray_, cv::COLOR_BGR2GRAY);
      else fr.image.copyTo(gray_);
      sfs_->compute(gray_, light_, res_);
    } catch (const std::runtime_error&) {
      count_error();
      set_status("light estimate unreliable: frame skipped");
      return;
    } catch (const std::exception&) {
      count_error();
      set_status("shape from shading failed on this frame");
      return;
    }
    DtmFrame* d = out_->begin_write();
    if (d == nullptr) return;
    gray_.copyTo(d->gray);
    res_.height.copyTo(d->height);
    res_.valid.copyTo(d->valid);
    d->light = res_.light;
    d->light_estimated = res_.light_estimated;
    d->light_confidence = res_.light_confidence;
    d->iterations = res_.iterations;
    d->final_mean_update = res_.final_mean_update;
    d->stamp = fr.capture_time;
    d->sequence = fr.sequence;
    d->camera = model_.get();
    out_->commit();
    set_status("ok");
  }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    kv.emplace_back("method", to_string(sfs_->params().method));
    kv.emplace_back("light_source", light_ ? "config" : "estimate");
  }

 private:
  hal::Camera* cam_ = nullptr;
  cv::Size size_;
  std::unique_ptr<ShapeFromShading> sfs_;
  std::optional<LightDirection> light_;
  std::unique_ptr<direct_depth::CameraModel> model_;
  cv::Mat gray_;
  SfsResult res_;
  LatestPool<DtmFrame>* out_ = nullptr;
  runtime::InputWatch* input_ = nullptr;
  bool have_last_ = false;
  std::uint64_t last_seq_ = 0;
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "sfs", "camera frame -> vignetting correction -> shape from shading -> shared DTM (terrain/dtm)",
      [] { return std::make_unique<SfsComponent>(); });
}

}  // namespace regolith::sfs
