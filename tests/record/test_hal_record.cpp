// The HAL recording's pieces: the CDR codec (round trips, alignment, bounds), the messages of the
// recording (image pixels, exact angles, failed queries as NaN) and record::HalRecorder with a
// camera, an encoder set and an IMU of its own: what is recorded, what is dropped when a ring is
// full, and that the wrappers only forward before start().
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "regolith/hal/camera.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/record/cdr.hpp"
#include "regolith/record/hal_messages.hpp"
#include "regolith/record/hal_recorder.hpp"

namespace {
using namespace regolith;
using record::CdrReader;
using record::CdrWriter;

TEST(Cdr, RoundTripWithAlignmentRelativeToTheEncapsulation) {
  std::vector<std::uint8_t> b;
  CdrWriter w(b);
  w.u8(7);
  w.f64(1.5);  // aligned to 8 after the 4-byte header: offset 4 + 8
  w.string("ab");
  w.u32(0xA1B2C3D4);
  const double seq[] = {-2.0, 3.25};
  w.f64_sequence(seq);
  w.header(-1'500'000'000, "base_link");  // -1.5 s: sec -2, nanosec 5e8
  ASSERT_EQ(b[0], 0x00);
  ASSERT_EQ(b[1], 0x01);
  // u8 at 4, padding to 12 (8-aligned relative to byte 4), f64 at 12.
  double at12 = 0;
  std::memcpy(&at12, b.data() + 12, 8);
  EXPECT_EQ(at12, 1.5);

  CdrReader r(b);
  EXPECT_EQ(r.u8(), 7);
  EXPECT_EQ(r.f64(), 1.5);
  EXPECT_EQ(r.string(), "ab");
  EXPECT_EQ(r.u32(), 0xA1B2C3D4u);
  EXPECT_EQ(r.f64_sequence(), (std::vector<double>{-2.0, 3.25}));
  std::string frame;
  EXPECT_EQ(r.header(&frame), -1'500'000'000);
  EXPECT_EQ(frame, "base_link");
}

TEST(Cdr, ReadingPastTheEndIsAnErrorNotACrash) {
  std::vector<std::uint8_t> b;
  CdrWriter w(b);
  w.u32(1000);  // a sequence count with no elements behind it
  CdrReader r(b);
  try {
    r.f64_sequence();
    FAIL() << "no error";
  } catch (const std::out_of_range& e) {
    EXPECT_NE(std::string(e.what()).find("CDR:"), std::string::npos) << e.what();
  }
  const std::vector<std::uint8_t> big_endian = {0x00, 0x00, 0x00, 0x00, 1, 2, 3, 4};
  EXPECT_THROW(CdrReader{big_endian}, std::out_of_range);
  EXPECT_THROW(CdrReader{std::span<const std::uint8_t>()}, std::out_of_range);
}

TEST(HalMessages, ImagesAnglesAndAttitudesComeBackExactly) {
  std::vector<std::uint8_t> b;
  cv::Mat img(3, 5, CV_8UC3);
  cv::randu(img, 0, 255);
  record::encode_image(b, 1'234'567'890, "front_optical_frame", img);
  const record::DecodedImage d = record::decode_image(b);
  EXPECT_EQ(d.stamp, 1'234'567'890);
  EXPECT_EQ(d.frame_id, "front_optical_frame");
  ASSERT_EQ(d.image.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(d.image, img, cv::NORM_INF), 0.0);

  record::encode_wheel_angle(b, 42, "left_front", 0.1 + 0.2);
  const record::DecodedWheelAngle a = record::decode_wheel_angle(b);
  EXPECT_EQ(a.wheel, "left_front");
  EXPECT_EQ(a.angle, 0.1 + 0.2);  // bit for bit
  record::encode_wheel_angle(b, 43, "left_front", std::numeric_limits<double>::quiet_NaN());
  EXPECT_TRUE(std::isnan(record::decode_wheel_angle(b).angle));

  record::encode_attitude(b, 7, Attitude{0.1, -0.2, 3.0});
  const record::DecodedAttitude t = record::decode_attitude(b);
  EXPECT_EQ(t.a.roll_rad, 0.1);
  EXPECT_EQ(t.a.pitch_rad, -0.2);
  EXPECT_EQ(t.a.yaw_rad, 3.0);

  hal::ImuSample s;
  s.stamp = 99;
  s.attitude = {0.05, -0.1, 1.2};
  s.angular_velocity = {0.1, 0.2, 0.3};
  s.linear_acceleration = {0.0, 0.5, 1.62};
  record::encode_imu(b, s, "base_link");
  const hal::ImuSample u = record::decode_imu(b);
  EXPECT_EQ(u.stamp, 99);
  EXPECT_NEAR(u.attitude.roll_rad, 0.05, 1e-12);
  EXPECT_NEAR(u.attitude.pitch_rad, -0.1, 1e-12);
  EXPECT_NEAR(u.attitude.yaw_rad, 1.2, 1e-12);
  EXPECT_EQ(u.linear_acceleration.z, 1.62);
}

TEST(HalMessages, ForeignOrDamagedImagesAreErrors) {
  std::vector<std::uint8_t> b;
  cv::Mat img(4, 4, CV_8UC1, cv::Scalar(9));
  record::encode_image(b, 0, "f", img);
  std::vector<std::uint8_t> cut(b.begin(), b.end() - 3);
  EXPECT_THROW(record::decode_image(cut), std::out_of_range);
  cv::Mat wide(2, 2, CV_16UC1, cv::Scalar(1));
  record::encode_image(b, 0, "f", wide);  // written as bgr8/mono8 by channel count: mono8 of 2x2 16-bit
  EXPECT_THROW(record::decode_image(std::vector<std::uint8_t>(b.begin(), b.begin() + 20)), std::out_of_range);
}

// ---- the recorder -------------------------------------------------------------------------------

/// Collects what the recorder writes, by topic.
class MemorySink final : public record::MessageSink {
 public:
  std::uint16_t add_cdr_channel(const std::string& topic, const std::string& ros_type,
                                const std::map<std::string, std::string>& metadata) override {
    std::lock_guard<std::mutex> l(m_);
    topics_.push_back(topic);
    types_[topic] = ros_type;
    meta_[topic] = metadata;
    return static_cast<std::uint16_t>(topics_.size() - 1);
  }
  void write(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t,
             std::span<const std::uint8_t> data) override {
    std::lock_guard<std::mutex> l(m_);
    messages_[topics_.at(channel)].push_back({sequence, log_time, std::vector<std::uint8_t>(data.begin(), data.end())});
  }
  void add_metadata(const std::string& name, const std::map<std::string, std::string>& values) override {
    std::lock_guard<std::mutex> l(m_);
    metadata_[name] = values;
  }
  struct Msg {
    std::uint32_t sequence;
    std::uint64_t log_time;
    std::vector<std::uint8_t> data;
  };
  std::map<std::string, std::vector<Msg>> messages_;
  std::map<std::string, std::string> types_;
  std::map<std::string, std::map<std::string, std::string>> meta_;
  std::map<std::string, std::map<std::string, std::string>> metadata_;

 private:
  std::mutex m_;
  std::vector<std::string> topics_;
};

class ManualClock final : public Clock {
 public:
  TimeNs now() const override { return t.load(); }
  void sleep_until(TimeNs u) override { t.store(std::max(t.load(), u)); }
  bool simulated() const override { return true; }
  std::atomic<TimeNs> t{10 * kNsPerSec};  // read by the recorder's writer thread
};

/// A camera whose frame k (k = 0, 1, ...) is due at k * 100 ms and has every pixel = k.
class CountingCamera final : public hal::Camera {
 public:
  CountingCamera() : pool_(hal::make_frame_pool(8, 6, hal::PixelFormat::kMono8)) {}
  const std::string& id() const override { return id_; }
  void start() override {}
  void stop() override {}
  hal::CameraFormat format() const override { return {8, 6, hal::PixelFormat::kMono8, 10.0}; }
  hal::CameraStats stats() const override { return {}; }
  bool latest(TimeNs now, hal::FrameLease& out) override {
    const std::int64_t k = now / (100 * kNsPerMs);
    if (k != published_) {
      hal::Frame* f = pool_->begin_write();
      if (f == nullptr) return false;
      f->image.setTo(cv::Scalar(static_cast<double>(k % 256)));
      f->capture_time = k * 100 * kNsPerMs;
      f->sequence = static_cast<std::uint64_t>(k);
      pool_->commit();
      published_ = k;
    }
    out = pool_->acquire();
    return static_cast<bool>(out);
  }

 private:
  std::string id_ = "front";
  std::unique_ptr<hal::FramePool> pool_;
  std::int64_t published_ = -1;
};

/// Two wheels turning at 1 and 2 rad/s, sampled every 10 ms (a history of everything).
class RampEncoders final : public hal::WheelEncoders {
 public:
  const std::string& id() const override { return id_; }
  void start() override {}
  void stop() override {}
  hal::EncoderStats stats() const override { return {}; }
  const std::vector<std::string>& wheel_names() const override { return names_; }
  bool latest(std::size_t w, TimeNs now, hal::AngleSample& out) const override {
    const TimeNs t = now / (10 * kNsPerMs) * (10 * kNsPerMs);
    out = {t, static_cast<double>(w + 1) * to_seconds(t)};
    return true;
  }
  bool angle_at(std::size_t w, TimeNs t, double& angle) const override {
    if (t < 0) return false;
    angle = static_cast<double>(w + 1) * to_seconds(t);
    return true;
  }
  std::size_t samples_since(std::size_t w, TimeNs after, TimeNs now, std::span<hal::AngleSample> out) const override {
    std::size_t n = 0;
    for (TimeNs t = std::max<TimeNs>(0, (after / (10 * kNsPerMs) + 1) * 10 * kNsPerMs); t <= now && n < out.size();
         t += 10 * kNsPerMs)
      out[n++] = {t, static_cast<double>(w + 1) * to_seconds(t)};
    return n;
  }

 private:
  std::string id_ = "wheels";
  std::vector<std::string> names_ = {"left", "right"};
};

TEST(HalRecorder, RecordsFramesSamplesAndQueryAnswersOnlyWhileStarted) {
  ManualClock clock;
  MemorySink sink;
  record::HalRecorder rec({.frames_per_camera = 8, .poll_period = kNsPerMs});
  auto cam_dev = rec.wrap(std::make_unique<CountingCamera>());
  auto enc_dev = rec.wrap(std::make_unique<RampEncoders>());
  auto* cam = dynamic_cast<hal::Camera*>(cam_dev.get());
  auto* enc = dynamic_cast<hal::WheelEncoders*>(enc_dev.get());
  ASSERT_NE(cam, nullptr);
  ASSERT_NE(enc, nullptr);
  EXPECT_EQ(enc->wheel_names(), (std::vector<std::string>{"left", "right"}));

  hal::FrameLease lease;
  double angle = 0;
  ASSERT_TRUE(cam->latest(clock.now(), lease));  // before start: forwarded, not recorded
  ASSERT_TRUE(enc->angle_at(0, clock.now(), angle));
  EXPECT_TRUE(sink.messages_.empty());

  rec.start(sink, clock);
  EXPECT_EQ(sink.metadata_["regolith_hal"]["time_origin_ns"], std::to_string(10 * kNsPerSec));
  EXPECT_EQ(sink.meta_["/hal/encoders/wheels/samples"]["wheels"], "left,right");
  EXPECT_EQ(sink.types_["/hal/cameras/front/image"], "sensor_msgs/msg/Image");
  for (int i = 0; i < 5; ++i) {
    clock.t += 100 * kNsPerMs;
    ASSERT_TRUE(cam->latest(clock.now(), lease));
    ASSERT_TRUE(cam->latest(clock.now(), lease));  // the same frame twice: recorded once
    ASSERT_TRUE(enc->angle_at(1, clock.now() - 5 * kNsPerMs, angle));
    EXPECT_FALSE(enc->angle_at(1, -1, angle));
  }
  rec.stop();
  EXPECT_EQ(sink.metadata_["regolith_hal_end"]["time_end_ns"], std::to_string(10 * kNsPerSec + 500 * kNsPerMs));

  const auto& frames = sink.messages_["/hal/cameras/front/image"];
  ASSERT_EQ(frames.size(), 5u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const record::DecodedImage d = record::decode_image(frames[i].data);
    EXPECT_EQ(frames[i].sequence, 101 + i);
    EXPECT_EQ(d.stamp, static_cast<TimeNs>(101 + i) * 100 * kNsPerMs);
    EXPECT_EQ(frames[i].log_time, static_cast<std::uint64_t>(d.stamp));  // logged at capture (ROS offset 0 here)
    EXPECT_EQ(d.image.at<std::uint8_t>(2, 3), (101 + i) % 256);
  }
  const auto& queries = sink.messages_["/hal/encoders/wheels/queries"];
  ASSERT_EQ(queries.size(), 10u);
  const record::DecodedWheelAngle q0 = record::decode_wheel_angle(queries[0].data);
  EXPECT_EQ(q0.wheel, "right");
  EXPECT_EQ(q0.stamp, 10 * kNsPerSec + 95 * kNsPerMs);
  EXPECT_EQ(q0.angle, 2.0 * to_seconds(10 * kNsPerSec + 95 * kNsPerMs));
  EXPECT_EQ(queries[0].log_time, static_cast<std::uint64_t>(10 * kNsPerSec + 100 * kNsPerMs));  // when it was asked
  EXPECT_TRUE(std::isnan(record::decode_wheel_angle(queries[1].data).angle));
  // Every sample of both wheels from 0 to the end: 0..10.5 s every 10 ms.
  const auto& samples = sink.messages_["/hal/encoders/wheels/samples"];
  EXPECT_EQ(samples.size(), 2u * 1051u);
  // Both wheels' samples in one channel, merged by stamp: its log times never go back, although
  // the first pass finds 1001 samples of each wheel.
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const record::DecodedWheelAngle s = record::decode_wheel_angle(samples[i].data);
    EXPECT_EQ(samples[i].log_time, static_cast<std::uint64_t>(s.stamp)) << i;
    if (i > 0) {
      EXPECT_GE(samples[i].log_time, samples[i - 1].log_time) << i;
    }
  }
  const auto counts = rec.counts();
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts[0].kind, "camera");
  EXPECT_EQ(counts[0].recorded, 5u);
  EXPECT_EQ(counts[0].dropped, 0u);
  EXPECT_EQ(counts[1].recorded, 10u + 2u * 1051u);
  EXPECT_EQ(rec.dropped(), 0u);

  // After stop() the wrappers forward only.
  clock.t += 100 * kNsPerMs;
  ASSERT_TRUE(cam->latest(clock.now(), lease));
  EXPECT_EQ(sink.messages_["/hal/cameras/front/image"].size(), 5u);
}

TEST(HalRecorder, AFullRingDropsAndCountsInRealTimeMode) {
  ManualClock clock;
  MemorySink sink;
  // One slot and a writer that does not wake up during the test: the 2nd and 3rd frames find the
  // ring full (real-time mode drops, never waits).
  record::HalRecorder rec({.frames_per_camera = 1, .poll_period = 3600 * kNsPerSec});
  auto dev = rec.wrap(std::make_unique<CountingCamera>());
  auto* cam = dynamic_cast<hal::Camera*>(dev.get());
  rec.start(sink, clock);
  hal::FrameLease lease;
  for (int i = 0; i < 3; ++i) {
    clock.t += 100 * kNsPerMs;
    ASSERT_TRUE(cam->latest(clock.now(), lease));
  }
  // The writer thread drained once at its first wake-up (possibly before the frames): at most one
  // frame was written then; stop() drains the rest.
  rec.stop();
  const auto c = rec.counts();
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].recorded + c[0].dropped, 3u);
  EXPECT_GE(c[0].dropped, 1u);
  EXPECT_EQ(sink.messages_["/hal/cameras/front/image"].size(), c[0].recorded);
}

TEST(HalMessages, CanFramesComeBackExactlyAndDamagedOnesAreErrors) {
  std::vector<std::uint8_t> buf;
  hal::CanFrame c;
  c.id = 0x18FF0010;
  c.extended = true;
  c.len = 5;
  for (int i = 0; i < 5; ++i) c.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(0xA0 + i);
  c.stamp = 12 * kNsPerSec + 345;
  record::encode_can_frame(buf, c, "wheels");
  // can_msgs/Frame: 4 encapsulation + header (8 + 4 + "wheels\0" 7 -> 19, padded to 20) + id 4 +
  // 4 x uint8 + uint8[8] (no length).
  EXPECT_EQ(buf.size(), 4u + 20u + 4u + 4u + 8u);
  hal::CanFrame d = record::decode_can_frame(buf, false);
  EXPECT_EQ(d.id, c.id);
  EXPECT_TRUE(d.extended);
  EXPECT_FALSE(d.remote || d.error || d.fd);
  EXPECT_EQ(d.len, 5);
  EXPECT_EQ(d.data, c.data);
  EXPECT_EQ(d.stamp, c.stamp);

  hal::CanFrame fd;
  fd.fd = true;
  fd.id = 0x123;
  fd.len = 64;
  for (int i = 0; i < 64; ++i) fd.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(i);
  record::encode_can_frame(buf, fd, "wheels");
  d = record::decode_can_frame(buf, true);
  EXPECT_TRUE(d.fd);
  EXPECT_EQ(d.len, 64);
  EXPECT_EQ(d.data, fd.data);
  EXPECT_THROW(record::decode_can_frame(std::span<const std::uint8_t>(buf).first(30), true), std::out_of_range);

  record::encode_can_frame(buf, c, "");
  buf[buf.size() - 9] = 9;  // dlc 9
  EXPECT_THROW(record::decode_can_frame(buf, false), std::invalid_argument);
}

/// An encoder set on a CAN bus: no samples, only a history of raw frames.
class BusEncoders final : public hal::WheelEncoders {
 public:
  const std::string& id() const override { return id_; }
  void start() override {}
  void stop() override {}
  hal::EncoderStats stats() const override { return {}; }
  const std::vector<std::string>& wheel_names() const override { return names_; }
  bool latest(std::size_t, TimeNs, hal::AngleSample&) const override { return false; }
  bool angle_at(std::size_t, TimeNs, double&) const override { return false; }
  bool reads_can() const override { return true; }
  std::size_t can_frames(std::uint64_t& cursor, TimeNs, std::span<hal::CanFrame> out,
                         std::uint64_t& missed) const override {
    return history.since(cursor, out, missed);
  }
  hal::CanFrameHistory history{8};

 private:
  std::string id_ = "bus";
  std::vector<std::string> names_ = {"w"};
};

TEST(HalRecorder, RecordsTheRawCanFramesAndCountsTheOnesTheBackendNoLongerHeld) {
  ManualClock clock;
  MemorySink sink;
  auto bus = std::make_unique<BusEncoders>();
  BusEncoders* raw = bus.get();
  // 12 frames into a history of 8 before the first drain: frames 0..3 are gone (dropped), 4..11
  // are recorded with their numbers as MCAP sequence; frame 7 is CAN FD.
  for (std::uint32_t i = 0; i < 12; ++i) {
    hal::CanFrame f;
    f.id = 0x100 + i;
    f.fd = i == 7;
    f.len = 1;
    f.data[0] = static_cast<std::uint8_t>(i);
    f.stamp = static_cast<TimeNs>(i) * kNsPerMs;
    raw->history.push(f);
  }
  record::HalRecorder rec({.poll_period = 3600 * kNsPerSec});
  auto dev = rec.wrap(std::move(bus));
  rec.start(sink, clock);
  rec.stop();
  EXPECT_EQ(sink.types_["/hal/encoders/bus/can"], "can_msgs/msg/Frame");
  EXPECT_EQ(sink.types_["/hal/encoders/bus/can_fd"], "ros2_socketcan_msgs/msg/FdFrame");
  const auto& classic = sink.messages_["/hal/encoders/bus/can"];
  ASSERT_EQ(classic.size(), 7u);
  EXPECT_EQ(classic.front().sequence, 4u);
  EXPECT_EQ(classic.back().sequence, 11u);
  EXPECT_EQ(record::decode_can_frame(classic.back().data, false).id, 0x10Bu);
  EXPECT_EQ(record::decode_can_frame(classic.back().data, false).stamp, 11 * kNsPerMs);
  const auto& fd = sink.messages_["/hal/encoders/bus/can_fd"];
  ASSERT_EQ(fd.size(), 1u);
  EXPECT_EQ(fd[0].sequence, 7u);
  EXPECT_EQ(record::decode_can_frame(fd[0].data, true).data[0], 7);
  const auto c = rec.counts();
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].recorded, 8u);
  EXPECT_EQ(c[0].dropped, 4u);
}

}  // namespace
