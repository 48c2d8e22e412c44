#pragma once
// The one device base (Device: identity, lifecycle, counters) under every device kind (Camera,
// WheelEncoders, Imu), and what the hardware backends share: the errors a backend throws while
// opening its device at start-up, and the back-off of the re-open loops that run afterwards.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"

namespace regolith::hal {

enum class DeviceState : std::uint8_t { kStopped, kStreaming, kFaulted, kRecovering };
std::string_view to_string(DeviceState s);

/// What every device counts, whatever it delivers (frames, angle samples, IMU samples).
struct DeviceCounters {
  std::uint64_t delivered = 0;   ///< frames / samples delivered
  std::uint64_t rejected = 0;    ///< dropped, corrupt or undecodable items
  std::uint64_t faults = 0;      ///< device errors (disconnects, timeouts, bus errors)
  std::uint64_t recoveries = 0;  ///< successful re-opens after a fault
  DeviceState state = DeviceState::kStopped;
};

/// One hardware device of a deployment (ros2_control's hardware component, F Prime's driver):
/// named in the YAML, started and stopped outside the rate groups, counting what it delivers.
/// A device kind (Camera, WheelEncoders, Imu) adds its real-time query functions; the registry,
/// the Context, the Application's start/stop and the health monitor handle every kind through
/// this base.
class Device {
 public:
  virtual ~Device() = default;
  /// Name from the deployment YAML (e.g. "front").
  virtual const std::string& id() const = 0;
  /// The kind: "camera", "encoders", "imu" (the kind's kKind).
  virtual const char* kind() const = 0;
  /// Begin delivering. Throws when the device cannot start at all (DeviceUnavailableError for a
  /// device that may appear later).
  virtual void start() = 0;
  virtual void stop() = 0;
  /// Read from any thread.
  virtual DeviceCounters counters() const = 0;
  /// Simulated time only: whether the device has produced what it delivers by time `t`. A mock
  /// that renders its output on a thread of its own can fall behind a lockstep clock that runs
  /// faster than real time; the simulated-time executor does not advance its clock to `t` before
  /// every device is ready (Application, bounded wait). Hardware and lazy mocks: always ready.
  /// Decorators forward it to the device they wrap.
  virtual bool ready_for(TimeNs t) const {
    (void)t;
    return true;
  }
};

/// A problem found while opening or configuring a device. `field` is the YAML key it concerns
/// (e.g. "device", "fourcc", "interface"); the message names the device. Backends throw one of the
/// two kinds below, never this base itself.
class DeviceError : public std::runtime_error {
 public:
  DeviceError(std::string field, const std::string& msg) : std::runtime_error(msg), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

/// The device that is there cannot do what the configuration asks (format or size not offered,
/// unknown or out-of-range control, not a capture node, not a CAN interface): restarting the
/// process cannot fix it. Reported as a ConfigError (`regolith run` exit status 2).
class DeviceConfigError : public DeviceError {
 public:
  using DeviceError::DeviceError;
};

/// The device is not usable right now (node or interface missing, busy, permission denied,
/// interface down) but may be later, e.g. a USB camera or CAN driver that appears late at boot:
/// a restart may succeed (`regolith run` exit status 3, restarted by regolith.service).
class DeviceUnavailableError : public DeviceError {
 public:
  using DeviceError::DeviceError;
};

/// For backend factories: rethrow `e` located at its field in the backend's mapping `p`
/// ("file:line:col: path.to.field: message", at the mapping when the field is absent). A
/// DeviceConfigError becomes a ConfigError, a DeviceUnavailableError stays one.
[[noreturn]] void rethrow_located(const Params& p, const DeviceError& e);

/// The back-off fields every re-opening backend shares (V4L2, libcamera, SocketCAN):
/// 0 < retry_min <= retry_max, both finite. Throws FieldError at `retry_min` or `retry_max`.
void validate_backoff(double retry_min_s, double retry_max_s);

/// Exponential back-off for re-opening a device: `initial`, doubled per failure up to `max`;
/// reset() after a success.
class Backoff {
 public:
  Backoff(TimeNs initial, TimeNs max) : initial_(initial), max_(max), next_(initial) {}
  TimeNs next() {
    const TimeNs d = next_;
    next_ = next_ > max_ / 2 ? max_ : next_ * 2;
    return d;
  }
  void reset() { next_ = initial_; }

 private:
  TimeNs initial_, max_, next_;
};

}  // namespace regolith::hal
