#pragma once
// libcamera camera backend: camera by id or index, stream role / size / pixel format from YAML,
// a request queue over FrameBufferAllocator buffers, frames delivered from the completion callback
// with the sensor timestamp, controls by name, fault reporting and restart with back-off.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/device.hpp"
#include "regolith/hal/registry.hpp"

namespace regolith::hal::libcam {

struct Config {
  std::string camera;          ///< [camera] libcamera id (cam --list); empty: use [index]
  int index = 0;               ///< [index] position in the sorted camera list
  std::string role = "video";  ///< [role] raw | still | video | viewfinder
  int width = 960;             ///< [width] px
  int height = 720;            ///< [height] px
  std::string pixel_format =
      "auto";  ///< [format] libcamera format name (BGR888, RGB888, YUYV, UYVY, R8, MJPEG) or auto
  PixelFormat output = PixelFormat::kBgr8;  ///< [pixel_format] mono8 | bgr8
  int buffers = 4;                          ///< [buffers] requests / buffers in flight (1..16)
  /// [rate] Hz, set through FrameDurationLimits when the camera has it (else taken as the nominal
  /// rate, as the V4L2 backend takes a driver without frame intervals); 0: the sensor mode's own,
  /// unknown to the components (their input timeouts then assume 1 Hz).
  double rate_hz = 0.0;
  std::vector<std::pair<std::string, std::string>> controls;  ///< [controls] libcamera control name -> value
  double frame_timeout_s = 2.0;  ///< [frame_timeout] s without a completed request -> fault + restart
  double retry_min_s = 0.2;      ///< [retry_min] s
  double retry_max_s = 5.0;      ///< [retry_max] s
  int max_readers = 4;           ///< [max_readers]
  void validate() const;
};

Config config_from_params(Params& p);

/// A camera as libcamera sees it (for `regolith devices`).
struct CameraInfo {
  std::string id;
  std::string model;  ///< properties::Model when present
  struct Format {
    std::string pixel_format;                ///< libcamera name, e.g. "BGR888"
    std::vector<std::pair<int, int>> sizes;  ///< discrete sizes offered for the role
    std::string size_range;                  ///< "min - max" text
  };
  std::vector<Format> formats;        ///< for the video-recording role
  std::vector<std::string> controls;  ///< control names with their ranges
};
/// Cameras libcamera can see (starts a camera manager; empty when there is none).
std::vector<CameraInfo> list_libcamera_cameras();

class LibcameraCamera final : public Camera {
 public:
  /// Acquires and configures the camera now; throws (field + message naming the camera)
  /// DeviceUnavailableError when libcamera sees no such camera (id, index) or it is busy, and
  /// DeviceConfigError when the role, format, size or a control is not available.
  LibcameraCamera(Config cfg, const DeviceContext& ctx);
  ~LibcameraCamera() override;

  const std::string& id() const override;
  CameraFormat format() const override;
  void start() override;
  void stop() override;
  bool latest(TimeNs now, FrameLease& out) override;
  CameraStats stats() const override;

  std::string camera_id() const;
  std::string device_format() const;  ///< libcamera pixel format in use
  std::string last_error() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Registers factory "libcamera" in `r`.
void register_libcamera_backend(BackendRegistry& r);

}  // namespace regolith::hal::libcam
