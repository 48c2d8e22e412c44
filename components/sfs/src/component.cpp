// Component "sfs": camera frame -> grey -> vignetting correction -> shape from shading -> shared
// DTM ("terrain/dtm"). Everything is sized in configure(); step() reuses the buffers.
#include "regolith/sfs/component.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/camera.hpp"
#include "regolith/core/frame_order.hpp"
#include "regolith/core/image_limits.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/input_timeout.hpp"
#include "regolith/sfs/flat_field.hpp"

namespace regolith::sfs {

direct_depth::CameraModel read_camera_model(Params p, int width, int height) {
  direct_depth::CameraModel m;
  m.width = p.get<int>("width", width,
                       {.unit = "px", .min = 8, .max = kMaxImageSidePx, .doc = "image width (must match the camera)"});
  m.height =
      p.get<int>("height", height,
                 {.unit = "px", .min = 8, .max = kMaxImageSidePx, .doc = "image height (must match the camera)"});
  if (m.width != width || m.height != height)
    p.fail("width", "camera_model is " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                        " px but the image is " + std::to_string(width) + "x" + std::to_string(height) + " px");
  m.fx = p.require<double>("fx", {.unit = "px", .min = 0.0, .min_exclusive = true, .doc = "focal length x"});
  m.fy = p.get<double>("fy", m.fx,
                       {.unit = "px", .min = 0.0, .min_exclusive = true, .doc = "focal length y (default fx)"});
  m.cx = p.get<double>("cx", 0.5 * (width - 1), {.unit = "px", .doc = "principal point column (default centre)"});
  m.cy = p.get<double>("cy", 0.5 * (height - 1), {.unit = "px", .doc = "principal point row (default centre)"});
  m.k1 = p.get<double>("k1", 0.0, {.doc = "radial distortion (OpenCV model)"});
  m.k2 = p.get<double>("k2", 0.0, {.doc = "radial distortion (OpenCV model)"});
  m.p1 = p.get<double>("p1", 0.0, {.doc = "tangential distortion (OpenCV model)"});
  m.p2 = p.get<double>("p2", 0.0, {.doc = "tangential distortion (OpenCV model)"});
  m.k3 = p.get<double>("k3", 0.0, {.doc = "radial distortion (OpenCV model)"});
  m.mount_height_m = p.require<double>(
      "mount_height_m", {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "optical centre above the ground"});
  m.pitch_rad = p.get<double>(
      "pitch_rad", 0.0,
      {.unit = "rad", .min = -1.5707, .max = 1.5707, .doc = "optical axis below the horizontal (down positive)"});
  m.roll_rad = p.get<double>("roll_rad", 0.0,
                             {.unit = "rad", .min = -1.5707, .max = 1.5707, .doc = "rotation about the optical axis"});
  p.finish_and_check([&] { m.validate(); });
  return m;
}

namespace {

class SfsComponent final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    ctx_ = &ctx;
    cam_ = &ctx.camera(p, "camera");
    const hal::CameraFormat fmt = cam_->format();
    size_ = cv::Size(fmt.width, fmt.height);

    SfsParams sp;
    // Default Pentland: the most accurate per millisecond (README "Choice of default"); its FFTW
    // plans are made on the first frame, so a warm solve does not allocate, like Tsai-Shah.
    const std::string method = p.get<std::string>(
        "method", "pentland",
        {.choices = {"tsai_shah", "pentland", "bichsel_pentland"}, .doc = "shape-from-shading method"});
    sp.method = method_from_string(method);
    sp.iterations = p.get<int>("iterations", sp.iterations,
                               {.min = 1, .max = 100000, .doc = "max iterations (Tsai-Shah, Bichsel-Pentland)"});
    sp.tolerance = p.get<double>("tolerance", sp.tolerance,
                                 {.unit = "px", .min = 0.0, .doc = "stop when the mean |dZ| per iteration is below"});
    sp.saturation_level = p.get<double>("saturation_level", sp.saturation_level,
                                        {.min = 0.0,
                                         .max = 1.0,
                                         .min_exclusive = true,
                                         .doc = "normalised brightness at/above which a pixel is masked"});
    sp.shadow_level =
        p.get<double>("shadow_level", sp.shadow_level,
                      {.min = 0.0, .max = 1.0, .doc = "normalised brightness at/below which a pixel is masked"});
    const std::string moved_sun =
        "the deployment has one sun: a top-level `sun: {azimuth_deg, elevation_deg}` "
        "block, converted into this camera's image frame with its mount (light_source: sun)";
    p.reject_moved("sun_slant_rad", moved_sun);
    p.reject_moved("sun_tilt_rad", moved_sun);
    p.reject_moved("camera_model", "the camera is described once, in rover.cameras.<camera> {camera_info, mount}");
    if (p.has("light_source") && p.node()["light_source"].Scalar() == "config")
      p.fail("light_source", "`config` (sun_slant_rad/sun_tilt_rad) is replaced by `sun`: " + moved_sun);
    const std::string source = p.get<std::string>("light_source", "sun",
                                                  {.choices = {"sun", "estimate"},
                                                   .doc = "sun: the deployment sun in this camera's frame (needs "
                                                          "rover.cameras.<camera>); estimate: moment estimator"});
    // The camera's calibration and mount (rover.cameras.<camera>): required for the sun, optional
    // with an estimated light (then the DTM carries no camera model).
    const RoverCamera* rc = ctx.rover().camera(p.node()["camera"].Scalar());
    if (source == "sun" || rc != nullptr) rc = &ctx.rover_camera(p, "camera");
    if (rc != nullptr) {
      model_ = std::make_unique<direct_depth::CameraModel>(
          common::camera_model_for_frames(*rc, fmt.width, fmt.height, p, "camera"));
    }
    if (source == "sun") {
      camera_ = rc;
      sun_ = &ctx.sun(p, "sfs light_source sun");
      imu_ = ctx.attitude_imu();  // per frame: the body attitude at the capture time
      // Level until the first frame: devices start after configure; with an IMU each frame is
      // converted through the attitude at its capture time (step).
      const common::CameraLight cl = common::camera_light(*sun_, *rc);
      light_ = cl.light;
      sun_in_view_ = cl.in_view;
    } else {
      sp.estimate_light = true;
      sp.min_light_confidence = p.get<double>(
          "min_light_confidence", sp.min_light_confidence,
          {.min = 0.0, .max = 1.0, .doc = "estimates below this confidence are rejected (frame skipped)"});
    }
    sp.vignetting.a2 =
        p.get<double>("vignetting_a2", 0.0, {.doc = "radial vignetting V(r) = 1 + a2 r^2 + a4 r^4 + a6 r^6"});
    sp.vignetting.a4 = p.get<double>("vignetting_a4", 0.0, {.doc = "see vignetting_a2"});
    sp.vignetting.a6 = p.get<double>("vignetting_a6", 0.0, {.doc = "see vignetting_a2"});
    const std::string flat = p.get<std::string>(
        "flat_field", "", {.doc = "flat-field image (overrides the polynomial); relative to the config file"});
    if (!flat.empty()) {
      std::filesystem::path fp(flat);
      if (fp.is_relative() && !ctx.config_dir().empty()) fp = std::filesystem::path(ctx.config_dir()) / fp;
      cv::Mat ff;
      if (const std::string why = read_flat_field(fp.string(), ff); !why.empty())
        p.fail("flat_field", "'" + fp.string() + "': " + why);
      sp.vignetting.flat_field = ff;
    }
    sp.vignetting.enabled =
        !flat.empty() || sp.vignetting.a2 != 0.0 || sp.vignetting.a4 != 0.0 || sp.vignetting.a6 != 0.0;
    try {
      sfs_ = std::make_unique<ShapeFromShading>(sp);
      quarter_sfs_ = std::make_unique<ShapeFromShading>(sp);  // same model on the frame reduced 4x
    } catch (const FieldError& e) {
      p.fail(e);
    }
    if (size_.width < 4 * kMinQuarterSide || size_.height < 4 * kMinQuarterSide)
      quarter_sfs_.reset();  // too small to reduce: quarter-resolution readers get the full solve
    const TimeNs timeout = runtime::read_input_timeout(p, fmt.rate_hz, 1.0);
    input_ = &watch_input("camera", timeout);
    order_ = FrameOrder(timeout);

    gray_.create(size_, CV_8U);
    const cv::Size sz = size_;
    const direct_depth::CameraModel* model = model_.get();
    out_ = &ctx.produce<DtmFrame>(kDtmChannel, 4, [sz, model] {
      DtmFrame f;
      f.gray.create(sz, CV_8U);
      f.height.create(sz, CV_32F);
      f.valid.create(sz, CV_8U);
      f.height4.create(sz.height / 4, sz.width / 4, CV_32F);
      f.valid4.create(sz.height / 4, sz.width / 4, CV_8U);
      fill_invalid(f.height, f.valid);
      fill_invalid(f.height4, f.valid4);
      f.camera = model;
      return f;
    });
  }

  void activate() override {
    // Every consumer has declared what it reads by now. Nobody reads the heights (e.g.
    // traversability on its ground grid, the preview): with the sun given, the full-frame solve is
    // skipped and the grey image and the sun go out alone. An estimated sun needs the solve.
    const bool full = ctx_->wanted(kDtmChannel, common::kDtmHeight);
    const bool quarter = ctx_->wanted(kDtmChannel, common::kDtmHeightQuarter);
    heights_wanted_ = full || quarter;
    level_ = !full && quarter && quarter_sfs_ ? 2 : 0;
    // Allocate the buffers of the one solve this deployment runs (none when nothing reads heights
    // and the sun is given) before the first cycle: a warm-up solve on a shaded synthetic frame
    // of the right size. The other level's solver is dropped.
    for (int r = 0; r < size_.height; ++r)
      for (int c = 0; c < size_.width; ++c)
        gray_.at<uchar>(r, c) = static_cast<uchar>(120 + 40 * std::sin(0.05 * c) * std::cos(0.07 * r));
    const std::optional<LightDirection> warm =
        light_ && sun_in_view_ ? light_ : std::optional<LightDirection>(LightDirection{0.5, 0.5});
    if (level_ == 2) {  // a quarter-resolution reader: always solved
      quarter_gray_.create(size_.height / 4, size_.width / 4, CV_8U);
      reduce4(gray_, quarter_gray_);
      quarter_sfs_->compute(quarter_gray_, warm, quarter_res_);
    } else {
      quarter_sfs_.reset();
      if (heights_wanted_ || !light_) sfs_->compute(gray_, warm, res_);
    }
  }

  void step(const runtime::CycleInfo& c) override {
    hal::FrameLease lease;
    if (!cam_->latest(c.now, lease)) return;
    const hal::Frame& fr = *lease;
    if (!new_frame_(fr.sequence)) return;
    if (order_.admit(fr.capture_time) == FrameOrder::Verdict::kOutOfOrder) {
      set_status("frame stamped at or before the last one solved (the camera clock stepped back): skipped");
      return;
    }
    if (imu_ != nullptr) {  // the sun in the image frame for the body's attitude at capture time
      Attitude a;
      if (imu_->attitude_at(fr.capture_time, a)) {
        const common::CameraLight cl = common::camera_light(*sun_, *camera_, a);
        light_ = cl.light;
        sun_in_view_ = cl.in_view;
      }
    }
    input_updated(*input_, c.now);
    if (fr.corrupt || fr.image.empty() || fr.image.size() != size_ ||
        (fr.image.type() != CV_8UC1 && fr.image.type() != CV_8UC3)) {
      count_error();
      set_status(fr.corrupt ? "corrupt frame skipped" : "frame size/type differs from the camera format");
      return;
    }
    // Size and type are checked above and the light at configure: nothing here throws. A grey
    // frame is read where the lease holds it (copied once, into the DTM slot, below).
    if (fr.image.type() == CV_8UC3) cv::cvtColor(fr.image, gray_, cv::COLOR_BGR2GRAY);
    const cv::Mat& gray = fr.image.type() == CV_8UC3 ? gray_ : fr.image;
    const bool solve = !light_ || (sun_in_view_ && heights_wanted_);
    // The solve of this level: the full frame's, or the reduced frame's (level 2).
    const SfsResult& res = level_ == 2 ? quarter_res_ : res_;
    if (solve && level_ == 2) {
      reduce4(gray, quarter_gray_);
      quarter_sfs_->compute(quarter_gray_, light_, quarter_res_);
    } else if (solve) {
      sfs_->compute(gray, light_, res_);
    }
    if (solve && res.status == SfsStatus::kUnreliableLight) {
      count_error();
      set_status("light estimate unreliable: frame skipped");
      return;
    }
    DtmFrame* d = out_->begin_write();
    if (d == nullptr) return;
    gray.copyTo(d->gray);
    const bool slot_was_solved = d->solved;  // what this slot held from its last write
    d->solved = solve;
    d->height_level = solve ? level_ : 0;
    if (solve && level_ == 2) {
      quarter_res_.height.convertTo(d->height4, CV_32F, 4.0);  // heights in the frame's pixel units
      quarter_res_.valid.copyTo(d->valid4);
      d->light = res.light;
    } else if (solve) {
      res_.height.copyTo(d->height);
      res_.valid.copyTo(d->valid);
      d->light = res.light;
    } else {                  // sun ahead of the camera or no reader of heights: the grey image and sun still go out
      if (slot_was_solved) {  // a slot last written unsolved is NaN / 0 already
        fill_invalid(d->height, d->valid);
        fill_invalid(d->height4, d->valid4);
      }
      d->light = *light_;
    }
    d->light_estimated = res.light_estimated;
    d->light_confidence = res.light_confidence;
    d->iterations = res.iterations;
    d->final_mean_update = res.final_mean_update * (1 << level_);  // px of the frame
    d->stamp = fr.capture_time;
    d->sequence = fr.sequence;
    d->camera = model_.get();
    out_->commit();
    set_status(solve          ? "ok"
               : sun_in_view_ ? "no consumer reads the DTM heights: SfS not run (grey image and sun published)"
                              : "sun ahead of the camera: no image-frame SfS (ground-frame consumers only)");
  }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    kv.emplace_back("method", to_string(sfs_->params().method));
    kv.emplace_back("light_source", light_ ? "sun" : "estimate");
    kv.emplace_back("solve_resolution", !heights_wanted_ ? "none (no reader of heights)"
                                        : level_ == 2    ? "quarter"
                                                         : "full");
    kv.emplace_back("frames_out_of_order", std::to_string(order_.out_of_order()));
    kv.emplace_back("clock_steps", std::to_string(order_.clock_steps()));
  }

  std::string result() const override {
    const auto l = out_ != nullptr ? out_->acquire() : decltype(out_->acquire()){};
    if (!l) return {};
    constexpr double kDeg = 180.0 / 3.14159265358979323846;
    char buf[128];
    if (!l->solved && !heights_wanted_) {
      std::snprintf(buf, sizeof buf, "no DTM solved: no consumer reads its heights (grey image and sun published)");
    } else if (!l->solved) {
      std::snprintf(buf, sizeof buf, "no DTM: sun ahead of the camera (slant %.0f deg)", l->light.slant_rad * kDeg);
    } else {
      // The level that was solved: the full frame, or its quarter (height4 / valid4).
      const bool quarter = l->height_level == 2;
      const cv::Mat& h = quarter ? l->height4 : l->height;
      const cv::Mat& v = quarter ? l->valid4 : l->valid;
      const double valid = 100.0 * cv::countNonZero(v) / static_cast<double>(std::max<std::size_t>(1, v.total()));
      std::snprintf(buf, sizeof buf, "DTM %dx%d%s, %.0f %% valid, sun slant %.0f tilt %.0f deg%s", h.cols, h.rows,
                    quarter ? " (quarter resolution)" : "", valid, l->light.slant_rad * kDeg, l->light.tilt_rad * kDeg,
                    l->light_estimated ? " (estimated)" : "");
    }
    return buf;
  }

 private:
  static constexpr int kMinQuarterSide = 16;  ///< px, smallest side of a reduced frame worth solving

  /// dst (CV_8U, src / 4 in each direction, allocated) = the mean of each 4x4 block of src.
  static void reduce4(const cv::Mat& src, cv::Mat& dst) {
    for (int r = 0; r < dst.rows; ++r) {
      uchar* q = dst.ptr<uchar>(r);
      for (int c = 0; c < dst.cols; ++c) {
        int sum = 0;
        for (int i = 0; i < 4; ++i) {
          const uchar* p = src.ptr<uchar>(4 * r + i) + 4 * c;
          sum += p[0] + p[1] + p[2] + p[3];
        }
        q[c] = static_cast<uchar>((sum + 8) / 16);
      }
    }
  }

  // NaN height, no valid pixel, by loop (Mat::setTo with a scalar allocates).
  static void fill_invalid(cv::Mat& height, cv::Mat& valid) {
    for (int r = 0; r < height.rows; ++r) {
      float* h = height.ptr<float>(r);
      uchar* v = valid.ptr<uchar>(r);
      for (int c = 0; c < height.cols; ++c) {
        h[c] = std::numeric_limits<float>::quiet_NaN();
        v[c] = 0;
      }
    }
  }

  hal::Camera* cam_ = nullptr;
  cv::Size size_;
  std::unique_ptr<ShapeFromShading> sfs_;
  std::unique_ptr<ShapeFromShading> quarter_sfs_;  ///< the same model on the frame reduced 4x (null: frame too small)
  cv::Mat quarter_gray_;
  SfsResult quarter_res_;
  int level_ = 0;  ///< 2: only quarter-resolution readers (activate()): solve on the reduced frame
  std::optional<LightDirection> light_;  ///< empty: estimated per frame
  bool sun_in_view_ = true;              ///< false: the sun is ahead of the camera (slant >= 90 deg)
  bool heights_wanted_ = true;           ///< a consumer reads the DTM heights (activate())
  runtime::Context* ctx_ = nullptr;
  const RoverCamera* camera_ = nullptr;
  const Sun* sun_ = nullptr;
  const hal::Imu* imu_ = nullptr;  ///< rover.imu: attitude per frame (null: level)
  std::unique_ptr<direct_depth::CameraModel> model_;
  cv::Mat gray_;
  SfsResult res_;
  LatestPool<DtmFrame>* out_ = nullptr;
  runtime::InputWatch* input_ = nullptr;
  NewValue new_frame_;
  FrameOrder order_;  ///< the DTM stream never goes back in time (input timeout as limit)
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "sfs", "camera frame -> vignetting correction -> shape from shading -> shared DTM (terrain/dtm)",
      [] { return std::make_unique<SfsComponent>(); });
}

}  // namespace regolith::sfs
