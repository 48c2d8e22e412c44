#include "common.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace regolith::mocks::detail {

Clock* clock_of(const hal::DeviceContext& ctx) {
  static SystemClock system_clock;
  return ctx.clock != nullptr ? ctx.clock : &system_clock;
}

SceneDescription scene_description(Params& p, const hal::DeviceContext& ctx,
                                   const std::vector<std::string>& moved_camera_keys,
                                   const std::vector<std::string>& moved_sun_keys) {
  for (const auto& k : moved_camera_keys)
    p.reject_moved(k,
                   "the camera is described once, in rover.cameras." + ctx.id +
                       " {camera_info: {width, height, k, d}, mount: {x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad}}");
  for (const auto& k : moved_sun_keys)
    p.reject_moved(k,
                   "the deployment has one sun: a top-level `sun: {azimuth_deg, elevation_deg}` block "
                   "(compass azimuth from the rover's heading at start)");
  SceneDescription d;
  if (ctx.rover != nullptr) {
    d.camera = ctx.rover->camera(ctx.id);
    if (ctx.rover->sun) d.sun = &*ctx.rover->sun;
  }
  if (d.camera != nullptr && d.camera->info.distortion_model == "plumb_bob") {
    for (double v : d.camera->info.d)
      if (v != 0.0)
        p.fail({}, "the synthetic renderer is a pinhole: rover.cameras." + ctx.id + ".camera_info.d must be zero");
  }
  return d;
}

void check_preload(Params& p, const char* key, std::uint64_t frames, cv::Size size, int bytes_per_pixel) {
  const std::uint64_t frame_bytes =
      static_cast<std::uint64_t>(size.area()) * static_cast<std::uint64_t>(bytes_per_pixel);
  if (frames * frame_bytes <= kMaxPreloadBytes) return;
  char text[256];
  std::snprintf(text, sizeof text,
                "%llu frames of %dx%d x %d B are %.1f GiB, more than the %.0f GiB a mock camera may hold; "
                "use fewer frames (they repeat with loop: true)",
                static_cast<unsigned long long>(frames), size.width, size.height, bytes_per_pixel,
                static_cast<double>(frames * frame_bytes) / static_cast<double>(1ull << 30),
                static_cast<double>(kMaxPreloadBytes) / static_cast<double>(1ull << 30));
  p.fail(key, text);
}

cv::Size scene_image_size(Params& p, const SceneDescription& d, cv::Size fallback) {
  if (d.camera != nullptr) fallback = {d.camera->info.width, d.camera->info.height};
  const cv::Size s(
      p.get<int>("width", fallback.width, {.unit = "px", .min = 16, .max = 4096, .doc = "image width"}),
      p.get<int>("height", fallback.height, {.unit = "px", .min = 16, .max = 4096, .doc = "image height"}));
  if (d.camera != nullptr && s != fallback)
    p.fail(s.width != fallback.width ? "width" : "height",
           std::to_string(s.width) + "x" + std::to_string(s.height) + " px differs from the calibration (" +
               std::to_string(fallback.width) + "x" + std::to_string(fallback.height) + " px, " + d.camera->where +
               ")");
  return s;
}

double read_sample_rate(Params& p, const char* doc) {
  return p.get<double>("sample_rate_hz", 100.0,
                       {.unit = "Hz", .min = 0.0, .max = 100000.0, .min_exclusive = true, .doc = doc});
}

TimeNs read_max_extrapolation(Params& p) {
  const double ms = p.get<double>(
      "max_extrapolation_ms", 50.0,
      {.unit = "ms", .min = 0.0, .max = 10000.0, .doc = "angle_at may extrapolate this far past the newest sample"});
  return static_cast<TimeNs>(std::llround(ms * 1e6));
}

// ---- PreloadedCamera ---------------------------------------------------------------------------

PreloadedCamera::PreloadedCamera(const hal::DeviceContext& ctx, hal::CameraFormat fmt, std::vector<cv::Mat> images,
                                 bool loop)
    : id_(ctx.id),
      index_(ctx.index),
      clock_(clock_of(ctx)),
      fmt_(fmt),
      images_(std::move(images)),
      loop_(loop),
      grid_(fmt.rate_hz),
      outlet_(fmt) {
  if (images_.empty()) throw std::invalid_argument("PreloadedCamera: no images");
  for (const auto& m : images_) {
    if (m.cols != fmt_.width || m.rows != fmt_.height || m.type() != hal::cv_type(fmt_.format) || !m.isContinuous())
      throw std::invalid_argument("PreloadedCamera: image geometry differs from the format");
  }
}

std::int64_t PreloadedCamera::frame_index(TimeNs rel) const {
  const std::int64_t k = grid_.index(rel);
  const auto n = static_cast<std::int64_t>(images_.size());
  return !loop_ && k >= n ? n - 1 : k;  // not looping: the last image stays the newest frame
}

void PreloadedCamera::start() {
  outlet_.reset();
  run_.begin(clock_->now());
}

void PreloadedCamera::stop() {
  run_.end(clock_->now());
}

bool PreloadedCamera::latest(TimeNs now, hal::FrameLease& out) {
  out.reset();
  if (!run_.running()) return false;
  const TimeNs start = run_.start();
  const std::int64_t k = frame_index(now - start);
  if (k < 0) return false;
  const auto n = static_cast<std::int64_t>(images_.size());
  return outlet_.serve(k, out, [&](hal::Frame& f) {
    images_[static_cast<std::size_t>(k % n)].copyTo(f.image);  // same geometry: no allocation
    f.capture_time = start + frame_offset(k);
    f.sequence = frame_sequence(k);
    f.camera_index = index_;
    f.corrupt = frame_corrupt(k);
  });
}

hal::CameraStats PreloadedCamera::stats() const {
  hal::CameraStats s;
  outlet_.fill_stats(s);
  s.state = run_.state();
  return s;
}

// ---- LazyEncoders ------------------------------------------------------------------------------

LazyEncoders::LazyEncoders(const hal::DeviceContext& ctx, std::vector<std::string> wheels, TimeNs max_extrapolation)
    : id_(ctx.id), wheels_(std::move(wheels)), clock_(clock_of(ctx)), max_extrapolation_(max_extrapolation) {}

void LazyEncoders::start() {
  run_.begin(clock_->now());
}

void LazyEncoders::stop() {
  run_.end(clock_->now());
}

bool LazyEncoders::latest(std::size_t wheel, TimeNs now, hal::AngleSample& out) const {
  if (!run_.running() || wheel >= wheels_.size()) return false;
  const TimeNs start = start_time();
  const std::int64_t g = index_at(wheel, now - start);
  if (g < 0) return false;
  out = sample(wheel, g);
  out.stamp += start;
  return true;
}

bool LazyEncoders::angle_at(std::size_t wheel, TimeNs t, double& angle) const {
  if (!run_.running() || wheel >= wheels_.size()) return false;
  const TimeNs start = start_time();
  const TimeNs rel = t - start;
  const std::int64_t newest = index_at(wheel, clock_->now() - start);
  if (newest < 0) return false;
  const hal::AngleSample b = sample(wheel, newest);
  if (rel >= b.stamp) {
    if (rel - b.stamp > max_extrapolation_) return false;
    if (newest == 0) {
      angle = b.angle;
      return true;
    }
    const hal::AngleSample a = sample(wheel, newest - 1);
    const double dt = static_cast<double>(b.stamp - a.stamp);
    angle = dt > 0 ? b.angle + (b.angle - a.angle) * static_cast<double>(rel - b.stamp) / dt : b.angle;
    return true;
  }
  const std::int64_t g0 = index_at(wheel, rel);
  if (g0 < 0) return false;  // before the first sample
  const hal::AngleSample s0 = sample(wheel, g0);
  const hal::AngleSample s1 = sample(wheel, g0 + 1);
  const double dt = static_cast<double>(s1.stamp - s0.stamp);
  const double f = dt > 0 ? static_cast<double>(rel - s0.stamp) / dt : 0.0;
  angle = s0.angle + f * (s1.angle - s0.angle);
  return true;
}

std::size_t LazyEncoders::samples_since(std::size_t wheel, TimeNs after, TimeNs now,
                                        std::span<hal::AngleSample> out) const {
  // Up to the stop once stopped: a recorder's last poll, after the devices stopped, still gets
  // the samples of the run's end.
  TimeNs delivered = 0;
  if (!run_.counted(now, delivered) || wheel >= wheels_.size() || out.empty()) return 0;
  const TimeNs start = start_time();
  const std::int64_t last = index_at(wheel, delivered);
  if (last < 0) return 0;
  // The first sample after `after` (index_at gives the newest at or before a time).
  const std::int64_t first = after < start ? 0 : index_at(wheel, after - start) + 1;
  const std::int64_t end = std::min(last + 1, first + static_cast<std::int64_t>(out.size()));
  std::size_t n = 0;
  for (std::int64_t g = first; g < end; ++g) {
    hal::AngleSample s = sample(wheel, g);
    s.stamp += start;
    if (s.stamp > after) out[n++] = s;
  }
  return n;
}

hal::EncoderStats LazyEncoders::stats() const {
  hal::EncoderStats s;
  s.rejected = rejected_;
  TimeNs rel = 0;
  if (!run_.counted(clock_->now(), rel)) return s;
  s.state = run_.state();
  for (std::size_t w = 0; w < wheels_.size(); ++w) s.samples += static_cast<std::uint64_t>(index_at(w, rel) + 1);
  return s;
}

// ---- GridImu ---------------------------------------------------------------------------------

GridImu::GridImu(const hal::DeviceContext& ctx, double rate_hz) : id_(ctx.id), clock_(clock_of(ctx)), grid_(rate_hz) {}

void GridImu::start() {
  run_.begin(clock_->now());
}

void GridImu::stop() {
  run_.end(clock_->now());
}

bool GridImu::latest(TimeNs now, hal::ImuSample& out) const {
  if (!run_.running()) return false;
  const std::int64_t k = grid_.index(now - run_.start());
  if (k < 0) return false;
  sample(k, out);
  return true;
}

std::size_t GridImu::samples_since(TimeNs after, TimeNs now, std::span<hal::ImuSample> out) const {
  return grid_samples_since(run_, grid_, after, now, out, [this](std::int64_t k, hal::ImuSample& s) { sample(k, s); });
}

bool GridImu::attitude_at(TimeNs t, Attitude& out) const {
  if (!run_.running()) return false;
  const TimeNs t0 = run_.start();
  if (t < t0) return false;
  out = attitude(to_seconds(t - t0));
  return true;
}

hal::DeviceCounters GridImu::counters() const {
  hal::DeviceCounters c;
  TimeNs rel = 0;
  if (!run_.counted(clock_->now(), rel)) return c;
  c.state = run_.state();
  const std::int64_t k = grid_.index(rel);
  c.delivered = k < 0 ? 0 : static_cast<std::uint64_t>(k + 1);
  return c;
}

void GridImu::sample(std::int64_t k, hal::ImuSample& out) const {
  const TimeNs rel = grid_.offset(k);
  const double t = to_seconds(rel);
  out.stamp = run_.start() + rel;
  out.sequence = static_cast<std::uint64_t>(k);
  out.attitude = attitude(t);
  motion(t, out);
}

}  // namespace regolith::mocks::detail
