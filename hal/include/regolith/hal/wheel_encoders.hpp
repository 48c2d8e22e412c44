#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "regolith/core/channels.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/can.hpp"

namespace regolith::hal {

/// One timestamped wheel angle. Angles are continuous (unwrapped) in rad.
struct AngleSample {
  TimeNs stamp = 0;
  double angle = 0.0;
};

struct EncoderStats {
  std::uint64_t samples = 0;       ///< angle samples accepted
  std::uint64_t rejected = 0;      ///< frames / lines that could not be decoded
  std::uint64_t faults = 0;        ///< bus or device faults
  std::uint64_t stale_events = 0;  ///< transitions of a wheel to stale
  std::uint64_t lost = 0;          ///< frames lost before they were read (receive-queue / controller overflows)
  DeviceState state = DeviceState::kStopped;
};

/// Per-wheel angle source. All query functions are real-time safe (no lock, no allocation).
class WheelEncoders : public Device {
 public:
  static constexpr const char* kKind = "encoders";
  const char* kind() const final { return kKind; }
  DeviceCounters counters() const final {
    const EncoderStats s = stats();
    return {s.samples, s.rejected, s.faults, 0, s.state};
  }
  virtual const std::vector<std::string>& wheel_names() const = 0;
  std::size_t wheel_count() const { return wheel_names().size(); }

  /// Newest sample of `wheel` available at `now`; false when there is none yet.
  virtual bool latest(std::size_t wheel, TimeNs now, AngleSample& out) const = 0;
  /// Angle of `wheel` at time `t` by linear interpolation between the samples around `t`
  /// (extrapolated from the last two samples by at most `max_extrapolation`). False when `t` is
  /// outside the history or the wheel has no data.
  virtual bool angle_at(std::size_t wheel, TimeNs t, double& angle) const = 0;
  /// Angular velocity (rad/s) from the last two samples at `now`; false if unknown.
  virtual bool velocity(std::size_t wheel, TimeNs now, double& rad_per_s) const;
  /// The samples of `wheel` with `after` < stamp <= `now`, oldest first, at most out.size() of them
  /// (call again from the last one's stamp for the rest); returns how many were written. For
  /// recorders, outside the rate groups. Backends that keep a history give every sample they still
  /// hold; the default gives only the newest one.
  virtual std::size_t samples_since(std::size_t wheel, TimeNs after, TimeNs now, std::span<AngleSample> out) const;

  /// True for backends that read a CAN bus: can_frames() gives the raw frames they received.
  virtual bool reads_can() const { return false; }
  /// The raw CAN frames received (for recorders, outside the rate groups): those numbered `cursor`
  /// on (each backend numbers its frames from 0) that arrived by `now`, oldest first, at most
  /// out.size(); advances `cursor` past them. Frames the backend no longer holds are skipped and
  /// added to `missed`. Backends without a bus (reads_can() false) return 0.
  virtual std::size_t can_frames(std::uint64_t& cursor, TimeNs now, std::span<CanFrame> out,
                                 std::uint64_t& missed) const;

  /// A wheel is stale when its newest sample is older than `timeout` at `now`.
  bool stale(std::size_t wheel, TimeNs now, TimeNs timeout) const;

  virtual EncoderStats stats() const = 0;
};

/// Fixed-capacity history of one wheel's samples, shared by the backends that receive samples
/// on their own thread (SocketCAN): the receive thread appends and publishes; readers interpolate
/// on a copy-free lease. Capacity is a compile-time constant so the snapshot is allocation-free.
class AngleHistory {
 public:
  static constexpr std::size_t kCapacity = 64;
  struct Snapshot {
    std::array<AngleSample, kCapacity> ring{};
    std::size_t count = 0;  ///< valid samples (<= kCapacity)
    std::size_t head = 0;   ///< index of the newest sample
    const AngleSample& newest(std::size_t back = 0) const { return ring[(head + kCapacity - back) % kCapacity]; }
  };

  AngleHistory() : pool_(4) {}
  /// Writer (one thread): append a sample (stamps must not go backwards; older ones are dropped).
  bool push(const AngleSample& s);
  bool latest(AngleSample& out) const;
  bool at(TimeNs t, TimeNs max_extrapolation, double& angle) const;
  bool velocity(double& rad_per_s) const;
  /// Samples with `after` < stamp still held, oldest first, at most out.size().
  std::size_t since(TimeNs after, std::span<AngleSample> out) const;

 private:
  Snapshot work_{};
  LatestPool<Snapshot> pool_;
};

/// Interpolate (or extrapolate by at most `max_extrapolation`) in a time-ordered snapshot.
bool interpolate(const AngleHistory::Snapshot& h, TimeNs t, TimeNs max_extrapolation, double& angle);

}  // namespace regolith::hal
