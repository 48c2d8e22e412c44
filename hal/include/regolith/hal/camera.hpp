#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include "regolith/core/time.hpp"
#include "regolith/hal/device.hpp"
#include "regolith/hal/frame.hpp"

namespace regolith::hal {

struct CameraFormat {
  int width = 640;
  int height = 480;
  PixelFormat format = PixelFormat::kMono8;
  double rate_hz = 30.0;
};

/// The fields every hardware camera backend's Config shares (V4L2, libcamera): width and height
/// in 1..kMaxImageSidePx px, frame_timeout > 0 s and finite. Throws FieldError at the field.
void validate_capture(int width, int height, double frame_timeout_s);

/// Counters every camera backend keeps; read from any thread.
struct CameraStats {
  std::uint64_t frames = 0;       ///< frames delivered
  std::uint64_t dropped = 0;      ///< sequence gaps / frames lost
  std::uint64_t corrupt = 0;      ///< frames with damaged payload
  std::uint64_t faults = 0;       ///< device errors (ENODEV, timeouts, ...)
  std::uint64_t recoveries = 0;   ///< successful restarts after a fault
  std::uint64_t bad_stamps = 0;   ///< frames withheld: stamped after they were read (StampCheckedCamera)
  std::uint64_t stamp_steps = 0;  ///< new frames stamped before the previous one (device clock stepped back)
  DeviceState state = DeviceState::kStopped;
  TimeNs last_frame_time = 0;
};

/// A camera. `start` and `stop` run outside the rate groups; `latest` is real-time safe: it never
/// blocks, never allocates and never throws.
class Camera : public Device {
 public:
  static constexpr const char* kKind = "camera";
  const char* kind() const final { return kKind; }
  DeviceCounters counters() const final {
    const CameraStats s = stats();
    return {s.frames, s.dropped + s.corrupt + s.bad_stamps, s.faults, s.recoveries, s.state};
  }
  /// The negotiated format (valid after construction; backends negotiate when configured).
  virtual CameraFormat format() const = 0;
  /// Lease the newest frame captured at or before `now`. Returns false when there is none
  /// (not started, no frame yet, device faulted). `now` lets mock cameras follow the simulated
  /// clock; hardware backends ignore it.
  virtual bool latest(TimeNs now, FrameLease& out) = 0;
  virtual CameraStats stats() const = 0;
};

}  // namespace regolith::hal
