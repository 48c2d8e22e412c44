// The exit statuses of `regolith run` that deploy/systemd/regolith.service relies on, from the
// built binary on the host: a device unavailable at start-up (camera node or CAN interface that
// does not exist) exits 3, which the unit restarts; a device that is there but cannot do what the
// deployment asks exits 2 (RestartPreventExitStatus=2), like any configuration error. The host
// kernel needs neither V4L2 nor SocketCAN for this: the devices are absent everywhere.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "child_process.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
namespace rt = regolith::testing;

namespace {

struct Result {
  int status = -1;  ///< exit status, 128 + signal when killed
  std::string out;
  std::string err;
};

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) out.push_back(line);
  }
  return out;
}

class StartupExitStatus : public ::testing::Test {
 protected:
  /// A minimal deployment (no DDS, a health component) with `devices` as its devices section.
  fs::path deployment(const std::string& devices) {
    const fs::path f = dir_ / "rover.yaml";
    std::ofstream(f) << "name: exit_status\n"
                        "dds: {enabled: false}\n"
                        "devices:\n"
                     << devices
                     << "rate_groups:\n"
                        "  - {name: health, rate_hz: 1, members: [health]}\n"
                        "components:\n"
                        "  health: {type: health}\n";
    return f;
  }

  Result run(const std::vector<std::string>& args) {
    const fs::path out = dir_ / "stdout.txt";
    std::vector<std::string> all{REGOLITH_EXE};
    all.insert(all.end(), args.begin(), args.end());
    Result r;
    const pid_t pid = rt::spawn(all, out);
    if (pid <= 0) {
      r.err = "posix_spawn failed";
      return r;
    }
    r.status = rt::wait_exit(pid);
    r.out = rt::read_file(out);
    r.err = rt::read_file(out.string() + ".err");
    return r;
  }

  Result run_deployment(const fs::path& cfg) {
    return run({"run", "--config", cfg.string(), "--duration", "1", "--quiet"});
  }

  // One directory per test, removed whatever the outcome.
  const regolith::testing::TempDir tmp_{std::string("exit_") +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name()};
  const fs::path& dir_ = tmp_.path();
};

#define EXPECT_CONTAINS(haystack, needle) \
  EXPECT_NE(std::string(haystack).find(needle), std::string::npos) << "stderr: " << (haystack)

}  // namespace

TEST_F(StartupExitStatus, MissingV4l2CameraExits3WithOneLineNamingItAndTheRetry) {
  if (fs::exists("/dev/video99")) GTEST_SKIP() << "/dev/video99 exists on this machine";
  const fs::path cfg = deployment("  cameras:\n    front: {backend: v4l2, device: /dev/video99}\n");
  const Result r = run_deployment(cfg);
  EXPECT_EQ(r.status, 3) << r.err;
  const auto err = lines(r.err);
  ASSERT_EQ(err.size(), 1u) << "one log line expected:\n" << r.err;
  EXPECT_CONTAINS(err[0], cfg.string() +
                              ":5:36: devices.cameras.front.device: v4l2 camera 'front' (/dev/video99): "
                              "cannot open: No such file or directory");
  EXPECT_CONTAINS(err[0], "device unavailable at start-up, will be retried by systemd (exit status 3");
  // validating the same deployment does not open devices: fine
  const Result check = run({"config", "check", cfg.string()});
  EXPECT_EQ(check.status, 0) << check.err;
}

TEST_F(StartupExitStatus, MissingCanInterfaceExits3WithOneLineNamingItAndTheRetry) {
  if (fs::exists("/sys/class/net/nosuchcan0")) GTEST_SKIP() << "nosuchcan0 exists on this machine";
  const fs::path cfg = deployment(
      "  encoders:\n"
      "    wheels:\n"
      "      backend: socketcan\n"
      "      interface: nosuchcan0\n"
      "      wheels: {front_left: {id: 0x101}}\n");
  const Result r = run_deployment(cfg);
  EXPECT_EQ(r.status, 3) << r.err;
  const auto err = lines(r.err);
  ASSERT_EQ(err.size(), 1u) << "one log line expected:\n" << r.err;
  EXPECT_CONTAINS(err[0], cfg.string() +
                              ":7:18: devices.encoders.wheels.interface: socketcan 'wheels': interface "
                              "'nosuchcan0' does not exist (CAN interfaces: ");
  EXPECT_CONTAINS(err[0], "will be retried by systemd (exit status 3");
}

TEST_F(StartupExitStatus, DeviceThatCannotCaptureIsAConfigurationErrorExit2) {
  // /dev/null opens fine but is no V4L2 capture node: retrying would not help
  const fs::path cfg = deployment("  cameras:\n    front: {backend: v4l2, device: /dev/null}\n");
  const Result r = run_deployment(cfg);
  EXPECT_EQ(r.status, 2) << r.err;
  const auto err = lines(r.err);
  ASSERT_EQ(err.size(), 1u) << "one log line expected:\n" << r.err;
  EXPECT_CONTAINS(err[0], cfg.string() +
                              ":5:36: devices.cameras.front.device: v4l2 camera 'front' (/dev/null): "
                              "not a V4L2 device");
  EXPECT_EQ(err[0].find("retried"), std::string::npos) << err[0];
}

TEST_F(StartupExitStatus, InterfaceThatIsNotCanIsAConfigurationErrorExit2) {
  const fs::path cfg = deployment(
      "  encoders:\n"
      "    wheels: {backend: socketcan, interface: lo, wheels: {front_left: {id: 0x101}}}\n");
  const Result r = run_deployment(cfg);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_CONTAINS(r.err,
                  "devices.encoders.wheels.interface: socketcan 'wheels': interface 'lo' is not a CAN interface");
  EXPECT_EQ(r.err.find("retried"), std::string::npos) << r.err;
}

TEST_F(StartupExitStatus, DevicesListsEveryBackendAndKeepsLibcamerasInfoLinesOut) {
  // `regolith devices` on a host without cameras or CAN: the three hardware sections, empty, and
  // the backends of this build. libcamera's own INFO lines (its version, in colour) stay out of
  // stderr unless LIBCAMERA_LOG_LEVELS asks for them.
  Result r = run({"devices"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_CONTAINS(r.out, "V4L2 cameras (backend: v4l2)");
  EXPECT_CONTAINS(r.out, "CAN interfaces (backend: socketcan)");
  EXPECT_CONTAINS(r.out, "camera backends: ");
  EXPECT_CONTAINS(r.out, "encoders backends: ");
  EXPECT_EQ(r.err.find("INFO"), std::string::npos) << r.err;
  if (r.out.find("(backend: libcamera)") == std::string::npos) return;  // built without libcamera
  ASSERT_EQ(setenv("LIBCAMERA_LOG_LEVELS", "*:INFO", 1), 0);
  r = run({"devices"});
  unsetenv("LIBCAMERA_LOG_LEVELS");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_CONTAINS(r.err, "libcamera v");  // the user's setting wins
}
