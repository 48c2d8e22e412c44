#include "regolith/record/hal_recorder.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>

#include "regolith/hal/camera.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/record/cdr.hpp"
#include "regolith/record/hal_messages.hpp"

namespace regolith::record {

std::string hal_camera_topic(const std::string& id, bool corrupt) {
  return "/hal/cameras/" + id + (corrupt ? "/image_corrupt" : "/image");
}
std::string hal_can_topic(const std::string& id, bool fd) {
  return "/hal/encoders/" + id + (fd ? "/can_fd" : "/can");
}
std::string hal_samples_topic(const std::string& kind, const std::string& id) {
  return "/hal/" + kind + "/" + id + "/samples";
}
std::string hal_queries_topic(const std::string& kind, const std::string& id) {
  return "/hal/" + kind + "/" + id + "/queries";
}

namespace {

/// Fixed-capacity ring: producers are the device callers (rate-group threads; one at a time, by a
/// try-flag), the consumer is the writer thread. Slots are made at construction.
template <class T>
class Ring {
 public:
  explicit Ring(std::size_t capacity, const T& proto = T{}) : slots_(std::max<std::size_t>(capacity, 1), proto) {}
  /// The slot to fill, or null when the ring is full; commit() publishes it.
  T* slot() {
    const std::uint64_t h = head_.load(std::memory_order_relaxed);
    if (h - tail_.load(std::memory_order_acquire) >= slots_.size()) return nullptr;
    return &slots_[h % slots_.size()];
  }
  void commit() { head_.store(head_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }
  /// Consumer: calls fn(slot) for each published slot, then frees them.
  template <class Fn>
  void drain(Fn&& fn) {
    const std::uint64_t h = head_.load(std::memory_order_acquire);
    std::uint64_t t = tail_.load(std::memory_order_relaxed);
    for (; t != h; ++t) fn(slots_[t % slots_.size()]);
    tail_.store(t, std::memory_order_release);
  }
  /// At construction only: give each slot its storage.
  template <class Fn>
  void for_each_slot(Fn&& fn) {
    for (T& s : slots_) fn(s);
  }
  std::atomic_flag busy = ATOMIC_FLAG_INIT;  // producer side: one caller at a time

 private:
  std::vector<T> slots_;
  std::atomic<std::uint64_t> head_{0}, tail_{0};
};

struct FrameSlot {
  cv::Mat image;
  TimeNs capture_time = 0;
  std::uint64_t sequence = 0;
  bool corrupt = false;
};

struct EncoderQuery {
  std::uint32_t wheel = 0;
  TimeNs asked = 0;    // when the component asked (the message's log time)
  TimeNs t = 0;        // the time it asked about (its header stamp)
  double angle = 0.0;  // NaN: the query failed
};

struct AttitudeQuery {
  TimeNs asked = 0;
  TimeNs t = 0;
  Attitude a;  // NaN roll: the query failed
};

}  // namespace

/// What one wrapped device records; shared by its wrapper (producer) and the recorder (writer).
struct HalRecorder::Tap {
  std::string id, kind;
  bool lossless = false;
  std::atomic<bool> active{false};  // between start() and stop(): wrappers only forward otherwise
  const Clock* clock = nullptr;     // the deployment's, set by start() before `active`
  std::atomic<std::uint64_t> recorded{0}, dropped{0};
  // camera
  std::unique_ptr<Ring<FrameSlot>> frames;
  std::atomic<std::int64_t> last_sequence{-1};
  std::uint16_t ch_image = 0, ch_corrupt = 0;
  std::string frame_id;
  const hal::Camera* camera = nullptr;
  // encoders / IMU
  std::unique_ptr<Ring<EncoderQuery>> enc_queries;
  std::unique_ptr<Ring<AttitudeQuery>> att_queries;
  std::uint16_t ch_samples = 0, ch_queries = 0, ch_attitude = 0;
  const hal::WheelEncoders* encoders = nullptr;
  const hal::Imu* imu = nullptr;
  std::vector<TimeNs> last_stamp;  // per wheel (or [0] for the IMU): newest sample written
  // raw CAN frames of an encoder backend that reads a bus
  bool reads_can = false;
  std::uint16_t ch_can = 0, ch_can_fd = 0;
  std::uint64_t can_cursor = 0, can_missed = 0;
  std::uint32_t seq_samples = 0, seq_queries = 0;

  /// Producer: claim the ring (waiting in lossless mode), fill a slot with `fill`, publish.
  template <class T, class Fill>
  void push(Ring<T>& ring, Fill&& fill) {
    if (!active.load(std::memory_order_acquire)) return;
    while (ring.busy.test_and_set(std::memory_order_acquire)) {
      if (!lossless) {
        dropped.fetch_add(1, std::memory_order_relaxed);
        return;
      }
    }
    T* s = ring.slot();
    while (s == nullptr && lossless && active.load(std::memory_order_acquire)) {
      std::this_thread::yield();
      s = ring.slot();
    }
    if (s != nullptr) {
      fill(*s);
      ring.commit();
    } else {
      dropped.fetch_add(1, std::memory_order_relaxed);
    }
    ring.busy.clear(std::memory_order_release);
  }
};

namespace {

class RecordingCamera final : public hal::Camera {
 public:
  RecordingCamera(std::unique_ptr<hal::Camera> inner, std::shared_ptr<HalRecorder::Tap> tap)
      : inner_(std::move(inner)), tap_(std::move(tap)) {}
  const std::string& id() const override { return inner_->id(); }
  void start() override { inner_->start(); }
  void stop() override { inner_->stop(); }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }
  hal::CameraFormat format() const override { return inner_->format(); }
  hal::CameraStats stats() const override { return inner_->stats(); }

  bool latest(TimeNs now, hal::FrameLease& out) override {
    if (!inner_->latest(now, out)) return false;
    if (!tap_->active.load(std::memory_order_acquire)) return true;
    const auto seq = static_cast<std::int64_t>(out->sequence);
    // Each frame once, whichever caller leases it first (the compare-exchange picks one).
    std::int64_t last = tap_->last_sequence.load(std::memory_order_acquire);
    while (seq > last) {
      if (tap_->last_sequence.compare_exchange_weak(last, seq, std::memory_order_acq_rel)) {
        const hal::Frame& f = *out;
        tap_->push(*tap_->frames, [&](FrameSlot& s) {
          f.image.copyTo(s.image);  // same geometry as the slot: no allocation
          s.capture_time = f.capture_time;
          s.sequence = f.sequence;
          s.corrupt = f.corrupt;
        });
        break;
      }
    }
    return true;
  }

 private:
  std::unique_ptr<hal::Camera> inner_;
  std::shared_ptr<HalRecorder::Tap> tap_;
};

class RecordingEncoders final : public hal::WheelEncoders {
 public:
  RecordingEncoders(std::unique_ptr<hal::WheelEncoders> inner, std::shared_ptr<HalRecorder::Tap> tap)
      : inner_(std::move(inner)), tap_(std::move(tap)) {}
  const std::string& id() const override { return inner_->id(); }
  void start() override { inner_->start(); }
  void stop() override { inner_->stop(); }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }
  hal::EncoderStats stats() const override { return inner_->stats(); }
  const std::vector<std::string>& wheel_names() const override { return inner_->wheel_names(); }
  bool latest(std::size_t wheel, TimeNs now, hal::AngleSample& out) const override {
    return inner_->latest(wheel, now, out);
  }
  bool angle_at(std::size_t wheel, TimeNs t, double& angle) const override {
    const bool ok = inner_->angle_at(wheel, t, angle);
    const double value = ok ? angle : std::numeric_limits<double>::quiet_NaN();
    tap_->push(*tap_->enc_queries, [&](EncoderQuery& q) {
      q = {static_cast<std::uint32_t>(wheel), tap_->clock->now(), t, value};
    });
    return ok;
  }
  std::size_t samples_since(std::size_t wheel, TimeNs after, TimeNs now,
                            std::span<hal::AngleSample> out) const override {
    return inner_->samples_since(wheel, after, now, out);
  }
  bool reads_can() const override { return inner_->reads_can(); }
  std::size_t can_frames(std::uint64_t& cursor, TimeNs now, std::span<hal::CanFrame> out,
                         std::uint64_t& missed) const override {
    return inner_->can_frames(cursor, now, out, missed);
  }

 private:
  std::unique_ptr<hal::WheelEncoders> inner_;
  std::shared_ptr<HalRecorder::Tap> tap_;
};

class RecordingImu final : public hal::Imu {
 public:
  RecordingImu(std::unique_ptr<hal::Imu> inner, std::shared_ptr<HalRecorder::Tap> tap)
      : inner_(std::move(inner)), tap_(std::move(tap)) {}
  const std::string& id() const override { return inner_->id(); }
  void start() override { inner_->start(); }
  void stop() override { inner_->stop(); }
  bool ready_for(TimeNs t) const override { return inner_->ready_for(t); }
  hal::DeviceCounters counters() const override { return inner_->counters(); }
  bool latest(TimeNs now, hal::ImuSample& out) const override { return inner_->latest(now, out); }
  bool attitude_at(TimeNs t, Attitude& out) const override {
    const bool ok = inner_->attitude_at(t, out);
    constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
    const Attitude value = ok ? out : Attitude{kNan, kNan, kNan};
    tap_->push(*tap_->att_queries, [&](AttitudeQuery& q) { q = {tap_->clock->now(), t, value}; });
    return ok;
  }
  std::size_t samples_since(TimeNs after, TimeNs now, std::span<hal::ImuSample> out) const override {
    return inner_->samples_since(after, now, out);
  }

 private:
  std::unique_ptr<hal::Imu> inner_;
  std::shared_ptr<HalRecorder::Tap> tap_;
};

}  // namespace

HalRecorder::HalRecorder(HalRecorderOptions options) : opts_(options) {}

HalRecorder::~HalRecorder() {
  try {
    stop();
  } catch (...) {  // a destructor must not throw
  }
}

std::unique_ptr<hal::Device> HalRecorder::wrap(std::unique_ptr<hal::Device> device) {
  auto tap = std::make_shared<Tap>();
  tap->id = device->id();
  tap->kind = device->kind();
  tap->lossless = opts_.lossless;
  if (auto* cam = dynamic_cast<hal::Camera*>(device.get())) {
    tap->camera = cam;
    tap->frames = std::make_unique<Ring<FrameSlot>>(opts_.frames_per_camera);  // pixels allocated by start()
    tap->frame_id = tap->id + "_optical_frame";
    std::unique_ptr<hal::Camera> inner(static_cast<hal::Camera*>(device.release()));
    taps_.push_back(tap);
    return std::make_unique<RecordingCamera>(std::move(inner), tap);
  }
  if (auto* enc = dynamic_cast<hal::WheelEncoders*>(device.get())) {
    tap->enc_queries = std::make_unique<Ring<EncoderQuery>>(opts_.queries_per_device);
    tap->encoders = enc;
    tap->last_stamp.assign(enc->wheel_count(), std::numeric_limits<TimeNs>::min());
    tap->reads_can = enc->reads_can();
    std::unique_ptr<hal::WheelEncoders> inner(static_cast<hal::WheelEncoders*>(device.release()));
    taps_.push_back(tap);
    return std::make_unique<RecordingEncoders>(std::move(inner), tap);
  }
  if (auto* imu = dynamic_cast<hal::Imu*>(device.get())) {
    tap->att_queries = std::make_unique<Ring<AttitudeQuery>>(opts_.queries_per_device);
    tap->imu = imu;
    tap->last_stamp.assign(1, std::numeric_limits<TimeNs>::min());
    std::unique_ptr<hal::Imu> inner(static_cast<hal::Imu*>(device.release()));
    taps_.push_back(tap);
    return std::make_unique<RecordingImu>(std::move(inner), tap);
  }
  return device;
}

void HalRecorder::start(MessageSink& sink, Clock& clock) {
  if (thread_.joinable() || stopped_) return;
  sink_ = &sink;
  clock_ = &clock;
  for (const auto& tp : taps_) {
    Tap& t = *tp;
    if (t.frames) {
      const hal::CameraFormat f = t.camera->format();
      t.frames->for_each_slot([&](FrameSlot& s) { s.image.create(f.height, f.width, hal::cv_type(f.format)); });
      const std::map<std::string, std::string> meta = {{"rate_hz", std::to_string(f.rate_hz)}};
      t.ch_image = sink.add_cdr_channel(hal_camera_topic(t.id), "sensor_msgs/msg/Image", meta);
      t.ch_corrupt = sink.add_cdr_channel(hal_camera_topic(t.id, true), "sensor_msgs/msg/Image", meta);
    } else if (t.encoders != nullptr) {
      std::string wheels;
      for (const auto& w : t.encoders->wheel_names()) wheels += (wheels.empty() ? "" : ",") + w;
      const std::map<std::string, std::string> meta = {{"wheels", wheels}};
      t.ch_samples = sink.add_cdr_channel(hal_samples_topic("encoders", t.id), "sensor_msgs/msg/JointState", meta);
      t.ch_queries = sink.add_cdr_channel(hal_queries_topic("encoders", t.id), "sensor_msgs/msg/JointState", meta);
      if (t.reads_can) {
        t.ch_can = sink.add_cdr_channel(hal_can_topic(t.id), "can_msgs/msg/Frame", {});
        t.ch_can_fd = sink.add_cdr_channel(hal_can_topic(t.id, true), "ros2_socketcan_msgs/msg/FdFrame", {});
      }
    } else if (t.imu != nullptr) {
      t.ch_samples = sink.add_cdr_channel(hal_samples_topic("imus", t.id), "sensor_msgs/msg/Imu", {});
      t.ch_queries = sink.add_cdr_channel(hal_queries_topic("imus", t.id), "geometry_msgs/msg/Vector3Stamped", {});
      t.ch_attitude = sink.add_cdr_channel("/hal/imus/" + t.id + "/attitude", "geometry_msgs/msg/Vector3Stamped", {});
    }
  }
  // Measured here: the application measures its own when it starts, after this.
  ros_offset_ = clock.simulated() ? opts_.sim_ros_offset : measure_realtime_offset();
  // recording_id tells the files of this recording from another's (under simulated time two runs
  // share their time origin): mcap_recording_files() keeps the split files that match.
  std::random_device rd;
  char id[40];
  std::snprintf(id, sizeof id, "%08x%08x%08x%08x", rd(), rd(), rd(), rd());
  sink.add_metadata("regolith_hal", {{"time_origin_ns", std::to_string(clock.now())},
                                     {"ros_time_offset_ns", std::to_string(ros_offset_)},
                                     {"simulated", clock.simulated() ? "true" : "false"},
                                     {"recording_id", id}});
  for (const auto& t : taps_) {
    t->clock = &clock;
    t->active.store(true, std::memory_order_release);  // the wrappers read `clock` after this
  }
  stop_.store(false);
  thread_ = std::thread([this] { loop(); });
}

void HalRecorder::stop() {
  if (stopped_) return;
  stopped_ = true;
  for (const auto& t : taps_) t->active.store(false, std::memory_order_release);
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stop_.store(true);
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (sink_ == nullptr) return;
  drain_all();
  sink_->add_metadata("regolith_hal_end", {{"time_end_ns", std::to_string(clock_->now())}});
}

void HalRecorder::loop() {
  std::unique_lock<std::mutex> lock(wake_mutex_);
  while (!stop_.load()) {
    lock.unlock();
    drain_all();
    lock.lock();
    wake_.wait_for(lock, std::chrono::nanoseconds(opts_.poll_period), [this] { return stop_.load(); });
  }
}

void HalRecorder::drain_all() {
  std::vector<std::uint8_t>& buf = buffer_;
  // MCAP log time on the time line of the DDS samples beside them: the capture time in ROS time.
  auto log_time = [&](TimeNs t) { return static_cast<std::uint64_t>(std::max<TimeNs>(0, t + ros_offset_)); };
  const TimeNs now = clock_->now();
  for (const auto& tp : taps_) {
    Tap& tap = *tp;
    if (tap.frames) {
      tap.frames->drain([&](const FrameSlot& s) {
        encode_image(buf, s.capture_time, tap.frame_id, s.image);
        sink_->write(s.corrupt ? tap.ch_corrupt : tap.ch_image, static_cast<std::uint32_t>(s.sequence),
                     log_time(s.capture_time), log_time(s.capture_time), buf);
        tap.recorded.fetch_add(1, std::memory_order_relaxed);
      });
    }
    if (tap.encoders != nullptr) {
      const auto& names = tap.encoders->wheel_names();
      // Every wheel's new samples, written in stamp order (one channel: its log times never go
      // back however many samples of each wheel a pass finds).
      std::array<hal::AngleSample, 256> samples;
      std::vector<WheelSample>& merged = wheel_samples_;
      merged.clear();
      for (std::size_t w = 0; w < names.size(); ++w) {
        std::size_t n = 0;
        do {
          n = tap.encoders->samples_since(w, tap.last_stamp[w], now, samples);
          for (std::size_t i = 0; i < n; ++i) {
            merged.push_back({samples[i].stamp, static_cast<std::uint32_t>(w), samples[i].angle});
            tap.last_stamp[w] = samples[i].stamp;
          }
        } while (n == samples.size());
      }
      std::stable_sort(merged.begin(), merged.end(),
                       [](const WheelSample& a, const WheelSample& b) { return a.stamp < b.stamp; });
      for (const WheelSample& s : merged) {
        encode_wheel_angle(buf, s.stamp, names[s.wheel], s.angle);
        sink_->write(tap.ch_samples, tap.seq_samples++, log_time(s.stamp), log_time(s.stamp), buf);
      }
      tap.recorded.fetch_add(merged.size(), std::memory_order_relaxed);
      if (tap.reads_can) {
        // MCAP sequence = the frame's number in the backend: a gap is frames it no longer held.
        std::array<hal::CanFrame, 64> frames;
        std::size_t n = 0;
        do {
          const std::uint64_t first = tap.can_cursor, missed = tap.can_missed;
          n = tap.encoders->can_frames(tap.can_cursor, now, frames, tap.can_missed);
          const std::uint64_t number = first + (tap.can_missed - missed);
          for (std::size_t i = 0; i < n; ++i) {
            const hal::CanFrame& f = frames[i];
            encode_can_frame(buf, f, tap.id);
            sink_->write(f.fd ? tap.ch_can_fd : tap.ch_can, static_cast<std::uint32_t>(number + i), log_time(f.stamp),
                         log_time(f.stamp), buf);
          }
          tap.recorded.fetch_add(n, std::memory_order_relaxed);
          tap.dropped.fetch_add(tap.can_missed - missed, std::memory_order_relaxed);
        } while (n == frames.size());
      }
      tap.enc_queries->drain([&](const EncoderQuery& q) {
        encode_wheel_angle(buf, q.t, q.wheel < names.size() ? names[q.wheel] : std::string(), q.angle);
        sink_->write(tap.ch_queries, tap.seq_queries++, log_time(q.asked), log_time(q.asked), buf);
        tap.recorded.fetch_add(1, std::memory_order_relaxed);
      });
    }
    if (tap.imu != nullptr) {
      std::array<hal::ImuSample, 64> samples;
      std::size_t n = 0;
      do {
        n = tap.imu->samples_since(tap.last_stamp[0], now, samples);
        for (std::size_t i = 0; i < n; ++i) {
          encode_imu(buf, samples[i], tap.id);
          // The MCAP sequence carries the device's sample sequence (the message has none).
          const auto seq = static_cast<std::uint32_t>(samples[i].sequence);
          const std::uint64_t lt = log_time(samples[i].stamp);
          sink_->write(tap.ch_samples, seq, lt, lt, buf);
          // The attitude exactly (the quaternion does not give roll, pitch, yaw back bit for bit).
          encode_attitude(buf, samples[i].stamp, samples[i].attitude);
          sink_->write(tap.ch_attitude, seq, lt, lt, buf);
          tap.last_stamp[0] = samples[i].stamp;
        }
        tap.recorded.fetch_add(2 * n, std::memory_order_relaxed);
      } while (n == samples.size());
      tap.att_queries->drain([&](const AttitudeQuery& q) {
        encode_attitude(buf, q.t, q.a);
        sink_->write(tap.ch_queries, tap.seq_queries++, log_time(q.asked), log_time(q.asked), buf);
        tap.recorded.fetch_add(1, std::memory_order_relaxed);
      });
    }
  }
}

std::vector<HalRecorder::DeviceCount> HalRecorder::counts() const {
  std::vector<DeviceCount> out;
  for (const auto& t : taps_) out.push_back({t->id, t->kind, t->recorded.load(), t->dropped.load()});
  return out;
}

std::uint64_t HalRecorder::dropped() const {
  std::uint64_t n = 0;
  for (const auto& t : taps_) n += t->dropped.load();
  return n;
}

}  // namespace regolith::record
