#pragma once
// V4L2 camera backend: device by path, card name or bus info; format / rate negotiation; mmap
// streaming on a capture thread (poll); kernel timestamps on the process clock; controls by name;
// dropped-frame counting; fault reporting and automatic reconnection with back-off.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/device.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/hal_v4l2/convert.hpp"

namespace regolith::hal::v4l2 {

/// One control setting from YAML: `name` as v4l2-ctl prints it ("exposure_time_absolute", "gain")
/// and an integer value or a menu entry name.
struct ControlSetting {
  std::string name;
  std::string value;
};

/// Backend parameters (YAML keys in brackets).
struct Config {
  std::string device;                        ///< [device] /dev/videoN (or empty: select by card / bus_info)
  std::string card;                          ///< [card] VIDIOC_QUERYCAP card name (exact match)
  std::string bus_info;                      ///< [bus_info] e.g. "usb-0000:00:14.0-1" or "platform:vivid-000"
  int width = 640;                           ///< [width] px
  int height = 480;                          ///< [height] px
  std::string fourcc = "auto";               ///< [fourcc] device format: auto, YUYV, UYVY, GREY, RGB3, BGR3, MJPG
  PixelFormat output = PixelFormat::kMono8;  ///< [pixel_format] mono8 | bgr8
  double rate_hz = 30.0;                     ///< [rate] requested frame rate, Hz
  int buffers = 4;                           ///< [buffers] mmap buffers (2..32)
  std::vector<ControlSetting> controls;      ///< [controls] name: value
  double frame_timeout_s = 2.0;              ///< [frame_timeout] s without a frame while streaming -> fault + restart
  double retry_min_s = 0.1;                  ///< [retry_min] s, first reconnection delay
  double retry_max_s = 2.0;                  ///< [retry_max] s, reconnection back-off ceiling
  int max_readers = 4;                       ///< [max_readers] simultaneous frame leases
  void validate() const;
};

Config config_from_params(Params& p);

/// Frames lost between two delivered sequence numbers (0 for consecutive or the first frame).
/// A sequence that goes backwards (driver restarted numbering) counts as no loss.
std::uint64_t sequence_gap(bool have_previous, std::uint32_t previous, std::uint32_t current);

/// V4L2 control names as v4l2-ctl prints them: lower case, runs of non-alphanumerics -> '_'.
std::string normalise_control_name(std::string_view v4l2_name);

/// What one device offers (for `regolith devices` and for error messages).
struct FrameSize {
  int width = 0, height = 0;
  std::vector<double> rates_hz;  ///< discrete frame rates (empty if unknown / stepwise)
};
struct FormatInfo {
  std::string fourcc;            ///< e.g. "YUYV"
  std::string description;       ///< driver text
  bool convertible = false;      ///< regolith can convert it
  std::vector<FrameSize> sizes;  ///< discrete sizes; stepwise ranges listed as min and max
  std::string size_range;        ///< "16x16 - 1920x1080 step 2x2" for stepwise/continuous sizes
};
struct DeviceInfo {
  std::string path;  ///< /dev/videoN
  std::string driver;
  std::string card;
  std::string bus_info;
  bool capture = false;  ///< single-planar video capture with streaming I/O
  std::vector<FormatInfo> formats;
};
/// Every /dev/video* node (capture nodes with their formats; others with capture = false).
std::vector<DeviceInfo> list_v4l2_devices(bool with_formats = true);
/// Resolve the node to open from device / card / bus_info among `devices` (capture nodes only).
/// Throws std::runtime_error naming the selector and listing the capture devices present.
std::string select_device(const std::vector<DeviceInfo>& devices, const std::string& device, const std::string& card,
                          const std::string& bus_info);

class V4l2Camera final : public Camera {
 public:
  /// Opens the device, negotiates format and rate, applies controls and allocates the buffers.
  /// Throws (naming the device and the field) DeviceUnavailableError when the node is missing,
  /// busy or not accessible, or no capture node matches card / bus_info; DeviceConfigError for
  /// anything else it cannot satisfy (not a capture node, format, size, controls, buffers).
  V4l2Camera(Config cfg, const DeviceContext& ctx);
  ~V4l2Camera() override;

  const std::string& id() const override { return id_; }
  CameraFormat format() const override { return format_; }
  void start() override;
  void stop() override;
  bool latest(TimeNs now, FrameLease& out) override;
  CameraStats stats() const override;

  /// Device format in use (fourcc text) and the node currently open.
  std::string device_fourcc() const { return fourcc_to_string(fourcc_of(dev_format_)); }
  std::string device_path() const;
  /// Last fault / recovery message (diagnostics).
  std::string last_error() const;
  /// Frames whose kernel timestamp was not CLOCK_MONOTONIC (stamped at dequeue instead).
  std::uint64_t non_monotonic_stamps() const { return non_mono_.load(); }

 private:
  struct Buffer {
    void* start = nullptr;
    std::size_t length = 0;
  };
  void open_and_configure(bool first);  // throws DeviceError / std::runtime_error
  // The stages of open_and_configure; `dev` is "v4l2 camera 'ID' (PATH)", the errors' prefix.
  std::string open_device();                                     // fd_ open and a capture node: returns `dev`
  DeviceFormat choose_format(const std::string& dev) const;      // the configured fourcc, or the best offered
  void set_format(const std::string& dev, DeviceFormat chosen);  // VIDIOC_S_FMT at the configured size
  double set_frame_rate();                                       // the rate the driver granted (or the configured one)
  void map_buffers(const std::string& dev);                      // VIDIOC_REQBUFS + mmap of each buffer
  void apply_controls();
  void stream_on();
  void close_device();
  void run();
  bool capture_one(TimeNs& last_frame);  // false on device error (errno in last_errno_)
  void fault(const std::string& what);
  void set_error(const std::string& what);
  bool wait_stop(TimeNs d);

  Config cfg_;
  std::string id_;
  std::uint16_t index_;
  Clock* clock_;
  std::unique_ptr<Clock> own_clock_;
  CameraFormat format_;
  DeviceFormat dev_format_ = DeviceFormat::kYuyv;
  std::size_t stride_ = 0;
  std::unique_ptr<FramePool> pool_;

  int fd_ = -1;
  int wake_fd_ = -1;
  std::string path_;
  std::vector<Buffer> buffers_;
  bool have_seq_ = false;
  std::uint32_t last_seq_ = 0;

  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<std::uint64_t> frames_{0}, dropped_{0}, corrupt_{0}, faults_{0}, recoveries_{0}, non_mono_{0};
  std::atomic<DeviceState> state_{DeviceState::kStopped};
  std::atomic<TimeNs> last_frame_time_{0};
  mutable std::mutex text_mutex_;
  std::string last_error_;
};

/// Registers factory "v4l2" in `r`.
void register_v4l2_backend(BackendRegistry& r);

}  // namespace regolith::hal::v4l2
