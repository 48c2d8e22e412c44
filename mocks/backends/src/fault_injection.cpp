// Cameras, encoders and IMUs "fault_injection": wrap another backend (`inner:`) and withhold,
// freeze, corrupt, delay or disconnect its data, or (cameras) step its clock, deterministically for
// a seed and a clock sequence.
#include <algorithm>
#include <array>
#include <cmath>

#include "backends_internal.hpp"
#include "common.hpp"
#include "regolith/hal/sample_filter.hpp"

namespace regolith::mocks {
namespace detail {
namespace {

enum Salt : std::uint64_t { kDrop = 0xD409, kCorrupt = 0xC044, kBytes = 0xB17E, kGarbage = 0x6A4B };

struct FaultConfig {
  double drop_rate = 0.0;
  double corrupt_rate = 0.0;
  std::int64_t freeze_after = 0;      // frames / samples; 0 = never
  std::int64_t disconnect_after = 0;  // frames / samples; 0 = never
  std::int64_t reconnect_after = 0;   // frames / samples of outage; 0 = never reconnect
  bool repeat = false;
  TimeNs delay = 0;
  std::uint64_t seed = 1;
  std::int64_t stamp_step_after = 0;  // frames; 0 = never (cameras)
  std::int64_t stamp_step_for = 0;    // frames the step lasts; 0 = for good
  TimeNs stamp_step = 0;              // added to the capture stamps while it lasts
};

FaultConfig read_fault_config(Params& p, std::string_view unit) {
  FaultConfig c;
  c.drop_rate = p.get<double>("drop_rate", 0.0, {.min = 0.0, .max = 1.0, .doc = "probability a new item is withheld"});
  c.corrupt_rate = p.get<double>(
      "corrupt_rate", 0.0, {.min = 0.0, .max = 1.0, .doc = "probability an item is damaged (bytes / garbage angle)"});
  c.freeze_after = p.get<std::int64_t>(
      "freeze_after", 0, {.unit = unit, .min = 0, .doc = "content stops changing after N items (0 = never)"});
  const double delay_ms = p.get<double>(
      "delay_ms", 0.0,
      {.unit = "ms", .min = 0.0, .max = 60000.0, .doc = "deliver what the inner device had this long ago"});
  c.delay = static_cast<TimeNs>(std::llround(delay_ms * 1e6));
  c.disconnect_after = p.get<std::int64_t>(
      "disconnect_after", 0, {.unit = unit, .min = 0, .doc = "device faults after N items' worth of time (0 = never)"});
  c.reconnect_after = p.get<std::int64_t>(
      "reconnect_after", 0, {.unit = unit, .min = 0, .doc = "outage length in items' worth of time (0 = for good)"});
  c.repeat = p.get<bool>("repeat", false, {.doc = "cycle disconnect/reconnect forever (else only once)"});
  if (c.repeat && (c.disconnect_after == 0 || c.reconnect_after == 0))
    p.fail("repeat", "needs disconnect_after > 0 and reconnect_after > 0");
  c.seed = static_cast<std::uint64_t>(p.get<std::int64_t>("seed", 1, {.min = 0, .doc = "fault random seed"}));
  return c;
}

/// Cameras only: a step of the device's clock (its capture stamps jump by stamp_step_ms from frame
/// stamp_step_after on, for stamp_step_for frames or for good).
void read_stamp_step(Params& p, FaultConfig& c) {
  c.stamp_step_after = p.get<std::int64_t>(
      "stamp_step_after", 0, {.unit = "frames", .min = 0, .doc = "capture stamps step from frame N on (0 = never)"});
  c.stamp_step_for = p.get<std::int64_t>(
      "stamp_step_for", 0, {.unit = "frames", .min = 0, .doc = "frames the stamp step lasts (0 = for good)"});
  const double ms = p.get<double>(
      "stamp_step_ms", 0.0,
      {.unit = "ms", .min = -86400000.0, .max = 86400000.0, .doc = "size of the stamp step (+ forward, - back)"});
  c.stamp_step = static_cast<TimeNs>(std::llround(ms * 1e6));
}

/// Disconnect / reconnect as a function of the time since start(), on the device's item grid.
class FaultSchedule {
 public:
  struct At {
    bool down = false;
    std::uint64_t faults = 0;      // disconnects so far
    std::uint64_t recoveries = 0;  // reconnects so far
    TimeNs outage_begin = 0;       // rel. start of the current outage (when down)
  };
  FaultSchedule(const FaultConfig& c, double rate_hz) : cfg_(c), grid_(rate_hz) {}
  const TimeGrid& grid() const { return grid_; }

  At at(TimeNs rel) const {
    At a;
    const std::int64_t n = cfg_.disconnect_after;
    const std::int64_t m = cfg_.reconnect_after;
    const std::int64_t k = grid_.index(rel);
    if (n == 0 || k < n) return a;
    if (m == 0) return {true, 1, 0, grid_.offset(n)};
    if (cfg_.repeat) {
      const std::int64_t period = n + m;
      const std::int64_t cycle = k / period;
      a.down = k % period >= n;
      a.recoveries = static_cast<std::uint64_t>(cycle);
      a.faults = a.recoveries + (a.down ? 1 : 0);
      a.outage_begin = grid_.offset(cycle * period + n);
      return a;
    }
    a.down = k < n + m;
    a.faults = 1;
    a.recoveries = a.down ? 0 : 1;
    a.outage_begin = grid_.offset(n);
    return a;
  }

 private:
  FaultConfig cfg_;
  TimeGrid grid_;
};

// ---- camera ------------------------------------------------------------------------------------

class FaultCamera final : public hal::Camera {
 public:
  FaultCamera(const hal::DeviceContext& ctx, std::unique_ptr<hal::Camera> inner, const FaultConfig& cfg)
      : id_(ctx.id),
        index_(ctx.index),
        clock_(clock_of(ctx)),
        inner_(std::move(inner)),
        cfg_(cfg),
        fmt_(inner_->format()),
        sched_(cfg, fmt_.rate_hz),
        pool_(hal::make_frame_pool(fmt_.width, fmt_.height, fmt_.format)),
        frozen_(fmt_.height, fmt_.width, hal::cv_type(fmt_.format), cv::Scalar::all(0)) {}

  const std::string& id() const override { return id_; }
  hal::CameraFormat format() const override { return fmt_; }

  void start() override {
    inner_->start();
    last_seen_.store(-1);
    frames_.store(0);
    dropped_.store(0);
    corrupt_.store(0);
    published_epoch_.store(-1);
    frozen_valid_ = false;
    run_.begin(clock_->now());
  }
  void stop() override {
    run_.end(clock_->now());
    inner_->stop();
  }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }

  bool latest(TimeNs now, hal::FrameLease& out) override {
    out.reset();
    if (!run_.running()) return false;
    const TimeNs start = run_.start();
    const FaultSchedule::At st = sched_.at(now - start);
    if (st.down) return false;
    hal::FrameLease in;
    if (inner_->latest(now - cfg_.delay, in)) {
      const auto seq = static_cast<std::int64_t>(in->sequence);
      if (seq > last_seen_.load(std::memory_order_acquire) && !writing_.test_and_set(std::memory_order_acquire)) {
        if (seq > last_seen_.load(std::memory_order_relaxed)) {
          // Frames captured while the device was disconnected never arrive.
          if (!sched_.at(in->capture_time - start).down) process(*in, st.faults);
          last_seen_.store(seq, std::memory_order_release);
        }
        writing_.clear(std::memory_order_release);
      }
    }
    // A frame from before the latest outage is not served after the reconnection.
    if (published_epoch_.load(std::memory_order_acquire) != static_cast<std::int64_t>(st.faults)) return false;
    out = pool_->acquire();
    return static_cast<bool>(out);
  }

  hal::CameraStats stats() const override {
    hal::CameraStats s;
    const hal::CameraStats in = inner_->stats();
    s.frames = frames_.load(std::memory_order_relaxed);
    s.dropped = dropped_.load(std::memory_order_relaxed);
    s.corrupt = corrupt_.load(std::memory_order_relaxed) + in.corrupt;
    s.faults = in.faults;
    s.recoveries = in.recoveries;
    s.last_frame_time = last_frame_time_.load(std::memory_order_relaxed);
    TimeNs rel = 0;
    if (!run_.counted(clock_->now(), rel)) return s;
    const FaultSchedule::At st = sched_.at(rel);
    s.faults += st.faults;
    s.recoveries += st.recoveries;
    s.state = run_.running() && st.down ? hal::DeviceState::kFaulted : in.state;
    return s;
  }

 private:
  // Runs under the writing_ flag.
  void process(const hal::Frame& in, std::uint64_t epoch) {
    const auto seq = in.sequence;
    if (cfg_.drop_rate > 0.0 && unit(hash(cfg_.seed, seq, kDrop)) < cfg_.drop_rate) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    const bool frozen = cfg_.freeze_after > 0 && static_cast<std::int64_t>(seq) >= cfg_.freeze_after;
    if (frozen && !frozen_valid_) {
      // The content stops at the last frame delivered before the freeze.
      auto cur = pool_->acquire();
      if (cur && published_epoch_.load(std::memory_order_relaxed) >= 0) {
        cur->image.copyTo(frozen_);
      } else {
        in.image.copyTo(frozen_);
      }
      frozen_valid_ = true;
    }
    hal::Frame* f = pool_->begin_write();
    if (f == nullptr) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    (frozen ? frozen_ : in.image).copyTo(f->image);
    f->corrupt = in.corrupt;
    if (cfg_.corrupt_rate > 0.0 && unit(hash(cfg_.seed, seq, kCorrupt)) < cfg_.corrupt_rate) {
      corrupt_rows(*f, seq);
      f->corrupt = true;
      corrupt_.fetch_add(1, std::memory_order_relaxed);
    }
    f->capture_time = in.capture_time + stamp_offset(seq);
    f->sequence = in.sequence;
    f->camera_index = index_;
    pool_->commit();
    frames_.fetch_add(1, std::memory_order_relaxed);
    last_frame_time_.store(in.capture_time, std::memory_order_relaxed);
    published_epoch_.store(static_cast<std::int64_t>(epoch), std::memory_order_release);
  }

  /// The device clock's step at frame `seq` (0 outside it).
  TimeNs stamp_offset(std::uint64_t seq) const {
    const auto k = static_cast<std::int64_t>(seq);
    if (cfg_.stamp_step_after == 0 || k < cfg_.stamp_step_after) return 0;
    if (cfg_.stamp_step_for > 0 && k >= cfg_.stamp_step_after + cfg_.stamp_step_for) return 0;
    return cfg_.stamp_step;
  }

  /// Overwrite a band of rows (1/16 of the image at a random height) with random bytes.
  void corrupt_rows(hal::Frame& f, std::uint64_t seq) const {
    cv::Mat& img = f.image;
    const int band = std::max(1, img.rows / 16);
    const int row0 = static_cast<int>(unit(hash(cfg_.seed, seq, kBytes)) * (img.rows - band + 1));
    const auto row_bytes = static_cast<std::size_t>(img.cols) * img.elemSize();
    for (int r = row0; r < row0 + band; ++r) {
      std::uint8_t* p = img.ptr<std::uint8_t>(r);
      std::uint64_t h = hash(cfg_.seed, seq, kBytes, static_cast<std::uint64_t>(r));
      for (std::size_t i = 0; i < row_bytes; ++i) {
        if (i % 8 == 0) h = mix64(h);
        p[i] = static_cast<std::uint8_t>(h >> (8 * (i % 8)));
      }
    }
  }

  std::string id_;
  std::uint16_t index_ = 0;
  Clock* clock_ = nullptr;
  std::unique_ptr<hal::Camera> inner_;
  FaultConfig cfg_;
  hal::CameraFormat fmt_;
  FaultSchedule sched_;
  std::unique_ptr<hal::FramePool> pool_;
  cv::Mat frozen_;
  bool frozen_valid_ = false;  // written under writing_
  RunSpan run_;
  std::atomic<std::int64_t> last_seen_{-1};
  std::atomic<std::int64_t> published_epoch_{-1};  // outage count when the served frame was made
  std::atomic_flag writing_ = ATOMIC_FLAG_INIT;
  std::atomic<std::uint64_t> frames_{0}, dropped_{0}, corrupt_{0};
  std::atomic<TimeNs> last_frame_time_{0};
};

// ---- sampled devices (encoders, IMU) -----------------------------------------------------------

/// The faults of a sampled device (encoders, IMU), shared by both decorators: the run and the
/// disconnect schedule, which samples the consumer receives (drops and outages withhold them), the
/// freeze, the corruption decision and the walk back to the newest received sample. `key...`
/// tells apart the streams of one device in the fault hashes (the encoders' wheel; none for an IMU).
/// What a damaged sample contains is the device's own business.
class SampleFaults {
 public:
  SampleFaults(const FaultConfig& c, double rate_hz) : cfg_(c), sched_(c, rate_hz) {}

  void begin(TimeNs now) { run_.begin(now); }
  void end(TimeNs now) { run_.end(now); }
  bool running() const { return run_.running(); }
  /// Running and not inside an outage at `now`.
  bool serving(TimeNs now) const { return run_.running() && !sched_.at(now - run_.start()).down; }
  /// The newest inner-device time the consumer can see at `now` (the configured delay).
  TimeNs horizon(TimeNs now) const { return now - cfg_.delay; }

  bool frozen(TimeNs stamp) const {
    return cfg_.freeze_after > 0 && stamp - run_.start() >= sched_.grid().offset(cfg_.freeze_after);
  }
  /// The last inner time before the freeze (its sample's content is what a frozen device repeats).
  TimeNs before_freeze() const { return run_.start() + sched_.grid().offset(cfg_.freeze_after) - 1; }

  /// False when the consumer never receives the sample stamped `stamp` (it falls in an outage, or
  /// is dropped); `older` is then the latest stamp an earlier received sample can have.
  template <class... Key>
  bool received(TimeNs stamp, TimeNs& older, Key... key) const {
    const FaultSchedule::At st = sched_.at(stamp - run_.start());
    if (st.down) {
      older = run_.start() + st.outage_begin - 1;
      return false;
    }
    if (cfg_.drop_rate > 0.0 &&
        unit(hash(cfg_.seed, key..., static_cast<std::uint64_t>(stamp), kDrop)) < cfg_.drop_rate) {
      older = stamp - 1;
      return false;
    }
    return true;
  }
  template <class... Key>
  bool corrupt(TimeNs stamp, Key... key) const {
    return cfg_.corrupt_rate > 0.0 &&
           unit(hash(cfg_.seed, key..., static_cast<std::uint64_t>(stamp), kCorrupt)) < cfg_.corrupt_rate;
  }
  std::uint64_t seed() const { return cfg_.seed; }

  /// Newest received sample with stamp <= q, read with `inner_latest(q, out)` (walks back over
  /// withheld samples; the caller damages it).
  template <class Sample, class InnerLatest, class... Key>
  bool newest_received(TimeNs q, Sample& out, InnerLatest&& inner_latest, Key... key) const {
    constexpr int kMaxWalk = 256;
    for (int i = 0; i < kMaxWalk; ++i) {
      if (!inner_latest(q, out)) return false;
      if (received(out.stamp, q, key...)) return true;
    }
    return false;
  }

  /// The schedule for the device's counters at `now` (false before the first start); `down` only
  /// while running.
  bool counted(TimeNs now, FaultSchedule::At& at) const {
    TimeNs rel = 0;
    if (!run_.counted(now, rel)) return false;
    at = sched_.at(rel);
    at.down = at.down && run_.running();
    return true;
  }

 private:
  FaultConfig cfg_;
  FaultSchedule sched_;
  RunSpan run_;
};

// ---- encoders ----------------------------------------------------------------------------------

class FaultEncoders final : public hal::WheelEncoders {
 public:
  FaultEncoders(const hal::DeviceContext& ctx, std::unique_ptr<hal::WheelEncoders> inner, const FaultConfig& cfg,
                double rate_hz, TimeNs max_extrapolation)
      : id_(ctx.id),
        clock_(clock_of(ctx)),
        inner_(std::move(inner)),
        faults_(cfg, rate_hz),
        max_extrapolation_(max_extrapolation) {}

  const std::string& id() const override { return id_; }
  const std::vector<std::string>& wheel_names() const override { return inner_->wheel_names(); }
  void start() override {
    inner_->start();
    faults_.begin(clock_->now());
  }
  void stop() override {
    faults_.end(clock_->now());
    inner_->stop();
  }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }

  bool latest(std::size_t wheel, TimeNs now, hal::AngleSample& out) const override {
    return faults_.serving(now) && visible(wheel, faults_.horizon(now), out);
  }

  bool angle_at(std::size_t wheel, TimeNs t, double& angle) const override {
    hal::AngleSample newest;
    if (!latest(wheel, clock_->now(), newest)) return false;
    if (t >= newest.stamp) {
      if (t - newest.stamp > max_extrapolation_) return false;
      hal::AngleSample prev;
      if (!visible(wheel, newest.stamp - 1, prev) || prev.stamp >= newest.stamp) {
        angle = newest.angle;
        return true;
      }
      angle = newest.angle + (newest.angle - prev.angle) * static_cast<double>(t - newest.stamp) /
                                 static_cast<double>(newest.stamp - prev.stamp);
      return true;
    }
    // Inside the history: the inner device's interpolation, frozen like the samples.
    if (!inner_->angle_at(wheel, t, angle)) return false;
    if (faults_.frozen(t)) return frozen_angle(wheel, angle);
    return true;
  }

  /// The inner backend's raw frames (faults are injected on the decoded samples).
  bool reads_can() const override { return inner_->reads_can(); }
  std::size_t can_frames(std::uint64_t& cursor, TimeNs now, std::span<hal::CanFrame> out,
                         std::uint64_t& missed) const override {
    return inner_->can_frames(cursor, now, out, missed);
  }

  /// What the consumer received (for recorders): the inner device's samples up to `now` - delay,
  /// without those dropped or inside outages, frozen and corrupted as latest() serves them.
  std::size_t samples_since(std::size_t wheel, TimeNs after, TimeNs now,
                            std::span<hal::AngleSample> out) const override {
    if (!faults_.running()) return 0;
    return hal::filter_samples(
        after, out,
        [&](TimeNs a, std::span<hal::AngleSample> b) {
          return inner_->samples_since(wheel, a, faults_.horizon(now), b);
        },
        [&](hal::AngleSample& s) {
          TimeNs older = 0;
          if (!faults_.received(s.stamp, older, wheel)) return false;
          damage(wheel, s);
          return true;
        });
  }

  hal::EncoderStats stats() const override {
    hal::EncoderStats s = inner_->stats();
    FaultSchedule::At st;
    if (!faults_.counted(clock_->now(), st)) return s;
    s.faults += st.faults;
    if (st.down) s.state = hal::DeviceState::kFaulted;
    return s;
  }

 private:
  /// Angle of the last inner sample before the freeze (false: there was none).
  bool frozen_angle(std::size_t wheel, double& angle) const {
    hal::AngleSample f;
    if (!inner_->latest(wheel, faults_.before_freeze(), f)) return false;
    angle = f.angle;
    return true;
  }
  /// A received sample as the consumer sees it: frozen and corrupted (a garbage angle).
  void damage(std::size_t wheel, hal::AngleSample& s) const {
    if (faults_.frozen(s.stamp)) frozen_angle(wheel, s.angle);
    if (faults_.corrupt(s.stamp, wheel))
      s.angle = (2.0 * unit(hash(faults_.seed(), wheel, static_cast<std::uint64_t>(s.stamp), kGarbage)) - 1.0) * 1e4;
  }
  /// Newest sample the consumer can have received with stamp <= q, damaged as served.
  bool visible(std::size_t wheel, TimeNs q, hal::AngleSample& out) const {
    const auto inner_latest = [&](TimeNs at, hal::AngleSample& o) { return inner_->latest(wheel, at, o); };
    if (!faults_.newest_received(q, out, inner_latest, wheel)) return false;
    damage(wheel, out);
    return true;
  }

  std::string id_;
  Clock* clock_ = nullptr;
  std::unique_ptr<hal::WheelEncoders> inner_;
  SampleFaults faults_;
  TimeNs max_extrapolation_ = 0;
};

// ---- IMU ---------------------------------------------------------------------------------------

/// The same faults on an IMU's samples: drops and outages withhold them, a freeze repeats the last
/// sample before it (stamps and sequence advance), a corrupt sample carries garbage attitude, rates
/// and acceleration (uniform in +-1e4: beyond hal::plausible, as a damaged packet is).
class FaultImu final : public hal::Imu {
 public:
  FaultImu(const hal::DeviceContext& ctx, std::unique_ptr<hal::Imu> inner, const FaultConfig& cfg, double rate_hz,
           TimeNs max_extrapolation)
      : id_(ctx.id),
        clock_(clock_of(ctx)),
        inner_(std::move(inner)),
        faults_(cfg, rate_hz),
        max_extrapolation_(max_extrapolation) {}

  const std::string& id() const override { return id_; }
  void start() override {
    inner_->start();
    faults_.begin(clock_->now());
  }
  void stop() override {
    faults_.end(clock_->now());
    inner_->stop();
  }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }

  bool latest(TimeNs now, hal::ImuSample& out) const override {
    return faults_.serving(now) && visible(faults_.horizon(now), out);
  }

  /// Between the two received samples around `t` (angles linear, yaw along the shorter way); past
  /// the newest one its attitude is held for at most max_extrapolation_ms.
  bool attitude_at(TimeNs t, Attitude& out) const override {
    const TimeNs now = clock_->now();
    hal::ImuSample a;
    if (!latest(now, a)) return false;
    if (t >= a.stamp) {
      if (t - a.stamp > max_extrapolation_) return false;
      out = a.attitude;
      return true;
    }
    if (!visible(t, a)) return false;
    hal::ImuSample b;
    if (!next_received(a.stamp, faults_.horizon(now), b)) return false;
    const double f = static_cast<double>(t - a.stamp) / static_cast<double>(b.stamp - a.stamp);
    constexpr double kPi = 3.14159265358979323846;
    const auto lerp = [f](double x, double y) { return x + f * (y - x); };
    double dyaw = b.attitude.yaw_rad - a.attitude.yaw_rad;
    if (std::isfinite(dyaw)) dyaw -= 2.0 * kPi * std::round(dyaw / (2.0 * kPi));
    out.roll_rad = lerp(a.attitude.roll_rad, b.attitude.roll_rad);
    out.pitch_rad = lerp(a.attitude.pitch_rad, b.attitude.pitch_rad);
    out.yaw_rad = a.attitude.yaw_rad + f * dyaw;
    return true;
  }

  /// What the consumer received (for recorders): as latest() serves them.
  std::size_t samples_since(TimeNs after, TimeNs now, std::span<hal::ImuSample> out) const override {
    if (!faults_.running()) return 0;
    return hal::filter_samples(
        after, out,
        [&](TimeNs a, std::span<hal::ImuSample> b) { return inner_->samples_since(a, faults_.horizon(now), b); },
        [&](hal::ImuSample& s) {
          TimeNs older = 0;
          if (!faults_.received(s.stamp, older)) return false;
          damage(s);
          return true;
        });
  }

  hal::DeviceCounters counters() const override {
    hal::DeviceCounters c = inner_->counters();
    FaultSchedule::At st;
    if (!faults_.counted(clock_->now(), st)) return c;
    c.faults += st.faults;
    c.recoveries += st.recoveries;
    if (st.down) c.state = hal::DeviceState::kFaulted;
    return c;
  }

 private:
  /// A received sample as the consumer sees it: frozen (the content of the last sample before the
  /// freeze, its own stamp and sequence) and corrupted.
  void damage(hal::ImuSample& s) const {
    if (faults_.frozen(s.stamp)) {
      hal::ImuSample f;
      if (inner_->latest(faults_.before_freeze(), f)) {
        s.attitude = f.attitude;
        s.angular_velocity = f.angular_velocity;
        s.linear_acceleration = f.linear_acceleration;
      }
    }
    if (faults_.corrupt(s.stamp)) {
      const auto key = static_cast<std::uint64_t>(s.stamp);
      std::uint64_t k = 0;
      const auto garbage = [&] { return (2.0 * unit(hash(faults_.seed(), key, kGarbage, ++k)) - 1.0) * 1e4; };
      s.attitude = {garbage(), garbage(), garbage()};
      s.angular_velocity = {garbage(), garbage(), garbage()};
      s.linear_acceleration = {garbage(), garbage(), garbage()};
    }
  }
  /// Newest received sample with stamp <= q, damaged as served.
  bool visible(TimeNs q, hal::ImuSample& out) const {
    const auto inner_latest = [&](TimeNs at, hal::ImuSample& o) { return inner_->latest(at, o); };
    if (!faults_.newest_received(q, out, inner_latest)) return false;
    damage(out);
    return true;
  }
  /// Oldest received sample with after < stamp <= until, damaged as served.
  bool next_received(TimeNs after, TimeNs until, hal::ImuSample& out) const {
    std::array<hal::ImuSample, 16> batch{};
    for (int round = 0; round < 16; ++round) {
      const std::size_t got = inner_->samples_since(after, until, batch);
      for (std::size_t i = 0; i < got; ++i) {
        TimeNs older = 0;
        if (!faults_.received(batch[i].stamp, older)) continue;
        out = batch[i];
        damage(out);
        return true;
      }
      if (got == 0) return false;
      after = batch[got - 1].stamp;
    }
    return false;
  }

  std::string id_;
  Clock* clock_ = nullptr;
  std::unique_ptr<hal::Imu> inner_;
  SampleFaults faults_;
  TimeNs max_extrapolation_ = 0;
};

}  // namespace
}  // namespace detail

std::unique_ptr<hal::Camera> make_fault_camera(Params& p, const hal::DeviceContext& ctx,
                                               const hal::BackendRegistry& registry) {
  Params inner_p = p.require_child("inner");
  auto inner = registry.make_camera(inner_p, ctx);
  inner_p.finish();
  detail::FaultConfig cfg = detail::read_fault_config(p, "frames");
  detail::read_stamp_step(p, cfg);
  return std::make_unique<detail::FaultCamera>(ctx, std::move(inner), cfg);
}

std::unique_ptr<hal::WheelEncoders> make_fault_encoders(Params& p, const hal::DeviceContext& ctx,
                                                        const hal::BackendRegistry& registry) {
  Params inner_p = p.require_child("inner");
  auto inner = registry.make_encoders(inner_p, ctx);
  inner_p.finish();
  const detail::FaultConfig cfg = detail::read_fault_config(p, "samples");
  const double rate = detail::read_sample_rate(p, "inner report rate: converts the sample counts above into time");
  const TimeNs max_ex = detail::read_max_extrapolation(p);
  return std::make_unique<detail::FaultEncoders>(ctx, std::move(inner), cfg, rate, max_ex);
}

std::unique_ptr<hal::Imu> make_fault_imu(Params& p, const hal::DeviceContext& ctx,
                                         const hal::BackendRegistry& registry) {
  Params inner_p = p.require_child("inner");
  auto inner = registry.make<hal::Imu>(inner_p, ctx);
  inner_p.finish();
  const detail::FaultConfig cfg = detail::read_fault_config(p, "samples");
  const double rate = detail::read_sample_rate(p, "inner report rate: converts the sample counts above into time");
  const TimeNs max_ex = detail::read_max_extrapolation(p);
  return std::make_unique<detail::FaultImu>(ctx, std::move(inner), cfg, rate, max_ex);
}

}  // namespace regolith::mocks
