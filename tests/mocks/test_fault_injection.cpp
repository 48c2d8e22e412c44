#include <array>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "mock_test_util.hpp"
#include "regolith/hal/plausible_encoders.hpp"
#include "regolith/hal/plausible_imu.hpp"
#include "regolith/hal/stamp_checked_camera.hpp"

namespace regolith::mocks::test {
namespace {

// 10 uniform images, image i has value 10 * (i + 1); 10 Hz; looping.
std::string camera_yaml(Fixture& fx, const std::string& faults) {
  std::filesystem::create_directories(fx.dir.file("frames"));
  for (int i = 0; i < 10; ++i) {
    cv::imwrite(fx.dir.file("frames/f" + std::to_string(i) + ".png"),
                cv::Mat(24, 32, CV_8UC1, cv::Scalar(10 * (i + 1))));
  }
  return "backend: fault_injection\ninner: {backend: image_files, path: frames, rate_hz: 10}\n" + faults;
}
int expected_pixel(std::uint64_t seq) {
  return 10 * static_cast<int>(seq % 10 + 1);
}
const TimeNs kFrame = 100 * kNsPerMs;

// Polls once per frame period and returns the delivered sequence numbers (-1 = nothing).
std::vector<std::int64_t> poll(hal::Camera& cam, TimeNs t0, int frames, int* bad_pixels = nullptr) {
  std::vector<std::int64_t> seqs;
  hal::FrameLease f;
  for (int k = 0; k < frames; ++k) {
    if (!cam.latest(t0 + k * kFrame, f)) {
      seqs.push_back(-1);
      continue;
    }
    seqs.push_back(static_cast<std::int64_t>(f->sequence));
    if (bad_pixels != nullptr && f->image.at<std::uint8_t>(3, 3) != expected_pixel(f->sequence)) ++*bad_pixels;
  }
  return seqs;
}

TEST(FaultCamera, DropRateWithinToleranceAndDeterministic) {
  Fixture fx;
  const std::string yaml = camera_yaml(fx, "drop_rate: 0.3\nseed: 5\n");
  auto a = fx.camera(yaml);
  auto b = fx.camera(yaml);
  auto c = fx.camera(camera_yaml(fx, "drop_rate: 0.3\nseed: 6\n"));
  a->start();
  b->start();
  c->start();
  const TimeNs t0 = fx.clock.now();
  const int n = 3000;
  int bad = 0;
  const auto sa = poll(*a, t0, n, &bad);
  const auto sb = poll(*b, t0, n);
  const auto sc = poll(*c, t0, n);
  EXPECT_EQ(sa, sb) << "same seed, same clock sequence -> same frames";
  EXPECT_NE(sa, sc);
  EXPECT_EQ(bad, 0);
  int fresh = 0;
  for (int k = 0; k < n; ++k) {
    fresh += sa[static_cast<std::size_t>(k)] == k;
    if (sa[static_cast<std::size_t>(k)] >= 0) {
      EXPECT_LE(sa[static_cast<std::size_t>(k)], k);  // never from the future
    }
  }
  const auto st = a->stats();
  EXPECT_EQ(st.frames + st.dropped, static_cast<std::uint64_t>(n));
  EXPECT_EQ(st.frames, static_cast<std::uint64_t>(fresh));
  const double rate = static_cast<double>(st.dropped) / n;
  EXPECT_NEAR(rate, 0.3, 0.03) << "measured drop rate " << rate;
}

TEST(FaultCamera, FreezeKeepsContentButAdvancesSequence) {
  Fixture fx;
  auto cam = fx.camera(camera_yaml(fx, "freeze_after: 4\n"));
  cam->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease f;
  for (int k = 0; k < 12; ++k) {
    ASSERT_TRUE(cam->latest(t0 + k * kFrame, f));
    EXPECT_EQ(f->sequence, static_cast<std::uint64_t>(k));
    EXPECT_EQ(f->capture_time, t0 + k * kFrame);
    EXPECT_EQ(f->image.at<std::uint8_t>(0, 0), expected_pixel(k < 4 ? static_cast<std::uint64_t>(k) : 3u)) << k;
  }
}

TEST(FaultCamera, DisconnectReconnectCountersAndStates) {
  Fixture fx;
  auto cam = fx.camera(camera_yaml(fx, "disconnect_after: 10\nreconnect_after: 5\n"));
  EXPECT_EQ(cam->stats().state, hal::DeviceState::kStopped);
  cam->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease f;
  for (int k = 0; k < 30; ++k) {
    const TimeNs now = t0 + k * kFrame + kFrame / 2;
    fx.clock.set(now);
    const bool got = cam->latest(now, f);
    const auto st = cam->stats();
    if (k < 10) {
      EXPECT_TRUE(got) << k;
      EXPECT_EQ(st.state, hal::DeviceState::kStreaming) << k;
      EXPECT_EQ(st.faults, 0u);
    } else if (k < 15) {
      EXPECT_FALSE(got) << k;
      EXPECT_EQ(st.state, hal::DeviceState::kFaulted) << k;
      EXPECT_EQ(st.faults, 1u);
      EXPECT_EQ(st.recoveries, 0u);
    } else {
      ASSERT_TRUE(got) << k;
      EXPECT_EQ(f->sequence, static_cast<std::uint64_t>(k));
      EXPECT_EQ(st.state, hal::DeviceState::kStreaming) << k;
      EXPECT_EQ(st.faults, 1u);
      EXPECT_EQ(st.recoveries, 1u);
    }
  }
  EXPECT_EQ(cam->stats().frames, 25u);
  // Stopped, the device keeps what happened while it ran (the final summary reads it after the
  // stop): an hour later the counters are those of its stop.
  cam->stop();
  fx.clock.set(fx.clock.now() + 3600 * kNsPerSec);
  EXPECT_EQ(cam->stats().state, hal::DeviceState::kStopped);
  EXPECT_EQ(cam->stats().faults, 1u);
  EXPECT_EQ(cam->stats().recoveries, 1u);
  EXPECT_EQ(cam->stats().frames, 25u);
  // Repeating outages: up 10, down 5, ... -> after 4 full cycles + 12 frames: 5 faults, 4 recoveries.
  auto rep = fx.camera(camera_yaml(fx, "disconnect_after: 10\nreconnect_after: 5\nrepeat: true\n"));
  rep->start();
  fx.clock.set(fx.clock.now() + (4 * 15 + 12) * kFrame);
  const auto st = rep->stats();
  EXPECT_EQ(st.faults, 5u);
  EXPECT_EQ(st.recoveries, 4u);
  EXPECT_EQ(st.state, hal::DeviceState::kFaulted);
  // Without reconnect_after the device stays faulted.
  auto dead = fx.camera(camera_yaml(fx, "disconnect_after: 3\n"));
  dead->start();
  EXPECT_FALSE(dead->latest(fx.clock.now() + 100 * kFrame, f));
  fx.clock.set(fx.clock.now() + 100 * kFrame);
  EXPECT_EQ(dead->stats().recoveries, 0u);
  EXPECT_EQ(dead->stats().state, hal::DeviceState::kFaulted);
}

TEST(FaultCamera, DelayDeliversWhatTheInnerHadEarlier) {
  Fixture fx;
  auto cam = fx.camera(camera_yaml(fx, "delay_ms: 250\n"));
  cam->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease f;
  EXPECT_FALSE(cam->latest(t0 + 200 * kNsPerMs, f)) << "nothing has arrived yet";
  ASSERT_TRUE(cam->latest(t0 + kNsPerSec, f));
  EXPECT_EQ(f->sequence, 7u);  // captured at 700 ms <= 1000 - 250
  EXPECT_EQ(f->capture_time, t0 + 700 * kNsPerMs);
  EXPECT_EQ(f->image.at<std::uint8_t>(0, 0), expected_pixel(7));
}

TEST(FaultCamera, ClockStepsAreCaughtByTheStampCheckEveryCameraIsReadThrough) {
  // Frames 5..9 stamped 10 s ahead (a device clock stepped forward, then back): the check every
  // deployment reads cameras through (hal::StampCheckedCamera) withholds exactly those five, each
  // counted once however often it is polled, and the camera reads on from frame 10 (stamps back
  // on the process clock; that step back is counted).
  Fixture fx;
  hal::StampCheckedCamera cam(
      fx.camera(camera_yaml(fx, "stamp_step_after: 5\nstamp_step_for: 5\nstamp_step_ms: 10000\n")), fx.clock);
  cam.start();
  const TimeNs t0 = fx.clock.now();
  std::vector<std::int64_t> seen;
  hal::FrameLease f;
  for (int k = 0; k < 15; ++k)
    for (int again = 0; again < 3; ++again) {            // three readers per frame period
      fx.clock.set(t0 + k * kFrame + again * kNsPerMs);  // read a little after the cycle's start
      const bool got = cam.latest(t0 + k * kFrame, f);
      if (again == 0) seen.push_back(got ? static_cast<std::int64_t>(f->sequence) : -1);
      if (got) {
        EXPECT_LE(f->capture_time, t0 + k * kFrame) << "never a frame from the future";
      }
    }
  EXPECT_EQ(seen, (std::vector<std::int64_t>{0, 1, 2, 3, 4, -1, -1, -1, -1, -1, 10, 11, 12, 13, 14}));
  const hal::CameraStats st = cam.stats();
  EXPECT_EQ(st.bad_stamps, 5u);
  EXPECT_EQ(st.frames, 10u) << "delivered: 15 from the device less the 5 withheld";
  EXPECT_EQ(st.stamp_steps, 0u) << "frame 10 is stamped after frame 4, the last one delivered";
  EXPECT_EQ(cam.counters().rejected, 5u);

  // A step back (frames 5.. stamped 2 s early, for good): delivered, their age is what it is, and
  // the step is counted once.
  Fixture fx2;
  hal::StampCheckedCamera back(fx2.camera(camera_yaml(fx2, "stamp_step_after: 5\nstamp_step_ms: -2000\n")), fx2.clock);
  back.start();
  const TimeNs t1 = fx2.clock.now();
  hal::FrameLease g;  // released before `back` (a lease must not outlive its camera's pool)
  for (int k = 0; k < 10; ++k) {
    fx2.clock.set(t1 + k * kFrame);
    ASSERT_TRUE(back.latest(t1 + k * kFrame, g));
    EXPECT_EQ(g->sequence, static_cast<std::uint64_t>(k));
    EXPECT_EQ(g->capture_time, t1 + k * kFrame - (k >= 5 ? 2 * kNsPerSec : 0));
  }
  EXPECT_EQ(back.stats().stamp_steps, 1u);
  EXPECT_EQ(back.stats().bad_stamps, 0u);
}

TEST(FaultCamera, CorruptFramesAreFlaggedAndDamaged) {
  Fixture fx;
  auto cam = fx.camera(camera_yaml(fx, "corrupt_rate: 0.5\nseed: 11\n"));
  cam->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease f;
  int flagged = 0, damaged_unflagged = 0, flagged_intact = 0;
  const int n = 600;
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(cam->latest(t0 + k * kFrame, f));
    const cv::Mat expect(24, 32, CV_8UC1, cv::Scalar(expected_pixel(f->sequence)));
    const bool damaged = cv::norm(f->image, expect, cv::NORM_INF) > 0;
    if (f->corrupt) {
      ++flagged;
      flagged_intact += !damaged;
    } else {
      damaged_unflagged += damaged;
    }
  }
  EXPECT_EQ(damaged_unflagged, 0);
  EXPECT_EQ(flagged_intact, 0);
  EXPECT_EQ(cam->stats().corrupt, static_cast<std::uint64_t>(flagged));
  EXPECT_NEAR(static_cast<double>(flagged) / n, 0.5, 0.06);
}

TEST(FaultCamera, InnerParametersAreValidated) {
  Fixture fx;
  std::string msg = config_error([&] { fx.camera(camera_yaml(fx, "") + "drop_rate: 1.5\n"); });
  EXPECT_NE(msg.find("drop_rate"), std::string::npos) << msg;
  msg = config_error(
      [&] { fx.camera("backend: fault_injection\ninner: {backend: image_files, path: frames, rate: 10}\n"); });
  EXPECT_NE(msg.find("inner.rate"), std::string::npos) << msg;
  msg = config_error([&] { fx.camera("backend: fault_injection\ninner: {backend: image_file}\n"); });
  EXPECT_NE(msg.find("did you mean 'image_files'"), std::string::npos) << msg;
  msg = config_error([&] { fx.camera("backend: fault_injection\n"); });
  EXPECT_NE(msg.find("inner: required section is missing"), std::string::npos) << msg;
}

// ---- encoders -----------------------------------------------------------------------------------

// Inner: one wheel at 1 rad/s sampled at 100 Hz, so a sample's angle equals its time in seconds.
std::string encoder_yaml(const std::string& faults) {
  return "backend: fault_injection\ninner: {backend: scripted, wheels: [w], speed_rad_s: 1, sample_rate_hz: 100}\n"
         "sample_rate_hz: 100\n" +
         faults;
}
const TimeNs kSample = 10 * kNsPerMs;

TEST(FaultEncoders, DropRateAndPreviousSampleServed) {
  Fixture fx;
  auto enc = fx.encoders(encoder_yaml("drop_rate: 0.2\nseed: 9\n"));
  auto same = fx.encoders(encoder_yaml("drop_rate: 0.2\nseed: 9\n"));
  enc->start();
  same->start();
  const TimeNs t0 = fx.clock.now();
  const int n = 5000;
  int fresh = 0;
  for (int k = 0; k < n; ++k) {
    hal::AngleSample s, s2;
    const TimeNs now = t0 + k * kSample;
    if (!enc->latest(0, now, s)) {
      EXPECT_LT(k, 5) << "a run of dropped samples at the very start is possible";
      continue;
    }
    ASSERT_TRUE(same->latest(0, now, s2));
    ASSERT_EQ(s.stamp, s2.stamp);
    EXPECT_LE(s.stamp, now);
    EXPECT_NEAR(s.angle, to_seconds(s.stamp - t0), 1e-9);  // an older sample, but a true one
    fresh += s.stamp == now;
  }
  EXPECT_NEAR(1.0 - static_cast<double>(fresh) / n, 0.2, 0.02);
}

TEST(FaultEncoders, DisconnectReconnect) {
  Fixture fx;
  auto enc = fx.encoders(encoder_yaml("disconnect_after: 50\nreconnect_after: 20\n"));
  enc->start();
  const TimeNs t0 = fx.clock.now();
  hal::AngleSample s;
  for (int k = 0; k < 100; ++k) {
    const TimeNs now = t0 + k * kSample + kSample / 2;
    fx.clock.set(now);
    const bool got = enc->latest(0, now, s);
    const auto st = enc->stats();
    if (k >= 50 && k < 70) {
      EXPECT_FALSE(got) << k;
      EXPECT_EQ(st.state, hal::DeviceState::kFaulted);
      EXPECT_TRUE(enc->stale(0, now, 5 * kSample));
    } else {
      ASSERT_TRUE(got) << k;
      EXPECT_EQ(s.stamp, t0 + k * kSample);
      EXPECT_EQ(st.state, hal::DeviceState::kStreaming);
    }
    EXPECT_EQ(st.faults, k >= 50 ? 1u : 0u) << k;
  }
  // After reconnecting, interpolation works again inside the new history.
  double a = 0;
  ASSERT_TRUE(enc->angle_at(0, t0 + 95 * kSample, a));
  EXPECT_NEAR(a, 0.95, 1e-9);
  // Stopped: the samples delivered and the outage stay counted (they read 0 before).
  const auto running = enc->stats();
  EXPECT_GE(running.samples, 99u);
  enc->stop();
  fx.clock.set(fx.clock.now() + 3600 * kNsPerSec);
  const auto stopped = enc->stats();
  EXPECT_EQ(stopped.state, hal::DeviceState::kStopped);
  EXPECT_EQ(stopped.samples, running.samples);
  EXPECT_EQ(stopped.faults, 1u);
}

TEST(FaultEncoders, DelayFreezeAndCorruption) {
  Fixture fx;
  auto delayed = fx.encoders(encoder_yaml("delay_ms: 30\n"));
  auto frozen = fx.encoders(encoder_yaml("freeze_after: 100\n"));
  auto corrupt = fx.encoders(encoder_yaml("corrupt_rate: 0.1\nseed: 2\n"));
  delayed->start();
  frozen->start();
  corrupt->start();
  const TimeNs t0 = fx.clock.now();
  hal::AngleSample s;
  ASSERT_TRUE(delayed->latest(0, t0 + 500 * kNsPerMs, s));
  EXPECT_EQ(s.stamp, t0 + 470 * kNsPerMs);
  EXPECT_NEAR(s.angle, 0.47, 1e-9);
  ASSERT_TRUE(frozen->latest(0, t0 + 1500 * kNsPerMs, s));
  EXPECT_EQ(s.stamp, t0 + 1500 * kNsPerMs);
  EXPECT_NEAR(s.angle, 0.99, 1e-9) << "angle of sample 99, the last one before the freeze";
  ASSERT_TRUE(frozen->latest(0, t0 + 990 * kNsPerMs, s));
  EXPECT_NEAR(s.angle, 0.99, 1e-9);
  int garbage = 0;
  const int n = 4000;
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(corrupt->latest(0, t0 + k * kSample, s));
    garbage += std::abs(s.angle - to_seconds(s.stamp - t0)) > 1e-6;
  }
  EXPECT_NEAR(static_cast<double>(garbage) / n, 0.1, 0.015);
}

TEST(FaultEncoders, RecordersGetExactlyTheSamplesTheConsumerReceived) {
  // samples_since (what a HAL recorder reads between polls) against latest() polled at every
  // sample: the same stamps, no dropped sample and nothing from the outage, the same corrupted
  // angles. Before, the decorator served only the newest sample per recorder poll.
  Fixture fx;
  auto enc = fx.encoders(
      encoder_yaml("drop_rate: 0.2\ncorrupt_rate: 0.1\nseed: 4\ndisconnect_after: 300\nreconnect_after: 50\n"));
  enc->start();
  const TimeNs t0 = fx.clock.now();
  std::vector<hal::AngleSample> polled;
  for (int k = 0; k < 600; ++k) {
    const TimeNs now = t0 + k * kSample;
    fx.clock.set(now);
    hal::AngleSample s;
    if (enc->latest(0, now, s) && (polled.empty() || s.stamp > polled.back().stamp)) polled.push_back(s);
  }
  std::vector<hal::AngleSample> recorded;
  std::array<hal::AngleSample, 50> buf{};
  TimeNs after = std::numeric_limits<TimeNs>::min();
  for (std::size_t got; (got = enc->samples_since(0, after, t0 + 599 * kSample, buf)) > 0;) {
    recorded.insert(recorded.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(got));
    after = buf[got - 1].stamp;
  }
  ASSERT_EQ(recorded.size(), polled.size());
  int corrupt = 0;
  for (std::size_t i = 0; i < polled.size(); ++i) {
    EXPECT_EQ(recorded[i].stamp, polled[i].stamp) << i;
    EXPECT_EQ(recorded[i].angle, polled[i].angle) << i;
    const double k = to_seconds(recorded[i].stamp - t0) / to_seconds(kSample);
    EXPECT_FALSE(k >= 300 && k < 350) << "a sample from the outage was recorded: " << k;
    corrupt += std::abs(recorded[i].angle - to_seconds(recorded[i].stamp - t0)) > 1e-6;
  }
  EXPECT_NEAR(static_cast<double>(polled.size()), 550 * 0.8, 30) << "drops";
  EXPECT_GT(corrupt, 20);
}

TEST(PlausibleEncoders, CorruptSamplesNeverReachTheReaderAndAreCounted) {
  // What the application puts between every encoder device and its readers, over a 1 rad/s wheel
  // whose samples are 20 % garbage (+-1e4 rad): latest() and angle_at() give true angles only
  // (an older sample when the newest is garbage), every garbage sample met is counted once.
  Fixture fx;
  hal::PlausibleEncoders enc(fx.encoders(encoder_yaml("corrupt_rate: 0.2\nseed: 5\n")), {2.0});
  enc.start();
  const TimeNs t0 = fx.clock.now();
  const int n = 3000;
  int served = 0, older = 0;
  for (int k = 0; k < n; ++k) {
    const TimeNs now = t0 + k * kSample;
    fx.clock.set(now);
    hal::AngleSample s;
    if (!enc.latest(0, now, s)) continue;
    ++served;
    ASSERT_NEAR(s.angle, to_seconds(s.stamp - t0), 1e-9) << k;
    older += s.stamp < now;
    double a = 0.0;
    for (const TimeNs t : {now - kSample / 2, now, now + kSample / 3})  // inside the history and past its end
      if (k > 2 && enc.angle_at(0, t, a)) {
        ASSERT_NEAR(a, to_seconds(t - t0), 1e-6) << k << " at +" << (t - now);
      }
  }
  EXPECT_GT(served, n - 10);
  EXPECT_NEAR(static_cast<double>(older) / n, 0.2, 0.03);  // the newest was garbage: the one before
  const auto st = enc.stats();
  EXPECT_NEAR(static_cast<double>(st.rejected) / n, 0.2, 0.03) << st.rejected;
  EXPECT_EQ(enc.counters().rejected, st.rejected);

  // A clean wheel loses nothing: every sample served as it is, none rejected.
  Fixture fx2;
  hal::PlausibleEncoders clean(fx2.encoders(encoder_yaml("")), {2.0});
  clean.start();
  const TimeNs u0 = fx2.clock.now();
  for (int k = 0; k < 1000; ++k) {
    fx2.clock.set(u0 + k * kSample);
    hal::AngleSample s;
    ASSERT_TRUE(clean.latest(0, u0 + k * kSample, s)) << k;
    EXPECT_EQ(s.stamp, u0 + k * kSample);
  }
  EXPECT_EQ(clean.stats().rejected, 0u);
}

// ---- IMU -----------------------------------------------------------------------------------------

// A scripted IMU turning at 10 deg/s (yaw = 0.1745 t rad), 100 Hz, level.
std::string imu_yaml(const std::string& faults) {
  return "backend: fault_injection\ninner: {backend: scripted, rate_hz: 100, yaw_rate_deg_s: 10}\nsample_rate_hz: "
         "100\n" +
         faults;
}
constexpr double kYawRate = 10.0 * 3.14159265358979323846 / 180.0;

TEST(FaultImu, DropsServeTheSampleBeforeDeterministically) {
  Fixture fx;
  auto imu = fx.imu(imu_yaml("drop_rate: 0.25\nseed: 3\n"));
  auto same = fx.imu(imu_yaml("drop_rate: 0.25\nseed: 3\n"));
  imu->start();
  same->start();
  const TimeNs t0 = fx.clock.now();
  const int n = 4000;
  int fresh = 0;
  for (int k = 0; k < n; ++k) {
    const TimeNs now = t0 + k * kSample;
    hal::ImuSample s, s2;
    if (!imu->latest(now, s)) {
      EXPECT_LT(k, 5);
      continue;
    }
    ASSERT_TRUE(same->latest(now, s2));
    ASSERT_EQ(s.stamp, s2.stamp);
    EXPECT_LE(s.stamp, now);
    EXPECT_NEAR(s.attitude.yaw_rad, kYawRate * to_seconds(s.stamp - t0), 1e-9);  // older, but true
    fresh += s.stamp == now;
  }
  EXPECT_NEAR(1.0 - static_cast<double>(fresh) / n, 0.25, 0.02);
}

TEST(FaultImu, OutagesFreezeDelayAndCounters) {
  Fixture fx;
  auto imu = fx.imu(imu_yaml("disconnect_after: 100\nreconnect_after: 50\nrepeat: true\n"));
  auto frozen = fx.imu(imu_yaml("freeze_after: 20\n"));
  auto delayed = fx.imu(imu_yaml("delay_ms: 200\n"));
  for (auto* d : {imu.get(), frozen.get(), delayed.get()}) d->start();
  const TimeNs t0 = fx.clock.now();
  hal::ImuSample s;
  Attitude a;
  // up for 100 samples, down for 50, up again
  fx.clock.set(t0 + 120 * kSample);
  EXPECT_FALSE(imu->latest(fx.clock.now(), s));
  EXPECT_FALSE(imu->attitude_at(t0 + 50 * kSample, a)) << "a faulted device answers nothing";
  EXPECT_EQ(imu->counters().state, hal::DeviceState::kFaulted);
  EXPECT_EQ(imu->counters().faults, 1u);
  fx.clock.set(t0 + 170 * kSample);
  ASSERT_TRUE(imu->latest(fx.clock.now(), s));
  EXPECT_EQ(s.stamp, t0 + 170 * kSample);
  EXPECT_EQ(imu->counters().recoveries, 1u);
  EXPECT_EQ(imu->counters().state, hal::DeviceState::kStreaming);
  // Inside the outage the history has no samples: the attitude there is interpolated across it
  // from the last sample before and the first after.
  ASSERT_TRUE(imu->attitude_at(t0 + 125 * kSample, a));
  EXPECT_NEAR(a.yaw_rad, kYawRate * to_seconds(125 * kSample), 1e-9);  // linear yaw: exact

  ASSERT_TRUE(frozen->latest(fx.clock.now(), s));
  EXPECT_EQ(s.stamp, t0 + 170 * kSample) << "stamps advance";
  EXPECT_NEAR(s.attitude.yaw_rad, kYawRate * to_seconds(19 * kSample), 1e-9) << "content frozen";
  ASSERT_TRUE(frozen->attitude_at(t0 + 100 * kSample, a));
  EXPECT_NEAR(a.yaw_rad, kYawRate * to_seconds(19 * kSample), 1e-9);

  ASSERT_TRUE(delayed->latest(fx.clock.now(), s));
  EXPECT_EQ(s.stamp, t0 + 150 * kSample);
  EXPECT_FALSE(delayed->attitude_at(fx.clock.now(), a)) << "200 ms past the newest sample: beyond max_extrapolation_ms";
  ASSERT_TRUE(delayed->attitude_at(t0 + 150 * kSample + 20 * kNsPerMs, a));
  EXPECT_NEAR(a.yaw_rad, kYawRate * to_seconds(150 * kSample), 1e-9) << "held, not extrapolated";
}

TEST(PlausibleImu, DamagedSamplesNeverReachTheReaderAndAreCountedOnce) {
  // What the application puts between every IMU and its readers, over an IMU whose samples are
  // 20 % garbage (+-1e4): latest(), attitude_at() and samples_since() give true values only.
  Fixture fx;
  hal::PlausibleImu imu(fx.imu(imu_yaml("corrupt_rate: 0.2\nseed: 8\n")), fx.clock);
  imu.start();
  const TimeNs t0 = fx.clock.now();
  const int n = 3000;
  int served = 0, older = 0, attitudes = 0, exact = 0;
  for (int k = 0; k < n; ++k) {
    const TimeNs now = t0 + k * kSample;
    fx.clock.set(now);
    hal::ImuSample s;
    if (!imu.latest(now, s)) continue;
    ++served;
    ASSERT_NEAR(s.attitude.yaw_rad, kYawRate * to_seconds(s.stamp - t0), 1e-9) << k;
    ASSERT_TRUE(hal::plausible(s));
    older += s.stamp < now;
    Attitude a;
    const TimeNs t = now - kSample / 2;
    if (k > 2 && imu.attitude_at(t, a)) {
      ++attitudes;
      // exact between plausible samples; held (at most kMaxHold) when none after t exists yet
      const double err = std::abs(a.yaw_rad - kYawRate * to_seconds(t - t0));
      ASSERT_LE(err, kYawRate * to_seconds(hal::PlausibleImu::kMaxHold)) << k;
      exact += err < 1e-6;
    }
  }
  EXPECT_GT(served, n - 10);
  EXPECT_NEAR(static_cast<double>(older) / n, 0.2, 0.03);
  // served everywhere: between the plausible samples around t when the device's own interpolation
  // went through a damaged one (1 - 0.8^2 of the intervals)
  EXPECT_EQ(attitudes, n - 3);
  EXPECT_NEAR(static_cast<double>(exact) / n, 0.8, 0.03) << "held only when the newest sample is damaged";
  const std::uint64_t rejected = imu.counters().rejected;
  EXPECT_NEAR(static_cast<double>(rejected) / n, 0.2, 0.03) << rejected;
  // The recorder's view: plausible samples only, and reading them counts nothing twice.
  std::vector<hal::ImuSample> all(static_cast<std::size_t>(n));
  const std::size_t got = imu.samples_since(t0 - 1, t0 + (n - 1) * kSample, all);
  EXPECT_EQ(got + rejected, static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < got; ++i) ASSERT_TRUE(hal::plausible(all[i]));
  EXPECT_EQ(imu.counters().rejected, rejected);

  // Sanity of the limits themselves.
  hal::ImuSample ok;
  ok.attitude = {0.1, -0.2, 123.0};  // yaw is continuous: any finite value
  ok.angular_velocity = {0.5, 0, 0};
  ok.linear_acceleration = {0, 0, 9.81};
  EXPECT_TRUE(hal::plausible(ok));
  hal::ImuSample bad = ok;
  bad.attitude.pitch_rad = 1.6;
  EXPECT_FALSE(hal::plausible(bad));
  bad = ok;
  bad.angular_velocity.z = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(hal::plausible(bad));
  bad = ok;
  bad.linear_acceleration.x = 200.0;
  EXPECT_FALSE(hal::plausible(bad));
}

}  // namespace
}  // namespace regolith::mocks::test
