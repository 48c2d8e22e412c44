// What the hardware backends share: the re-open back-off, and the start-up device errors with
// their YAML location (a configuration problem becomes a ConfigError; an unavailable device stays
// a DeviceUnavailableError so that `regolith run` can exit with its own, restartable status).
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "regolith/core/error.hpp"
#include "regolith/core/image_limits.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/device.hpp"

using namespace regolith;
using namespace regolith::hal;

TEST(Backoff, DoublesToCeilingAndResets) {
  Backoff b(100 * kNsPerMs, 1000 * kNsPerMs);
  std::vector<TimeNs> got;
  for (int i = 0; i < 6; ++i) got.push_back(b.next() / kNsPerMs);
  EXPECT_EQ(got, (std::vector<TimeNs>{100, 200, 400, 800, 1000, 1000}));
  b.reset();
  EXPECT_EQ(b.next(), 100 * kNsPerMs);
  EXPECT_EQ(b.next(), 200 * kNsPerMs);
}

TEST(Backoff, CeilingThatIsNotAPowerOfTwoMultipleIsHit) {
  Backoff c(50 * kNsPerMs, 120 * kNsPerMs);
  EXPECT_EQ(c.next(), 50 * kNsPerMs);
  EXPECT_EQ(c.next(), 100 * kNsPerMs);
  EXPECT_EQ(c.next(), 120 * kNsPerMs);
  EXPECT_EQ(c.next(), 120 * kNsPerMs);
}

// Each backend's Config::validate (V4L2, libcamera, SocketCAN) calls these; the error names the field.
namespace {
std::string field_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const FieldError& e) {
    return e.field();
  }
  return "(no error)";
}
}  // namespace

TEST(Backoff, FieldsAreCheckedOnceForEveryBackend) {
  EXPECT_EQ(field_of([] { validate_backoff(0.1, 5.0); }), "(no error)");
  EXPECT_EQ(field_of([] { validate_backoff(0.1, 0.1); }), "(no error)");
  EXPECT_EQ(field_of([] { validate_backoff(0.0, 5.0); }), "retry_min");
  EXPECT_EQ(field_of([] { validate_backoff(std::nan(""), 5.0); }), "retry_min");
  EXPECT_EQ(field_of([] { validate_backoff(HUGE_VAL, HUGE_VAL); }), "retry_min");
  EXPECT_EQ(field_of([] { validate_backoff(0.5, 0.2); }), "retry_max");
  EXPECT_EQ(field_of([] { validate_backoff(0.5, HUGE_VAL); }), "retry_max")
      << "libcamera let an infinite ceiling through";
  EXPECT_EQ(field_of([] { validate_backoff(0.5, std::nan("")); }), "retry_max");
}

TEST(CaptureFields, SizesAndTimeoutAreCheckedOnceForEveryCameraBackend) {
  EXPECT_EQ(field_of([] { validate_capture(640, 480, 2.0); }), "(no error)");
  EXPECT_EQ(field_of([] { validate_capture(kMaxImageSidePx, 1, 2.0); }), "(no error)");
  EXPECT_EQ(field_of([] { validate_capture(0, 480, 2.0); }), "width");
  EXPECT_EQ(field_of([] { validate_capture(kMaxImageSidePx + 1, 480, 2.0); }), "width");
  EXPECT_EQ(field_of([] { validate_capture(640, -1, 2.0); }), "height");
  EXPECT_EQ(field_of([] { validate_capture(640, 480, 0.0); }), "frame_timeout");
  EXPECT_EQ(field_of([] { validate_capture(640, 480, HUGE_VAL); }), "frame_timeout");
  try {
    validate_capture(640, 20000, 2.0);
    FAIL() << "no error";
  } catch (const FieldError& e) {
    EXPECT_NE(std::string(e.what()).find("must be in [1, 16384] px (got 20000)"), std::string::npos) << e.what();
  }
}

TEST(DeviceErrors, KindsShareTheFieldCarryingBase) {
  const DeviceUnavailableError u("device", "v4l2 camera 'front' (/dev/video99): cannot open");
  const DeviceConfigError c("fourcc", "v4l2 camera 'front' (/dev/video0): does not offer 'MJPG'");
  const DeviceError& ub = u;
  const DeviceError& cb = c;
  EXPECT_EQ(ub.field(), "device");
  EXPECT_EQ(cb.field(), "fourcc");
  EXPECT_STREQ(ub.what(), "v4l2 camera 'front' (/dev/video99): cannot open");
  EXPECT_EQ(dynamic_cast<const DeviceConfigError*>(&ub), nullptr) << "an unavailable device is not a config error";
  EXPECT_EQ(dynamic_cast<const DeviceUnavailableError*>(&cb), nullptr);
}

TEST(DeviceErrors, ConfigProblemIsRethrownAsLocatedConfigError) {
  auto p = Params::load_string("backend: v4l2\ndevice: /dev/video0\nfourcc: MJPG\n", "rover.yaml");
  try {
    rethrow_located(p, DeviceConfigError("fourcc", "v4l2 camera 'front': does not offer 'MJPG'"));
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "rover.yaml:3:9: fourcc: v4l2 camera 'front': does not offer 'MJPG'");
    return;
  }
  FAIL() << "no ConfigError";
}

TEST(DeviceErrors, UnavailableDeviceStaysUnavailableAndIsLocated) {
  auto p = Params::load_string("backend: v4l2\ndevice: /dev/video99\n", "rover.yaml");
  try {
    rethrow_located(p, DeviceUnavailableError("device", "v4l2 camera 'front' (/dev/video99): cannot open"));
  } catch (const DeviceUnavailableError& e) {
    EXPECT_EQ(e.field(), "device");
    EXPECT_STREQ(e.what(), "rover.yaml:2:9: device: v4l2 camera 'front' (/dev/video99): cannot open");
    return;
  } catch (const ConfigError& e) {
    FAIL() << "became a ConfigError: " << e.what();
  }
  FAIL() << "no DeviceUnavailableError";
}

TEST(DeviceErrors, AbsentFieldIsLocatedAtTheMapping) {
  auto p = Params::load_string("backend: v4l2\ncard: Arducam\n", "rover.yaml");
  try {
    rethrow_located(p, DeviceUnavailableError("bus_info", "v4l2 camera 'front': no video capture device matches"));
  } catch (const DeviceUnavailableError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("rover.yaml:1:1: <root>: v4l2 camera 'front': no video capture", 0), 0u)
        << e.what();
    return;
  }
  FAIL() << "no DeviceUnavailableError";
}
