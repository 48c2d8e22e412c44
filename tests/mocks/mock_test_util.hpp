#pragma once
// Helpers for the mock-backend tests: a manual clock, temp directories, YAML -> backends.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>

#include "error_of.hpp"
#include "regolith/core/params.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "temp_dir.hpp"

namespace regolith::mocks::test {

/// A simulated clock the test moves by hand (like the runtime's SimClock).
class ManualClock final : public Clock {
 public:
  explicit ManualClock(TimeNs t = 5 * kNsPerSec) : now_(t) {}
  TimeNs now() const override { return now_.load(); }
  void sleep_until(TimeNs t) override {
    if (t > now_.load()) now_.store(t);
  }
  bool simulated() const override { return true; }
  void set(TimeNs t) { now_.store(t); }

 private:
  std::atomic<TimeNs> now_;
};

/// The test suite's temp directory (tests/common/temp_dir.hpp).
using TempDir = regolith::testing::TempDir;

/// Owns a registry with the mock backends and builds devices from YAML text.
struct Fixture {
  hal::BackendRegistry registry;
  ManualClock clock;
  TempDir dir;
  Fixture() { register_mock_backends(registry); }
  hal::DeviceContext ctx(std::uint16_t index = 0) { return {"dev", index, &clock, dir.str()}; }

  /// `open = false`: as `regolith config check` builds it (parameters validated, device not opened).
  std::unique_ptr<hal::Camera> camera(const std::string& yaml, std::uint16_t index = 0, bool open = true) {
    Params p = Params::load_string(yaml, dir.file("test.yaml"));
    hal::DeviceContext c = ctx(index);
    c.open_devices = open;
    auto cam = registry.make_camera(p, c);
    p.finish();
    return cam;
  }
  std::unique_ptr<hal::Imu> imu(const std::string& yaml) {
    Params p = Params::load_string(yaml, dir.file("test.yaml"));
    auto imu = registry.make<hal::Imu>(p, ctx());
    p.finish();
    return imu;
  }
  std::unique_ptr<hal::WheelEncoders> encoders(const std::string& yaml) {
    Params p = Params::load_string(yaml, dir.file("test.yaml"));
    auto enc = registry.make_encoders(p, ctx());
    p.finish();
    return enc;
  }
};

/// Message of the ConfigError thrown by `f` (regolith::testing::error_of).
template <class F>
std::string config_error(F&& f) {
  return regolith::testing::error_of<ConfigError>(f);
}

}  // namespace regolith::mocks::test
