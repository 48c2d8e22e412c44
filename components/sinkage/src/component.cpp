// Component "wheel_sinkage": camera frame + wheel angle at the frame's capture time -> sinkage
// estimator -> channel / DDS terrain/wheel_sinkage; optional overlay PNGs and bench-rig CSV log
// written by a non-real-time writer thread. Everything is sized in configure(); step() does not
// allocate, lock, format strings or block.
#include "regolith/sinkage/component.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "regolith/core/channels.hpp"
#include "regolith/core/frame_order.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/context.hpp"
#include "regolith/runtime/input_timeout.hpp"
#include "regolith/sinkage/bench_log.hpp"

namespace regolith::sinkage {

const char* to_string(EncoderProblem p) {
  switch (p) {
    case EncoderProblem::kNone: return "none";
    case EncoderProblem::kMissing: return "missing_encoder";
    case EncoderProblem::kStale: return "stale_encoder";
    case EncoderProblem::kNoAngle: return "no_encoder_angle";
  }
  return "?";
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Relocates a validate() FieldError ("WheelGeometry.hub_center_px.x: ...") at its key in `p`.
[[noreturn]] void fail_validation(Params& p, const FieldError& e) {
  if (e.field() == "mode") p.fail("segmentation", e.problem());  // SinkageParams.mode is read from `segmentation`
  p.fail(e);
}

WheelGeometry read_geometry(Params g) {
  WheelGeometry w;
  const auto hub = g.require<std::vector<double>>(
      "hub_center_px", {.unit = "px", .doc = "[x, y] centre of rotation of the wheel in the image"});
  if (hub.size() != 2) g.fail("hub_center_px", "expected [x, y] (got " + std::to_string(hub.size()) + " values)");
  w.hub_center_px = {hub[0], hub[1]};
  w.leg_count = g.get<int>("leg_count", w.leg_count,
                           {.min = 1, .max = static_cast<double>(kMaxLegs), .doc = "legs on the wheel"});
  w.leg_spacing_rad = g.get<double>("leg_spacing_rad", 2.0 * 3.14159265358979323846 / w.leg_count,
                                    {.unit = "rad",
                                     .min = 0.0,
                                     .min_exclusive = true,
                                     .doc = "angle between neighbouring legs (default 2 pi / leg_count)"});
  w.leg_length_px = g.require<double>(
      "leg_length_px", {.unit = "px", .min = 0.0, .min_exclusive = true, .doc = "hub centre to leg tip (thesis plz)"});
  w.leg_width_px = g.require<double>(
      "leg_width_px", {.unit = "px", .min = 0.0, .min_exclusive = true, .doc = "width of the leg shaft"});
  w.hub_radius_px = g.get<double>("hub_radius_px", w.hub_radius_px,
                                  {.unit = "px", .min = 0.0, .doc = "legs are visible from this radius outwards"});
  w.foot_width_px = g.get<double>("foot_width_px", w.foot_width_px,
                                  {.unit = "px", .min = 0.0, .doc = "foot width across the leg axis (0 = no foot)"});
  w.foot_thickness_px = g.get<double>("foot_thickness_px", w.foot_thickness_px,
                                      {.unit = "px", .min = 0.0, .doc = "foot extent along the axis from the tip"});
  w.angle_offset_rad = g.get<double>(
      "angle_offset_rad", 0.0,
      {.unit = "rad", .doc = "image angle of leg 0 (from straight down towards +x) when the encoder reads 0"});
  w.rotation_direction = g.get<int>(
      "rotation_direction", 1, {.min = -1, .max = 1, .doc = "+1 or -1: sign of the encoder angle in the image angle"});
  try {
    w.validate();
  } catch (const FieldError& e) {
    fail_validation(g, e);
  }
  g.finish();
  return w;
}

}  // namespace

AlgorithmConfig read_algorithm_config(Params& p) {
  AlgorithmConfig a;
  a.geometry = read_geometry(p.require_child("geometry"));
  SinkageParams& s = a.params;
  s.hue_min_deg =
      p.get<double>("hue_min_deg", s.hue_min_deg,
                    {.unit = "deg", .min = 0.0, .max = 360.0, .doc = "HSV hue band of the leg paint, lower end"});
  s.hue_max_deg =
      p.get<double>("hue_max_deg", s.hue_max_deg,
                    {.unit = "deg", .min = 0.0, .max = 360.0, .doc = "upper end (band wraps when min > max)"});
  s.sat_min = p.get<double>("sat_min", s.sat_min, {.min = 0.0, .max = 1.0, .doc = "minimum HSV saturation"});
  s.val_min = p.get<double>("val_min", s.val_min, {.min = 0.0, .max = 1.0, .doc = "minimum HSV value"});
  const std::string mode =
      p.get<std::string>("segmentation", "auto",
                         {.choices = {"hsv", "adaptive", "auto"},
                          .doc = "hsv band, adaptive (Otsu on blue chroma), auto (adaptive in poor light)"});
  s.mode = mode == "hsv"        ? SegmentationMode::kHsv
           : mode == "adaptive" ? SegmentationMode::kAdaptive
                                : SegmentationMode::kAuto;
  s.dark_mean_value = p.get<double>(
      "dark_mean_value", s.dark_mean_value,
      {.min = 0.0, .max = 1.0, .doc = "auto: mean V in the mask below which the adaptive threshold is used"});
  s.adaptive_min_separation = p.get<double>(
      "adaptive_min_separation", s.adaptive_min_separation,
      {.min = 0.0, .max = 255.0, .doc = "8-bit chroma units between Otsu class means (else: no leg colour)"});
  s.open_kernel_px = p.get<int>("open_kernel_px", s.open_kernel_px,
                                {.unit = "px", .min = 1, .max = 15, .doc = "opening kernel, odd (1 = off)"});
  s.close_kernel_px = p.get<int>("close_kernel_px", s.close_kernel_px,
                                 {.unit = "px", .min = 1, .max = 15, .doc = "closing kernel, odd (1 = off)"});
  s.contact_half_angle_rad = p.get<double>("contact_half_angle_rad", s.contact_half_angle_rad,
                                           {.unit = "rad",
                                            .min = 0.0,
                                            .max = 1.5707963267948966,
                                            .doc = "legs within this angle of straight down are examined"});
  s.angle_tolerance_rad =
      p.get<double>("angle_tolerance_rad", s.angle_tolerance_rad,
                    {.unit = "rad", .min = 0.0, .max = 0.5, .doc = "mask sweep for encoder-to-leg misalignment"});
  s.mask_margin_px =
      p.get<double>("mask_margin_px", s.mask_margin_px,
                    {.unit = "px", .min = 0.0, .max = 100.0, .doc = "mask dilation around the template"});
  s.use_dynamic_mask = p.get<bool>("use_dynamic_mask", true, {.doc = "false: segment the whole frame (slow)"});
  s.refine_leg_angle = p.get<bool>("refine_leg_angle", true, {.doc = "re-fit each leg's axis from its pixels"});
  s.mm_per_px = p.get<double>("mm_per_px", s.mm_per_px,
                              {.unit = "mm/px", .min = 0.0, .min_exclusive = true, .doc = "scale at the wheel plane"});
  s.leg_length_mm = p.get<double>(
      "leg_length_mm", 0.0,
      {.unit = "mm", .min = 0.0, .doc = "> 0: scale = leg_length_mm / geometry.leg_length_px (overrides mm_per_px)"});
  s.min_confidence =
      p.get<double>("min_confidence", s.min_confidence, {.min = 0.0, .max = 1.0, .doc = "legs below are invalid"});
  s.min_visible_px =
      p.get<double>("min_visible_px", s.min_visible_px,
                    {.unit = "px", .min = 0.0, .max = 1e4, .doc = "a leg needs this much visible length"});
  s.contact_min_mm =
      p.get<double>("contact_min_mm", s.contact_min_mm,
                    {.unit = "mm", .min = 0.0, .max = 1e4, .doc = "a leg deeper than this is in contact"});
  const std::string filter = p.get<std::string>(
      "filter", "none", {.choices = {"none", "ema", "median"}, .doc = "temporal filter on the wheel sinkage"});
  s.filter = filter == "ema"      ? TemporalFilter::kEma
             : filter == "median" ? TemporalFilter::kMedian
                                  : TemporalFilter::kNone;
  s.ema_alpha =
      p.get<double>("ema_alpha", s.ema_alpha,
                    {.min = 0.0, .max = 1.0, .min_exclusive = true, .doc = "ema: weight of the newest frame"});
  s.median_window = p.get<int>("median_window", s.median_window,
                               {.unit = "frames", .min = 1, .max = 31, .doc = "median: window length"});
  try {
    s.validate();
  } catch (const FieldError& e) {
    fail_validation(p, e);
  }
  return a;
}

namespace {

using WheelSinkageMsg = msgs::regolith_msgs::WheelSinkage;

struct LogRecord {
  TimeNs stamp = 0;
  std::uint64_t sequence = 0;
  double angle = 0, vision_mm = 0, confidence = 0, transducer_mm = 0;
  bool valid = false;
  const char* reason = "none";  // static string
};

struct OverlaySlot {
  cv::Mat image;
  SinkageResult result;
  std::uint64_t sequence = 0;
};

class WheelSinkageComponent final : public runtime::Component {
 public:
  ~WheelSinkageComponent() override { stop_writer(); }

  void configure(Params& p, runtime::Context& ctx) override {
    cam_ = &ctx.camera(p, "camera");
    const hal::CameraFormat fmt = cam_->format();
    if (fmt.format != hal::PixelFormat::kBgr8) {
      p.fail("camera", "camera '" + cam_->id() + "' delivers mono8; the leg colour needs a bgr8 camera");
    }
    size_ = cv::Size(fmt.width, fmt.height);
    enc_ = &ctx.encoders(p, "encoders");
    wheel_ = find_channel(p, "wheel", *enc_, enc_->wheel_names().empty() ? std::string() : enc_->wheel_names()[0]);
    enc_timeout_ = from_seconds(p.get<double>(
        "encoder_timeout_s", 0.1,
        {.unit = "s",
         .min = 0.0,
         .min_exclusive = true,
         .doc = "newest encoder sample older than this at the frame's capture time -> stale, invalid result"}));

    // Bench rig: a linear transducer channel (m) on the same or another encoder device.
    const std::string transducer = p.get<std::string>(
        "transducer", "",
        {.doc = "encoder channel carrying the bench rig's linear sinkage transducer (m); empty = none"});
    if (!transducer.empty()) {
      tenc_ = p.has("transducer_encoders") ? &ctx.encoders(p, "transducer_encoders") : enc_;
      transducer_ = find_channel(p, "transducer", *tenc_, transducer);
    } else if (p.has("transducer_encoders")) {
      p.fail("transducer_encoders", "given without 'transducer' (the channel name)");
    }
    transducer_scale_ =
        p.get<double>("transducer_scale", 1.0, {.doc = "m per channel unit (sinkage = scale * value + offset)"});
    transducer_offset_m_ = p.get<double>("transducer_offset_m", 0.0,
                                         {.unit = "m", .doc = "added to the scaled value (zero of the transducer)"});

    algo_ = read_algorithm_config(p);
    const WheelGeometry& g = algo_.geometry;
    {  // the wheel must reach into the image
      const double cx = std::clamp(g.hub_center_px.x, 0.0, static_cast<double>(size_.width));
      const double cy = std::clamp(g.hub_center_px.y, 0.0, static_cast<double>(size_.height));
      if (std::hypot(cx - g.hub_center_px.x, cy - g.hub_center_px.y) >= g.leg_length_px) {
        Params gp = p.child("geometry");
        gp.fail("hub_center_px", "the wheel (hub + leg_length_px) lies entirely outside the " +
                                     std::to_string(size_.width) + "x" + std::to_string(size_.height) + " image");
      }
    }
    try {
      estimator_ = std::make_unique<SinkageEstimator>(g, algo_.params, size_);
    } catch (const std::invalid_argument& e) {
      p.fail({}, e.what());
    }
    // Warm up once so that nothing lazy happens in the first real step.
    cv::Mat black(size_, CV_8UC3, cv::Scalar::all(0));
    estimator_->process(black, 0.0, result_);
    estimator_->reset_filter();

    wheel_name_ = p.get<std::string>("wheel_name", enc_->wheel_names()[wheel_],
                                     {.doc = "wheel name in the published message (default: the encoder wheel)"});
    frame_id_ = p.get<std::string>("frame_id", "base_link", {.doc = "header.frame_id of terrain/wheel_sinkage"});

    out_ = &ctx.produce<WheelSinkageSample>(kSinkageChannel, 4);
    const TimeNs frame_timeout = runtime::read_input_timeout(p, fmt.rate_hz, 0.5);
    cam_watch_ = &watch_input("camera", frame_timeout);
    order_ = FrameOrder(frame_timeout);
    // The encoder input is refreshed once per processed frame (when the frame found its angle):
    // stale only when no frame has for as long as the camera may be silent. A single late
    // sample is counted per frame (stale_encoder) instead.
    enc_watch_ = &watch_input("encoders", std::max(enc_timeout_, frame_timeout));

    if (dds::Participant* part = ctx.dds()) {
      const dds::TopicInfo* info = dds::find_topic(kSinkageChannel);
      const std::string name = wheel_name_, frame = frame_id_;
      dds_ = part->make_outbox<WheelSinkageMsg>(kSinkageChannel, info->writer_qos(),
                                                dds::OutboxOptions{dds::OutboxMode::kFifo, 8},
                                                [name, frame](WheelSinkageMsg& m) {
                                                  dds::reserve(m, dds::WheelSinkageCapacity{1, 64, 64});
                                                  dds::copy_string(m.header.frame_id, 64, frame);
                                                  dds::set_length(m.wheel_names, 1);
                                                  dds::copy_string(m.wheel_names._buffer[0], 64, name);
                                                });
    }

    // Bench-rig log and overlays (written by the writer thread).
    log_path_ = p.get<std::string>(
        "log_csv", "", {.doc = "bench log (vision vs transducer) CSV, relative to the working directory; empty = off"});
    load_label_ = label(p, "load_label", "unknown", "test condition: normal load, e.g. '3.5 kg' (log column)");
    light_label_ =
        label(p, "illumination_label", "unknown", "test condition: illumination, e.g. '10-15 lux' (log column)");
    const int queue = p.get<int>("log_queue", 4096,
                                 {.unit = "rows",
                                  .min = 16,
                                  .max = 1 << 20,
                                  .doc = "rows buffered for the writer thread (overflow: dropped, counted)"});
    if (!log_path_.empty()) {
      check_parent(p, "log_csv", log_path_);
      log_q_ = std::make_unique<BoundedQueue<LogRecord>>(static_cast<std::size_t>(queue), DropPolicy::kDropNewest);
    }
    overlay_dir_ = p.get<std::string>("overlay_dir", "", {.doc = "directory for diagnostic overlay PNGs; empty = off"});
    overlay_every_ = p.get<int>(
        "overlay_every", 0, {.unit = "frames", .min = 0, .doc = "save an overlay every N processed frames (0 = off)"});
    if (overlay_every_ > 0 && overlay_dir_.empty()) p.fail("overlay_every", "needs overlay_dir");
    if (!overlay_dir_.empty() && overlay_every_ == 0) p.fail("overlay_dir", "needs overlay_every > 0");
    if (overlay_every_ > 0) {
      if (!std::filesystem::is_directory(overlay_dir_))
        p.fail("overlay_dir", "'" + overlay_dir_ + "' is not a directory");
      for (auto& s : slots_) s.image.create(size_, CV_8UC3);
      ov_free_ = std::make_unique<BoundedQueue<int>>(kSlots, DropPolicy::kDropNewest);
      ov_ready_ = std::make_unique<BoundedQueue<int>>(kSlots, DropPolicy::kDropNewest);
      for (int i = 0; i < kSlots; ++i) ov_free_->push(i);
    }
  }

  void activate() override {
    if (log_q_) {
      log_file_ = std::fopen(log_path_.c_str(), "w");
      if (log_file_ == nullptr) throw std::runtime_error(log_path_ + ": cannot open the sinkage log for writing");
      std::fprintf(log_file_, "# regolith wheel_sinkage bench log: component %s, wheel %s\n%s\n", name().c_str(),
                   wheel_name_.c_str(), bench_log_header());
    }
    if (log_q_ || ov_free_) {
      stop_.store(false);
      writer_ = std::thread([this] { writer_loop(); });
    }
    new_frame_.reset();
    estimator_->reset_filter();
  }

  void deactivate() override { stop_writer(); }

  // step_frame() checks every frame (corrupt, size, type) before the estimator sees it, so nothing
  // in the cycle throws.
  void step(const runtime::CycleInfo& c) override { step_frame(c); }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    auto add = [&kv](const char* k, const std::atomic<std::uint64_t>& v) {
      kv.emplace_back(k, std::to_string(v.load()));
    };
    add("frames", frames_);
    kv.emplace_back("frames_out_of_order", std::to_string(order_.out_of_order()));
    kv.emplace_back("clock_steps", std::to_string(order_.clock_steps()));
    add("valid", valid_);
    add("bad_frames", bad_frames_);
    for (std::size_t i = 1; i < enc_problems_.size(); ++i)
      kv.emplace_back(to_string(static_cast<EncoderProblem>(i)), std::to_string(enc_problems_[i].load()));
    for (std::size_t i = 1; i < reasons_.size(); ++i)
      kv.emplace_back(std::string("invalid_") + to_string(static_cast<InvalidReason>(i)),
                      std::to_string(reasons_[i].load()));
    if (tenc_ != nullptr) add("transducer_missing", transducer_missing_);
    if (log_q_) {
      add("log_rows", log_rows_);
      kv.emplace_back("log_dropped", std::to_string(log_q_->dropped()));
      add("log_write_errors", log_errors_);
      if (const int e = log_errno_.load(); e != 0) kv.emplace_back("log_error", log_path_ + ": " + std::strerror(e));
    }
    if (ov_free_) {
      add("overlays_written", overlays_written_);
      add("overlays_skipped", overlays_skipped_);
      add("overlays_failed", overlays_failed_);
    }
  }

  std::string result() const override {
    const auto l = out_ != nullptr ? out_->acquire() : decltype(out_->acquire()){};
    if (!l) return {};
    if (!l->result.valid) return "no sinkage this frame";
    char buf[96];
    std::snprintf(buf, sizeof buf, "sinkage %.1f mm (conf %.2f)", l->result.sinkage_mm, l->result.confidence);
    return buf;
  }

 private:
  static constexpr int kSlots = 2;

  static std::size_t find_channel(Params& p, const char* key, const hal::WheelEncoders& enc, const std::string& dflt) {
    const std::string want = p.get<std::string>(key, dflt, {.doc = "channel (wheel) name in the encoder set"});
    const auto& names = enc.wheel_names();
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == want) return i;
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    std::string msg = "encoder set '" + enc.id() + "' has no channel '" + want + "' (channels: " + list + ")";
    const std::string guess = did_you_mean(want, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    p.fail(key, msg);
  }

  static std::string label(Params& p, const char* key, const char* dflt, const char* doc) {
    std::string v = p.get<std::string>(key, dflt, {.doc = doc});
    if (v.find_first_of(",\n\r") != std::string::npos) p.fail(key, "must not contain commas or line breaks");
    return v;
  }

  static void check_parent(Params& p, const char* key, const std::string& path) {
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    if (!parent.empty() && !std::filesystem::is_directory(parent)) {
      p.fail(key, "directory '" + parent.string() + "' does not exist");
    }
  }

  void step_frame(const runtime::CycleInfo& c) {
    hal::FrameLease lease;
    if (!cam_->latest(c.now, lease)) return;
    const hal::Frame& fr = *lease;
    if (!new_frame_(fr.sequence)) return;
    // A frame stamped before the last one would take the wheel angle at the wrong time.
    if (order_.admit(fr.capture_time) == FrameOrder::Verdict::kOutOfOrder) {
      set_status("frame stamped at or before the last one (the camera clock stepped back): skipped");
      return;
    }
    input_updated(*cam_watch_, c.now);
    frames_.fetch_add(1, std::memory_order_relaxed);
    if (fr.corrupt || fr.image.empty() || fr.image.size() != size_ || fr.image.type() != CV_8UC3) {
      bad_frames_.fetch_add(1, std::memory_order_relaxed);
      count_error();
      set_status(fr.corrupt ? "corrupt frame skipped" : "frame size/type differs from the camera format");
      return;
    }

    // Wheel angle at the frame's capture time.
    double angle = kNaN;
    EncoderProblem problem = EncoderProblem::kNone;
    hal::AngleSample newest;
    if (!enc_->latest(wheel_, c.now, newest)) {
      problem = EncoderProblem::kMissing;
    } else if (fr.capture_time - newest.stamp > enc_timeout_) {
      problem = EncoderProblem::kStale;
    } else if (newest.stamp == fr.capture_time) {
      angle = newest.angle;  // a sample exactly at the capture time (angle_at may need two samples)
      input_updated(*enc_watch_, c.now);
    } else if (!enc_->angle_at(wheel_, fr.capture_time, angle) || !std::isfinite(angle)) {
      problem = EncoderProblem::kNoAngle;
      angle = kNaN;
    } else {
      input_updated(*enc_watch_, c.now);
    }
    if (problem != EncoderProblem::kNone) {
      enc_problems_[static_cast<std::size_t>(problem)].fetch_add(1, std::memory_order_relaxed);
      // A frame captured before the encoders' first sample at start-up (nothing before it to
      // interpolate from, no angle ever read) is the two devices starting, not a fault: counted,
      // not an error. Missing or stale encoders always are.
      const bool starting = problem == EncoderProblem::kNoAngle && newest.stamp > fr.capture_time &&
                            enc_watch_->updates.load(std::memory_order_relaxed) == 0;
      if (!starting) count_error();
    }

    estimator_->process(fr.image, angle, result_);  // NaN angle -> invalid, kBadAngle
    const SinkageResult& r = result_;
    if (r.valid)
      valid_.fetch_add(1, std::memory_order_relaxed);
    else
      reasons_[static_cast<std::size_t>(r.reason)].fetch_add(1, std::memory_order_relaxed);

    double truth_mm = kNaN;
    if (tenc_ != nullptr) {
      hal::AngleSample ts;
      double v = 0;
      if (tenc_->latest(transducer_, c.now, ts) && fr.capture_time - ts.stamp <= enc_timeout_ &&
          tenc_->angle_at(transducer_, fr.capture_time, v) && std::isfinite(v)) {
        truth_mm = 1000.0 * (transducer_scale_ * v + transducer_offset_m_);
      } else {
        transducer_missing_.fetch_add(1, std::memory_order_relaxed);
      }
    }

    if (WheelSinkageSample* s = out_->begin_write()) {
      s->stamp = fr.capture_time;
      s->sequence = fr.sequence;
      s->encoder_angle_rad = angle;
      s->encoder = problem;
      s->transducer_mm = truth_mm;
      s->result = r;
      s->geometry = algo_.geometry;
      out_->commit();
    }
    if (dds_) {
      if (WheelSinkageMsg* m = dds_->begin()) {
        dds::set_stamp(m->header.stamp, fr.capture_time);
        dds::set_length(m->sinkage_m, 1);
        dds::set_length(m->confidence, 1);
        m->sinkage_m._buffer[0] = r.valid ? r.sinkage_mm * 1e-3 : kNaN;
        m->confidence._buffer[0] = r.valid ? r.confidence : 0.0;
        dds_->commit();
      }
    }
    const char* reason = problem != EncoderProblem::kNone ? to_string(problem) : to_string(r.reason);
    if (log_q_) {
      LogRecord rec;
      rec.stamp = fr.capture_time;
      rec.sequence = fr.sequence;
      rec.angle = angle;
      rec.vision_mm = r.valid ? r.sinkage_mm : kNaN;
      rec.confidence = r.confidence;
      rec.transducer_mm = truth_mm;
      rec.valid = r.valid;
      rec.reason = reason;
      log_q_->push(rec);  // full: dropped and counted by the queue
    }
    if (ov_free_ && (frames_.load(std::memory_order_relaxed) - 1) % static_cast<std::uint64_t>(overlay_every_) == 0) {
      int idx = 0;
      if (ov_free_->pop(idx)) {
        OverlaySlot& slot = slots_[static_cast<std::size_t>(idx)];
        fr.image.copyTo(slot.image);  // same size and type: no reallocation
        slot.result = r;
        slot.sequence = fr.sequence;
        ov_ready_->push(idx);
      } else {
        overlays_skipped_.fetch_add(1, std::memory_order_relaxed);
      }
    }
    set_status(r.valid ? "ok" : reason);
  }

  // ---- writer thread (not real time) ----
  void writer_loop() {
    char line[512];
    for (;;) {
      bool did = false;
      LogRecord rec;
      while (log_q_ && log_q_->pop(rec)) {
        const std::size_t n = format_bench_log_row(line, sizeof line, to_seconds(rec.stamp), rec.sequence, rec.angle,
                                                   rec.vision_mm, rec.valid, rec.confidence, rec.reason,
                                                   rec.transducer_mm, load_label_.c_str(), light_label_.c_str());
        if (std::fwrite(line, 1, n, log_file_) == n && std::fputc('\n', log_file_) != EOF) {
          log_rows_.fetch_add(1, std::memory_order_relaxed);
        } else {
          log_failed(errno);
        }
        did = true;
      }
      int idx = 0;
      while (ov_ready_ && ov_ready_->pop(idx)) {
        const OverlaySlot& slot = slots_[static_cast<std::size_t>(idx)];
        char file[64];
        std::snprintf(file, sizeof file, "_%08llu.png", static_cast<unsigned long long>(slot.sequence));
        bool written = false;
        try {
          draw_overlay(*estimator_, slot.image, slot.result, overlay_);
          written = cv::imwrite((std::filesystem::path(overlay_dir_) / (name() + file)).string(), overlay_);
        } catch (const std::exception&) {
          // an unwritable overlay must not stop the log: counted below
        }
        (written ? overlays_written_ : overlays_failed_).fetch_add(1, std::memory_order_relaxed);
        ov_free_->push(idx);
        did = true;
      }
      if (!did) {
        if (stop_.load()) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    if (log_file_ != nullptr && std::fflush(log_file_) != 0) log_failed(errno);
  }

  // A row (or the flush, or the close) that did not reach the log: counted, and the first reason
  // kept for diagnostics() (a full disk must show on the rig's health page, not only in the file).
  void log_failed(int err) {
    log_errors_.fetch_add(1, std::memory_order_relaxed);
    int none = 0;
    log_errno_.compare_exchange_strong(none, err != 0 ? err : EIO);
  }

  void stop_writer() {
    if (writer_.joinable()) {
      stop_.store(true);
      writer_.join();
    }
    if (log_file_ != nullptr) {
      if (std::fclose(log_file_) != 0) log_failed(errno);
      log_file_ = nullptr;
    }
  }

  hal::Camera* cam_ = nullptr;
  hal::WheelEncoders* enc_ = nullptr;
  hal::WheelEncoders* tenc_ = nullptr;
  std::size_t wheel_ = 0, transducer_ = 0;
  TimeNs enc_timeout_ = 0;
  double transducer_scale_ = 1.0, transducer_offset_m_ = 0.0;
  cv::Size size_;
  AlgorithmConfig algo_;
  std::unique_ptr<SinkageEstimator> estimator_;
  SinkageResult result_;
  std::string wheel_name_, frame_id_;
  LatestPool<WheelSinkageSample>* out_ = nullptr;
  std::shared_ptr<dds::Outbox<WheelSinkageMsg>> dds_;
  runtime::InputWatch* cam_watch_ = nullptr;
  runtime::InputWatch* enc_watch_ = nullptr;
  NewValue new_frame_;
  FrameOrder order_;  // the sinkage stream never goes back in time (the camera timeout as limit)

  // counters (read by diagnostics() from the health thread)
  std::atomic<std::uint64_t> frames_{0}, valid_{0}, bad_frames_{0}, transducer_missing_{0};
  std::array<std::atomic<std::uint64_t>, 4> enc_problems_{};
  std::array<std::atomic<std::uint64_t>, static_cast<std::size_t>(InvalidReason::kCount)> reasons_{};

  // writer thread: bench log + overlays
  std::string log_path_, load_label_, light_label_, overlay_dir_;
  int overlay_every_ = 0;
  std::unique_ptr<BoundedQueue<LogRecord>> log_q_;
  std::unique_ptr<BoundedQueue<int>> ov_free_, ov_ready_;
  std::array<OverlaySlot, kSlots> slots_{};
  cv::Mat overlay_;
  std::FILE* log_file_ = nullptr;
  std::thread writer_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> log_rows_{0}, log_errors_{0};
  std::atomic<std::uint64_t> overlays_written_{0}, overlays_skipped_{0}, overlays_failed_{0};
  std::atomic<int> log_errno_{0};  // the first write error's errno (0 = none)
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "wheel_sinkage",
      "hub camera frame + wheel angle at capture time -> wheel-leg sinkage (terrain/wheel_sinkage); bench-rig log",
      [] { return std::make_unique<WheelSinkageComponent>(); });
}

}  // namespace regolith::sinkage
