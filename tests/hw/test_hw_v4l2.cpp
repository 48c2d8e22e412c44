// Driver tests of the V4L2 backend against vivid (label hw; skipped when no vivid node exists).
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "hw_util.hpp"
#include "regolith/hal_v4l2/v4l2.hpp"

using namespace regolith;
using namespace regolith::hal;
using regolith::hwtest::wait_until;

namespace {

const v4l2::DeviceInfo* vivid_node(const std::vector<v4l2::DeviceInfo>& devs) {
  for (const auto& d : devs)
    if (d.driver == "vivid" && d.capture) return &d;
  return nullptr;
}

#define REQUIRE_VIVID(var)                                                                                    \
  const auto all_devices_ = v4l2::list_v4l2_devices(false);                                                   \
  const v4l2::DeviceInfo* var = vivid_node(all_devices_);                                                     \
  if (var == nullptr) GTEST_SKIP() << "no vivid capture node (load vivid, or run tests/hw/run.sh BUILD_DIR)"; \
  static_cast<void>(0)

DeviceContext context(const std::string& id) {
  DeviceContext c;
  c.id = id;
  return c;
}

struct Seen {
  std::vector<std::uint64_t> seq;
  std::vector<TimeNs> stamp;
};

/// Lease frames until `n` distinct ones were seen (bounded by `timeout_s`).
Seen collect(Camera& cam, std::size_t n, double timeout_s, const std::function<void(const Frame&)>& check = {}) {
  Seen s;
  std::uint64_t last_gen = 0;
  wait_until(
      [&] {
        FrameLease lease;
        if (cam.latest(monotonic_now(), lease) && lease.generation() != last_gen) {
          last_gen = lease.generation();
          const TimeNs now = monotonic_now();
          EXPECT_LE(lease->capture_time, now) << "capture time in the future";
          s.seq.push_back(lease->sequence);
          s.stamp.push_back(lease->capture_time);
          if (check) check(*lease);
        }
        return s.seq.size() >= n;
      },
      timeout_s);
  return s;
}

void expect_monotonic(const Seen& s, TimeNs started) {
  for (std::size_t i = 1; i < s.seq.size(); ++i) {
    EXPECT_GT(s.seq[i], s.seq[i - 1]) << "sequence must increase (frame " << i << ")";
    EXPECT_GT(s.stamp[i], s.stamp[i - 1]) << "timestamps must increase (frame " << i << ")";
  }
  ASSERT_FALSE(s.stamp.empty());
  EXPECT_GT(s.stamp.front(), started - kNsPerSec) << "capture time long before start()";
  const double mean_dt = to_seconds(s.stamp.back() - s.stamp.front()) / static_cast<double>(s.stamp.size() - 1);
  EXPECT_GT(mean_dt, 0.005) << "frames closer than 5 ms apart on average: stamps not from the sensor";
  EXPECT_LT(mean_dt, 0.5) << "frames more than 0.5 s apart on average";
}

int find_control(int fd, const std::string& name) {
  v4l2_query_ext_ctrl q{};
  q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  while (ioctl(fd, VIDIOC_QUERY_EXT_CTRL, &q) == 0) {
    if (v4l2::normalise_control_name(q.name) == name) return static_cast<int>(q.id);
    q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  return -1;
}

}  // namespace

TEST(HwV4l2, ListsVividWithFormats) {
  REQUIRE_VIVID(node);
  const auto with_formats = v4l2::list_v4l2_devices(true);
  const v4l2::DeviceInfo* dev = vivid_node(with_formats);
  ASSERT_NE(dev, nullptr);
  ASSERT_EQ(dev->path, node->path);
  std::vector<std::string> fourccs;
  for (const auto& f : dev->formats) fourccs.push_back(f.fourcc);
  EXPECT_NE(std::find(fourccs.begin(), fourccs.end(), "YUYV"), fourccs.end());
  EXPECT_NE(std::find(fourccs.begin(), fourccs.end(), "GREY"), fourccs.end());
  EXPECT_EQ(dev->bus_info, "platform:vivid-000");
  bool has_640x360 = false;
  for (const auto& f : dev->formats)
    for (const auto& s : f.sizes) has_640x360 |= s.width == 640 && s.height == 360 && !s.rates_hz.empty();
  EXPECT_TRUE(has_640x360) << "vivid's webcam input offers 640x360 with frame intervals";
}

TEST(HwV4l2, CapturesYuyvAsBgr8WithColourBars) {
  REQUIRE_VIVID(dev);
  v4l2::Config c;
  c.device = dev->path;
  c.width = 640;
  c.height = 360;
  c.fourcc = "YUYV";
  c.output = PixelFormat::kBgr8;
  c.rate_hz = 25;
  c.buffers = 4;
  c.controls = {{"test_pattern", "75% Colorbar"}, {"brightness", "128"}};
  v4l2::V4l2Camera cam(c, context("front"));
  EXPECT_EQ(cam.device_fourcc(), "YUYV");
  EXPECT_EQ(cam.format().width, 640);
  EXPECT_NEAR(cam.format().rate_hz, 25.0, 0.01);
  const TimeNs started = monotonic_now();
  cam.start();
  int checked = 0;
  const Seen s = collect(cam, 10, 20.0, [&](const Frame& f) {
    ASSERT_EQ(f.image.type(), CV_8UC3);
    const int y = f.image.rows * 3 / 4;
    const cv::Vec3b white = f.image.at<cv::Vec3b>(y, f.image.cols / 16);       // bar 0: 75% white
    const cv::Vec3b yellow = f.image.at<cv::Vec3b>(y, f.image.cols * 3 / 16);  // bar 1: yellow
    const cv::Vec3b blue = f.image.at<cv::Vec3b>(y, f.image.cols * 13 / 16);   // bar 6: blue
    EXPECT_GT(white[0], 150);
    EXPECT_NEAR(white[0], white[2], 12);
    EXPECT_LT(yellow[0], 60);
    EXPECT_GT(yellow[1], 150);
    EXPECT_GT(yellow[2], 150);
    EXPECT_GT(blue[0], 150);
    EXPECT_LT(blue[2], 60);
    ++checked;
  });
  const CameraStats st = cam.stats();
  cam.stop();
  ASSERT_EQ(s.seq.size(), 10u) << "fewer than 10 frames in 20 s";
  EXPECT_EQ(checked, 10);
  expect_monotonic(s, started);
  EXPECT_GE(st.frames, 10u);
  EXPECT_EQ(st.faults, 0u);
  EXPECT_EQ(st.corrupt, 0u);
  EXPECT_EQ(cam.non_monotonic_stamps(), 0u) << "vivid stamps buffers with CLOCK_MONOTONIC";
  EXPECT_EQ(cam.stats().state, DeviceState::kStopped);
}

TEST(HwV4l2, CapturesGreyAsMono8SelectedByBusInfo) {
  REQUIRE_VIVID(dev);
  v4l2::Config c;
  c.bus_info = dev->bus_info;
  c.width = 640;
  c.height = 480;
  c.fourcc = "auto";  // mono8 prefers GREY
  c.output = PixelFormat::kMono8;
  c.buffers = 3;
  v4l2::V4l2Camera cam(c, context("mono"));
  EXPECT_EQ(cam.device_fourcc(), "GREY");
  EXPECT_EQ(cam.device_path(), dev->path);
  const TimeNs started = monotonic_now();
  cam.start();
  const Seen s = collect(cam, 8, 20.0, [](const Frame& f) {
    ASSERT_EQ(f.image.type(), CV_8UC1);
    const int y = f.image.rows * 3 / 4;
    const int white = f.image.at<std::uint8_t>(y, f.image.cols / 16);
    const int black = f.image.at<std::uint8_t>(y, f.image.cols * 15 / 16);
    EXPECT_GT(white - black, 100) << "75% white bar vs black bar";
  });
  cam.stop();
  ASSERT_EQ(s.seq.size(), 8u);
  expect_monotonic(s, started);
}

TEST(HwV4l2, AppliesControlsAndRejectsUnknownOnes) {
  REQUIRE_VIVID(dev);
  v4l2::Config c;
  c.device = dev->path;
  c.width = 640;
  c.height = 360;
  c.controls = {{"Brightness", "201"}};
  {
    v4l2::V4l2Camera cam(c, context("front"));
    const int fd = ::open(dev->path.c_str(), O_RDWR);
    ASSERT_GE(fd, 0);
    v4l2_control ctl{};
    ctl.id = V4L2_CID_BRIGHTNESS;
    ASSERT_EQ(ioctl(fd, VIDIOC_G_CTRL, &ctl), 0);
    EXPECT_EQ(ctl.value, 201);
    ::close(fd);
  }
  c.controls = {{"brightnes", "10"}};
  try {
    v4l2::V4l2Camera cam(c, context("front"));
    FAIL() << "unknown control accepted";
  } catch (const DeviceConfigError& e) {
    EXPECT_EQ(e.field(), "controls");
    EXPECT_NE(std::string(e.what()).find("has no control 'brightnes' (did you mean 'brightness'?)"), std::string::npos)
        << e.what();
  }
  c.controls = {{"brightness", "999"}};
  try {
    v4l2::V4l2Camera cam(c, context("front"));
    FAIL() << "out-of-range control accepted";
  } catch (const DeviceConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("control 'brightness' = 999 is outside [0, 255]"), std::string::npos)
        << e.what();
  }
}

TEST(HwV4l2, RejectsFormatSizeAndBusyDeviceClearly) {
  REQUIRE_VIVID(dev);
  v4l2::Config c;
  c.device = dev->path;
  c.width = 640;
  c.height = 360;
  c.fourcc = "MJPG";
  try {
    v4l2::V4l2Camera cam(c, context("front"));
    FAIL() << "vivid does not offer MJPG";
  } catch (const DeviceConfigError& e) {
    EXPECT_EQ(e.field(), "fourcc");
    EXPECT_NE(std::string(e.what()).find("(" + dev->path + "): does not offer 'MJPG' (offers: YUYV"), std::string::npos)
        << e.what();
  }
  c.fourcc = "YUYV";
  c.width = 1000;
  c.height = 700;
  try {
    v4l2::V4l2Camera cam(c, context("front"));
    FAIL() << "1000x700 accepted";
  } catch (const DeviceConfigError& e) {
    EXPECT_EQ(e.field(), "width");
    EXPECT_NE(std::string(e.what()).find("cannot capture 1000x700 in YUYV"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("640x360"), std::string::npos) << "offered sizes listed: " << e.what();
  }
  c.width = 640;
  c.height = 360;
  v4l2::V4l2Camera first(c, context("first"));
  first.start();
  try {
    v4l2::V4l2Camera second(c, context("second"));
    FAIL() << "a second camera on a streaming device was accepted";
  } catch (const DeviceUnavailableError& e) {  // busy now, may be free later: restartable
    EXPECT_EQ(e.field(), "device");
    EXPECT_NE(std::string(e.what()).find("v4l2 camera 'second' (" + dev->path + "): busy"), std::string::npos)
        << e.what();
  }
  first.stop();
}

TEST(HwV4l2, RecoversFromVividDisconnect) {
  REQUIRE_VIVID(dev);
  v4l2::Config c;
  c.device = dev->path;
  c.width = 640;
  c.height = 360;
  c.output = PixelFormat::kBgr8;
  c.retry_min_s = 0.05;
  c.retry_max_s = 0.4;
  v4l2::V4l2Camera cam(c, context("front"));
  cam.start();
  ASSERT_TRUE(wait_until([&] { return cam.stats().frames >= 3; }, 20.0)) << "no frames before the disconnect";
  {
    const int fd = ::open(dev->path.c_str(), O_RDWR);
    ASSERT_GE(fd, 0);
    const int id = find_control(fd, "disconnect");
    if (id < 0) {
      ::close(fd);
      cam.stop();
      GTEST_SKIP() << "vivid has no 'disconnect' control (loaded with no_error_inj=1)";
    }
    v4l2_control ctl{};
    ctl.id = static_cast<__u32>(id);
    ctl.value = 1;
    ASSERT_EQ(ioctl(fd, VIDIOC_S_CTRL, &ctl), 0);
    ::close(fd);  // vivid reconnects once every file handle is closed
  }
  ASSERT_TRUE(wait_until([&] { return cam.stats().faults >= 1; }, 10.0)) << "disconnect not detected";
  EXPECT_NE(cam.last_error().find(dev->path), std::string::npos) << cam.last_error();
  ASSERT_TRUE(
      wait_until([&] { return cam.stats().recoveries >= 1 && cam.stats().state == DeviceState::kStreaming; }, 20.0))
      << "no recovery; last error: " << cam.last_error();
  const std::uint64_t after = cam.stats().frames;
  ASSERT_TRUE(wait_until([&] { return cam.stats().frames >= after + 5; }, 20.0)) << "no frames after recovery";
  const Seen s = collect(cam, 3, 10.0);
  EXPECT_EQ(s.seq.size(), 3u) << "latest() must lease frames again";
  cam.stop();
}

TEST(HwV4l2, RecoversFromDriverUnbindSelectedByBusInfo) {
  REQUIRE_VIVID(dev);
  const std::filesystem::path drv = "/sys/bus/platform/drivers/vivid";
  if (::access((drv / "unbind").c_str(), W_OK) != 0) GTEST_SKIP() << "cannot unbind vivid (needs root)";
  v4l2::Config c;
  c.bus_info = dev->bus_info;
  c.width = 640;
  c.height = 360;
  c.retry_min_s = 0.05;
  c.retry_max_s = 0.4;
  v4l2::V4l2Camera cam(c, context("front"));
  cam.start();
  ASSERT_TRUE(wait_until([&] { return cam.stats().frames >= 3; }, 20.0));
  { std::ofstream(drv / "unbind") << "vivid.0"; }
  ASSERT_TRUE(wait_until([&] { return cam.stats().faults >= 1; }, 10.0)) << "unplug not detected";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_NE(cam.stats().state, DeviceState::kStreaming) << "device is gone";
  FrameLease lease;
  EXPECT_FALSE(cam.latest(monotonic_now(), lease)) << "no frames while the device is gone";
  { std::ofstream(drv / "bind") << "vivid.0"; }
  ASSERT_TRUE(wait_until([&] { return cam.stats().state == DeviceState::kStreaming; }, 20.0)) << cam.last_error();
  const std::uint64_t after = cam.stats().frames;
  EXPECT_TRUE(wait_until([&] { return cam.stats().frames >= after + 3; }, 20.0));
  EXPECT_GE(cam.stats().recoveries, 1u);
  cam.stop();
}
