#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include "regolith/core/time.hpp"
#include "regolith/hal/frame.hpp"

namespace regolith::hal {

struct CameraFormat {
  int width = 640;
  int height = 480;
  PixelFormat format = PixelFormat::kMono8;
  double rate_hz = 30.0;
};

enum class DeviceState : std::uint8_t { kStopped, kStreaming, kFaulted, kRecovering };
std::string_view to_string(DeviceState s);

/// Counters every camera backend keeps; read from any thread.
struct CameraStats {
  std::uint64_t frames = 0;          ///< frames delivered
  std::uint64_t dropped = 0;         ///< sequence gaps / frames lost
  std::uint64_t corrupt = 0;         ///< frames with damaged payload
  std::uint64_t faults = 0;          ///< device errors (ENODEV, timeouts, ...)
  std::uint64_t recoveries = 0;      ///< successful restarts after a fault
  DeviceState state = DeviceState::kStopped;
  TimeNs last_frame_time = 0;
};

/// A camera. `start` and `stop` run outside the rate groups; `latest` is real-time safe: it never
/// blocks, never allocates and never throws.
class Camera {
 public:
  virtual ~Camera() = default;
  /// Name from the deployment YAML (e.g. "front").
  virtual const std::string& id() const = 0;
  /// The negotiated format (valid after construction; backends negotiate when configured).
  virtual CameraFormat format() const = 0;
  /// Begin streaming. Throws std::runtime_error when the device cannot start at all.
  virtual void start() = 0;
  virtual void stop() = 0;
  /// Lease the newest frame captured at or before `now`. Returns false when there is none
  /// (not started, no frame yet, device faulted). `now` lets mock cameras follow the simulated
  /// clock; hardware backends ignore it.
  virtual bool latest(TimeNs now, FrameLease& out) = 0;
  virtual CameraStats stats() const = 0;
};

}  // namespace regolith::hal
