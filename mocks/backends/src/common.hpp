#pragma once
// Internal building blocks shared by the mock backends: deterministic hashing "randomness", the
// frame outlet of a camera whose frames are made on demand, the lazy frame camera (preloaded
// images served on a time grid), the lazy encoder base (samples computed on demand from a script
// or a log) and the IMU on a time grid. Not installed.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/frame.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::mocks::detail {

/// When a mock device ran, on its clock: begin() at start(), end() at stop(). A scripted device's
/// counters are what it delivered up to now while it runs and up to its stop afterwards, so a
/// stopped device keeps its totals (frames, samples, faults and recoveries), as a hardware
/// backend's counters do; the final summary reads them after every device stopped.
class RunSpan {
 public:
  void begin(TimeNs now) {
    start_.store(now, std::memory_order_release);
    stop_.store(now, std::memory_order_release);
    ran_.store(true, std::memory_order_release);
    running_.store(true, std::memory_order_release);
  }
  void end(TimeNs now) {  // from the thread that starts and stops the device
    if (!running()) return;
    stop_.store(now, std::memory_order_release);  // before running_: counted() never sees a stale stop
    running_.store(false, std::memory_order_release);
  }
  bool running() const { return running_.load(std::memory_order_acquire); }
  /// Streaming while it runs, stopped otherwise (what a scripted device reports).
  hal::DeviceState state() const { return running() ? hal::DeviceState::kStreaming : hal::DeviceState::kStopped; }
  TimeNs start() const { return start_.load(std::memory_order_acquire); }
  /// Time since the start up to which the counters count: `now` while running, the stop after
  /// it; false before the first start.
  bool counted(TimeNs now, TimeNs& rel) const {
    if (!ran_.load(std::memory_order_acquire)) return false;
    rel = (running() ? now : stop_.load(std::memory_order_acquire)) - start();
    return true;
  }

 private:
  std::atomic<bool> running_{false}, ran_{false};
  std::atomic<TimeNs> start_{0}, stop_{0};
};

// ---- deterministic pseudo-randomness (stateless: a pure function of its inputs) ---------------

/// SplitMix64 finaliser: a good 64-bit mixing function.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}
inline std::uint64_t hash(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0) {
  return mix64(mix64(mix64(seed ^ 0x5851F42D4C957F2DULL) ^ a) ^ mix64(b + 0x2545F4914F6CDD1DULL) ^ (c << 1));
}
/// Uniform in [0, 1).
inline double unit(std::uint64_t h) {
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}
/// Standard normal from two hashes (Box-Muller).
inline double gaussian(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  const double u1 = 1.0 - unit(hash(seed, a, b, 1));  // (0, 1]
  const double u2 = unit(hash(seed, a, b, 2));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
}

/// The clock of the device context, or the process-wide monotonic clock when none was given.
Clock* clock_of(const hal::DeviceContext& ctx);

/// The rendering geometry of a synthetic camera, declared once in the deployment: the rover
/// description's entry for this device (or null: the scene's defaults) and the deployment sun (or
/// null). Keys an older file format had in the device block are rejected at their key, saying
/// where they go now.
struct SceneDescription {
  const RoverCamera* camera = nullptr;
  const Sun* sun = nullptr;
};
SceneDescription scene_description(Params& p, const hal::DeviceContext& ctx,
                                   const std::vector<std::string>& moved_camera_keys,
                                   const std::vector<std::string>& moved_sun_keys);
/// Image size: the device's width/height keys, defaulting to the calibration's; a mismatch with the
/// calibration is an error at the key.
cv::Size scene_image_size(Params& p, const SceneDescription& d, cv::Size fallback);

/// Most bytes a mock camera may render or load at configure time (all its frames together).
inline constexpr std::uint64_t kMaxPreloadBytes = 1ull << 30;
/// A located error at `key` when `frames` frames of `size` with `bytes_per_pixel` would exceed
/// kMaxPreloadBytes (`frames: 10000` of 640x480 BGR is 8.6 GiB: refused, not swapped to death).
void check_preload(Params& p, const char* key, std::uint64_t frames, cv::Size size, int bytes_per_pixel);

// ---- a regular time grid: sample k is at k / rate after the start ------------------------------

class TimeGrid {
 public:
  TimeGrid() = default;
  explicit TimeGrid(double rate_hz) : period_ns_(1e9 / rate_hz) {}
  double period_ns() const { return period_ns_; }
  /// Offset of sample k from the start (ns).
  TimeNs offset(std::int64_t k) const { return std::llround(static_cast<double>(k) * period_ns_); }
  /// Newest k with offset(k) <= rel; -1 when rel < 0.
  std::int64_t index(TimeNs rel) const {
    if (rel < 0) return -1;
    auto k = static_cast<std::int64_t>(std::floor(static_cast<double>(rel) / period_ns_));
    while (offset(k + 1) <= rel) ++k;
    while (k > 0 && offset(k) > rel) --k;
    return k;
  }

 private:
  double period_ns_ = 1e9;
};

/// The samples on `grid` of a device that ran over `run`, delivered by `now` and stamped after
/// `after`, at most out.size() (sample(k, item) fills sample k, stamp included). Up to the stop
/// once stopped: a recorder's last poll after the devices stopped still gets the run's end.
template <class T, class SampleFn>
std::size_t grid_samples_since(const RunSpan& run, const TimeGrid& grid, TimeNs after, TimeNs now, std::span<T> out,
                               SampleFn&& sample) {
  TimeNs delivered = 0;
  if (!run.counted(now, delivered) || out.empty()) return 0;
  const TimeNs t0 = run.start();
  const std::int64_t last = grid.index(delivered);
  const std::int64_t first = after < t0 ? 0 : grid.index(after - t0) + 1;
  const std::int64_t end = std::min(last + 1, first + static_cast<std::int64_t>(out.size()));
  std::size_t n = 0;
  for (std::int64_t k = std::max<std::int64_t>(first, 0); k < end; ++k) {
    sample(k, out[n]);
    if (out[n].stamp > after) ++n;
  }
  return n;
}

// ---- the frames a mock camera hands out -------------------------------------------------------

/// The frame pool of a camera whose frame k is made on demand: frame k is written into a pool slot
/// once, when a caller of latest() first asks for it (or anything newer), and every caller leases
/// the newest frame written. Of two concurrent callers only one writes (an atomic try-flag); the
/// other leases the current frame. A full pool (every slot leased) skips the frame and counts it.
class FrameOutlet {
 public:
  explicit FrameOutlet(const hal::CameraFormat& fmt) : pool_(hal::make_frame_pool(fmt.width, fmt.height, fmt.format)) {}

  /// At start(): nothing written yet.
  void reset() { published_.store(-1, std::memory_order_release); }

  /// Writes frame k with fill(hal::Frame&) (pixels, capture time, sequence, index, corrupt flag)
  /// unless frame k or a newer one was written, then leases the newest frame into `out`. False
  /// (and `out` empty) before the first frame.
  template <class Fill>
  bool serve(std::int64_t k, hal::FrameLease& out, Fill&& fill) {
    if (k > published_.load(std::memory_order_acquire) && !writing_.test_and_set(std::memory_order_acquire)) {
      if (k > published_.load(std::memory_order_relaxed)) {
        if (hal::Frame* f = pool_->begin_write()) {
          fill(*f);
          pool_->commit();
          last_frame_time_.store(f->capture_time, std::memory_order_relaxed);
          published_.store(k, std::memory_order_release);
        } else {
          write_failures_.fetch_add(1, std::memory_order_relaxed);
        }
      }
      writing_.clear(std::memory_order_release);
    }
    if (published_.load(std::memory_order_acquire) < 0) return false;
    out = pool_->acquire();
    return static_cast<bool>(out);
  }

  /// frames (frame numbers up to the newest written), dropped (skipped: pool full) and the newest
  /// frame's capture time into `s`.
  void fill_stats(hal::CameraStats& s) const {
    const std::int64_t k = published_.load(std::memory_order_acquire);
    s.frames = k >= 0 ? static_cast<std::uint64_t>(k + 1) : 0;
    s.dropped = write_failures_.load(std::memory_order_relaxed);
    s.last_frame_time = last_frame_time_.load(std::memory_order_relaxed);
  }

 private:
  std::unique_ptr<hal::FramePool> pool_;
  std::atomic<std::int64_t> published_{-1};
  std::atomic_flag writing_ = ATOMIC_FLAG_INIT;
  std::atomic<std::uint64_t> write_failures_{0};
  std::atomic<TimeNs> last_frame_time_{0};
};

// ---- camera serving preloaded images lazily ----------------------------------------------------

/// Camera whose frame k (captured at start + k / rate) is `images[k % n]` (or the last one held
/// when not looping). Pixels are copied into a pool slot when a newer frame becomes due
/// (FrameOutlet).
class PreloadedCamera : public hal::Camera {
 public:
  PreloadedCamera(const hal::DeviceContext& ctx, hal::CameraFormat fmt, std::vector<cv::Mat> images, bool loop);

  const std::string& id() const override { return id_; }
  hal::CameraFormat format() const override { return fmt_; }
  void start() override;
  void stop() override;
  bool latest(TimeNs now, hal::FrameLease& out) override;
  hal::CameraStats stats() const override;

  std::size_t image_count() const { return images_.size(); }
  const cv::Mat& image(std::size_t i) const { return images_[i]; }

 protected:
  // The frame schedule; the default is the rate grid (frame k = images[k % n], sequence k, captured
  // k / rate after the start). A subclass with recorded times (replay) overrides all four.
  /// Newest frame due `rel` after the start; -1 when none.
  virtual std::int64_t frame_index(TimeNs rel) const;
  virtual TimeNs frame_offset(std::int64_t k) const { return grid_.offset(k); }
  virtual std::uint64_t frame_sequence(std::int64_t k) const { return static_cast<std::uint64_t>(k); }
  virtual bool frame_corrupt(std::int64_t /*k*/) const { return false; }

 private:
  std::string id_;
  std::uint16_t index_ = 0;
  Clock* clock_ = nullptr;
  hal::CameraFormat fmt_;
  std::vector<cv::Mat> images_;
  bool loop_ = true;
  TimeGrid grid_;
  RunSpan run_;
  FrameOutlet outlet_;
};

// ---- encoders computed on demand ---------------------------------------------------------------

/// Base of the lazy encoders: a subclass says which sample of a wheel is the newest at time t
/// (`index_at`) and what that sample is (`sample`); latest / angle_at / stats follow from it.
class LazyEncoders : public hal::WheelEncoders {
 public:
  LazyEncoders(const hal::DeviceContext& ctx, std::vector<std::string> wheels, TimeNs max_extrapolation);

  const std::string& id() const override { return id_; }
  const std::vector<std::string>& wheel_names() const override { return wheels_; }
  void start() override;
  void stop() override;
  bool latest(std::size_t wheel, TimeNs now, hal::AngleSample& out) const override;
  bool angle_at(std::size_t wheel, TimeNs t, double& angle) const override;
  /// Every scripted sample in (after, now]: the script is the history.
  std::size_t samples_since(std::size_t wheel, TimeNs after, TimeNs now,
                            std::span<hal::AngleSample> out) const override;
  hal::EncoderStats stats() const override;

 protected:
  /// Global number of the newest sample of `wheel` with stamp <= start + rel; -1 if none.
  virtual std::int64_t index_at(std::size_t wheel, TimeNs rel) const = 0;
  /// Sample number g of `wheel` (stamp relative to the start).
  virtual hal::AngleSample sample(std::size_t wheel, std::int64_t g) const = 0;

  TimeNs start_time() const { return run_.start(); }
  /// Time since the start that has been delivered by `now` (up to the stop once stopped); false
  /// before the first start.
  bool delivered(TimeNs now, TimeNs& rel) const { return run_.counted(now, rel); }
  std::uint64_t rejected_ = 0;  ///< set at construction (lines / frames that could not be decoded)

 private:
  std::string id_;
  std::vector<std::string> wheels_;
  Clock* clock_ = nullptr;
  TimeNs max_extrapolation_ = 0;
  RunSpan run_;
};

/// Read `max_extrapolation_ms` (shared by the encoder backends).
TimeNs read_max_extrapolation(Params& p);
/// `sample_rate_hz` (default 100 Hz): the rate an encoder or IMU source reports at; `doc` says
/// what it means for that source.
double read_sample_rate(Params& p, const char* doc);

// ---- an IMU computed on demand on its rate grid ------------------------------------------------

/// Base of the computed IMUs: sample k of a run is stamped start + k / rate and holds the body
/// attitude a subclass gives for that time (`attitude`) with its rates and specific force
/// (`motion`); latest / samples_since / attitude_at / counters follow from it.
class GridImu : public hal::Imu {
 public:
  GridImu(const hal::DeviceContext& ctx, double rate_hz);

  const std::string& id() const override { return id_; }
  void start() override;
  void stop() override;
  bool latest(TimeNs now, hal::ImuSample& out) const override;
  std::size_t samples_since(TimeNs after, TimeNs now, std::span<hal::ImuSample> out) const override;
  bool attitude_at(TimeNs t, Attitude& out) const override;
  hal::DeviceCounters counters() const override;

 protected:
  /// The body attitude `t` seconds after the start.
  virtual Attitude attitude(double t) const = 0;
  /// Angular velocity and linear acceleration (specific force) `t` s after the start; `out.attitude`
  /// is already set.
  virtual void motion(double t, hal::ImuSample& out) const = 0;
  TimeNs start_time() const { return run_.start(); }

 private:
  /// Sample k of the run (stamp: the start + k periods).
  void sample(std::int64_t k, hal::ImuSample& out) const;

  std::string id_;
  Clock* clock_ = nullptr;
  TimeGrid grid_;
  RunSpan run_;
};

}  // namespace regolith::mocks::detail
