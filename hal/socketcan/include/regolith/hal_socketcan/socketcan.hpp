#pragma once
// SocketCAN wheel-encoder backend: a raw CAN socket on one interface, kernel receive filters for
// the configured ids, kernel receive timestamps converted to the process clock, error frames
// decoded into counters, per-wheel stale detection, interface down/up and removal recovery.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/hal/can.hpp"
#include "regolith/hal/device.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::hal::socketcan {

/// Backend parameters (YAML keys in brackets). validate() throws std::invalid_argument naming the field.
struct Config {
  std::string interface = "can0";      ///< [interface] network interface name
  std::vector<CanSignal> wheels;       ///< [wheels] name -> signal (angles in rad)
  std::vector<CanSignal> transducers;  ///< [transducers] bench channels (own unit, e.g. m)
  double stale_timeout_s = 0.2;        ///< [stale_timeout] s without a sample -> wheel stale
  double max_extrapolation_s = 0.05;   ///< [max_extrapolation] s, angle_at beyond newest sample
  double retry_min_s = 0.05;           ///< [retry_min] s, first retry after a bus/socket fault
  double retry_max_s = 2.0;            ///< [retry_max] s, retry back-off ceiling
  int receive_buffer_kb = 1024;        ///< [receive_buffer_kb] socket receive queue (SO_RCVBUF[FORCE])
  int frame_history = 1024;            ///< [frame_history] raw frames kept for recorders (can_frames)
  bool error_frames = true;            ///< [error_frames] subscribe to and decode error frames
  bool kernel_timestamps = true;       ///< [kernel_timestamps] SO_TIMESTAMPING receive stamps
  bool tx_enabled = false;             ///< [command.enabled] allow send()
  std::uint32_t tx_id = 0;             ///< [command.id]
  bool tx_extended = false;            ///< [command.extended]
  void validate() const;
};

/// Read a Config from the backend's YAML mapping (calls p.finish()).
Config config_from_params(Params& p);

/// Decoded content of one SocketCAN error frame (linux/can/error.h).
struct CanErrorInfo {
  bool tx_timeout = false;
  bool lost_arbitration = false;
  int arbitration_bit = -1;  ///< bit position where arbitration was lost (-1 unknown)
  bool controller = false;   ///< any controller problem
  bool rx_overflow = false;
  bool tx_overflow = false;
  bool error_warning = false;  ///< rx or tx error counter reached the warning level
  bool error_passive = false;  ///< rx or tx error passive
  bool error_active = false;   ///< controller back to error active
  bool protocol = false;
  bool transceiver = false;
  bool no_ack = false;
  bool bus_off = false;
  bool bus_error = false;
  bool restarted = false;
  int tx_error_count = -1;       ///< from data[6] when CAN_ERR_CNT is set
  int rx_error_count = -1;       ///< from data[7]
  std::string describe() const;  ///< e.g. "bus-off, error-passive (tx 128, rx 0)"
};
/// Decode an error frame (frame.error must be true; id holds the error class bits).
CanErrorInfo decode_error_frame(const CanFrame& frame);

/// Bus-level counters (besides EncoderStats).
struct BusStats {
  std::uint64_t frames = 0;          ///< frames received (all ids passed by the filters)
  std::uint64_t unexpected_ids = 0;  ///< frames no signal decodes (should stay 0: kernel filters)
  std::uint64_t short_frames = 0;    ///< known id with a too-short payload (DLC)
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t error_passive = 0;
  std::uint64_t error_warning = 0;
  std::uint64_t lost_arbitration = 0;
  std::uint64_t controller_problems = 0;
  std::uint64_t protocol_violations = 0;
  std::uint64_t transceiver_errors = 0;
  std::uint64_t no_ack = 0;
  std::uint64_t restarts = 0;
  std::uint64_t rx_overflows = 0;    ///< controller or socket receive-queue overflows
  std::uint64_t interface_down = 0;  ///< times the interface went down / vanished
  std::uint64_t tx_frames = 0;
  std::uint64_t tx_errors = 0;
  bool kernel_timestamps = false;          ///< receive stamps come from the kernel
  std::uint64_t receive_buffer_bytes = 0;  ///< socket receive queue the kernel granted (SO_RCVBUF)
  std::string last_error;                  ///< human-readable last fault (diagnostics)
};

class SocketCanEncoders final : public WheelEncoders {
 public:
  /// Opens and binds the socket now. Throws, naming the interface (field "interface"),
  /// DeviceUnavailableError when it does not exist or is down, and DeviceConfigError when it is not
  /// a CAN interface or the kernel has no SocketCAN.
  SocketCanEncoders(Config cfg, const DeviceContext& ctx);
  ~SocketCanEncoders() override;

  const std::string& id() const override { return id_; }
  const std::vector<std::string>& wheel_names() const override { return names_; }
  void start() override;
  void stop() override;
  bool latest(std::size_t wheel, TimeNs now, AngleSample& out) const override;
  bool angle_at(std::size_t wheel, TimeNs t, double& angle) const override;
  /// Every sample of the receive history (64 per wheel) after `after`.
  std::size_t samples_since(std::size_t wheel, TimeNs after, TimeNs now, std::span<AngleSample> out) const override;
  /// Every frame the socket received (the configured ids and error frames), from a history of
  /// Config::frame_history frames.
  bool reads_can() const override { return true; }
  std::size_t can_frames(std::uint64_t& cursor, TimeNs now, std::span<CanFrame> out,
                         std::uint64_t& missed) const override;
  EncoderStats stats() const override;

  BusStats bus_stats() const;
  /// Whether `wheel` is currently flagged stale by the receive thread.
  bool stale_flag(std::size_t wheel) const;
  /// Send a command frame with the configured id (command.enabled must be true). Returns false and
  /// counts tx_errors when the kernel refuses it; throws std::logic_error when disabled.
  bool send(const std::uint8_t* data, std::size_t len);
  const Config& config() const { return cfg_; }

 private:
  void open_socket();  // throws DeviceUnavailableError / std::runtime_error with the reason
  void close_socket();
  void run();
  void handle_frame(const CanFrame& f);
  void check_stale(TimeNs now);
  bool interface_up() const;
  void note_error(const std::string& what);

  Config cfg_;
  std::string id_;
  Clock* clock_;
  std::unique_ptr<Clock> own_clock_;
  std::vector<std::string> names_;
  CanDecoder decoder_;
  std::vector<std::unique_ptr<AngleHistory>> history_;
  std::unique_ptr<CanFrameHistory> frames_;
  std::unique_ptr<std::atomic<bool>[]> stale_;
  std::unique_ptr<std::atomic<TimeNs>[]> last_stamp_;
  int fd_ = -1;
  std::uint32_t socket_drops_ = 0;  // the socket's own drop count (SO_RXQ_OVFL) last seen: reader thread
  int wake_fd_ = -1;
  std::thread thread_;
  std::atomic<bool> running_{false};

  struct Counters;
  std::unique_ptr<Counters> c_;
};

/// A CAN network interface as seen by the kernel (for `regolith devices`).
struct CanInterfaceInfo {
  std::string name;
  bool up = false;
  bool virtual_can = false;  ///< vcan / vxcan (no bus timing, no error frames)
  int mtu = 0;               ///< 16 = classic CAN, 72 = CAN FD capable
  std::string kind;          ///< driver kind from sysfs ("vcan", "can", ...)
};
/// All interfaces of type ARPHRD_CAN (from /sys/class/net). Empty when there is none.
std::vector<CanInterfaceInfo> list_can_interfaces();

/// Registers factory "socketcan" in `r`.
void register_socketcan_backend(BackendRegistry& r);

}  // namespace regolith::hal::socketcan
