// Driver tests of the libcamera backend against vimc (label hw; skipped when libcamera sees no vimc).
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "hw_util.hpp"
#include "regolith/hal_libcamera/libcamera.hpp"

using namespace regolith;
using namespace regolith::hal;
using regolith::hwtest::wait_until;

namespace {

std::string vimc_camera(const std::vector<libcam::CameraInfo>& cams) {
  for (const auto& c : cams)
    if (c.id.find("vimc") != std::string::npos) return c.id;
  return {};
}

#define REQUIRE_VIMC(var)                                                                           \
  const auto cams_ = libcam::list_libcamera_cameras();                                              \
  const std::string var = vimc_camera(cams_);                                                       \
  if (var.empty()) GTEST_SKIP() << "libcamera sees no vimc camera (run tests/hw/run.sh BUILD_DIR)"; \
  static_cast<void>(0)

DeviceContext context(const std::string& id) {
  DeviceContext c;
  c.id = id;
  return c;
}

}  // namespace

TEST(HwLibcamera, ListsVimcWithFormats) {
  REQUIRE_VIMC(id);
  const auto& cam = *std::find_if(cams_.begin(), cams_.end(), [&](const auto& c) { return c.id == id; });
  std::vector<std::string> names;
  for (const auto& f : cam.formats) names.push_back(f.pixel_format);
  EXPECT_NE(std::find(names.begin(), names.end(), "BGR888"), names.end());
}

TEST(HwLibcamera, CapturesVimcWithSensorTimestamps) {
  REQUIRE_VIMC(id);
  libcam::Config c;
  c.camera = id;
  c.width = 960;  // vimc's pipeline wants sizes divisible by 3
  c.height = 720;
  c.pixel_format = "BGR888";
  c.output = PixelFormat::kBgr8;
  c.buffers = 4;
  c.rate_hz = 10.0;  // FrameDurationLimits when vimc has it; the nominal rate either way
  libcam::LibcameraCamera cam(c, context("vimc"));
  EXPECT_EQ(cam.device_format(), "BGR888");
  EXPECT_EQ(cam.camera_id(), id);
  EXPECT_EQ(cam.format().rate_hz, 10.0) << "the components time their camera input by it";
  const TimeNs started = monotonic_now();
  cam.start();
  std::vector<std::uint64_t> seq;
  std::vector<TimeNs> stamps;
  std::uint64_t gen = 0;
  wait_until(
      [&] {
        FrameLease lease;
        if (cam.latest(monotonic_now(), lease) && lease.generation() != gen) {
          gen = lease.generation();
          EXPECT_EQ(lease->image.cols, 960);
          EXPECT_EQ(lease->image.rows, 720);
          EXPECT_LE(lease->capture_time, monotonic_now());
          cv::Scalar mean, stddev;
          cv::meanStdDev(lease->image, mean, stddev);
          EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 10.0) << "vimc's test pattern is not a flat image";
          seq.push_back(lease->sequence);
          stamps.push_back(lease->capture_time);
        }
        return seq.size() >= 5;
      },
      30.0);
  const CameraStats st = cam.stats();
  cam.stop();
  ASSERT_EQ(seq.size(), 5u) << "fewer than 5 frames from vimc in 30 s; last error: " << cam.last_error();
  for (std::size_t i = 1; i < seq.size(); ++i) {
    EXPECT_GT(seq[i], seq[i - 1]);
    EXPECT_GT(stamps[i], stamps[i - 1]);
  }
  EXPECT_GT(stamps.front(), started - kNsPerSec);
  EXPECT_EQ(st.faults, 0u);
  EXPECT_EQ(st.state, DeviceState::kStreaming);
  EXPECT_EQ(cam.stats().state, DeviceState::kStopped);
}

TEST(HwLibcamera, RejectsUnknownCameraSizeAndControlClearly) {
  REQUIRE_VIMC(id);
  libcam::Config c;
  c.camera = "/base/no/such/camera";
  try {
    libcam::LibcameraCamera cam(c, context("front"));
    FAIL() << "unknown camera accepted";
  } catch (const DeviceUnavailableError& e) {  // may appear later: restartable
    EXPECT_EQ(e.field(), "camera");
    EXPECT_NE(std::string(e.what()).find("no camera '/base/no/such/camera' (cameras: " + id), std::string::npos)
        << e.what();
  }
  c.camera = id;
  c.width = 17;
  c.height = 5;
  try {
    libcam::LibcameraCamera cam(c, context("front"));
    FAIL() << "17x5 accepted";
  } catch (const DeviceConfigError& e) {
    EXPECT_EQ(e.field(), "width");
    EXPECT_NE(std::string(e.what()).find("cannot produce 17x5"), std::string::npos) << e.what();
  }
  c.width = 960;
  c.height = 720;
  c.controls = {{"NoSuchControl", "1"}};
  try {
    libcam::LibcameraCamera cam(c, context("front"));
    FAIL() << "unknown control accepted";
  } catch (const DeviceConfigError& e) {
    EXPECT_EQ(e.field(), "controls");
    EXPECT_NE(std::string(e.what()).find("has no control 'NoSuchControl'"), std::string::npos) << e.what();
  }
}
