#pragma once
// Backends are chosen by name in the deployment YAML (`backend: v4l2`). Each backend library
// registers a factory here; unknown names are rejected with a did-you-mean.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::hal {

/// What a backend gets besides its own parameters.
struct DeviceContext {
  std::string id;              ///< device name in the YAML (e.g. "front")
  std::uint16_t index = 0;     ///< index among devices of its kind
  Clock* clock = nullptr;      ///< the process clock (simulated under --sim-time)
  std::string config_dir;      ///< directory of the YAML file: relative paths resolve from here
  /// false for `regolith config check`: validate parameters only, do not open or probe devices.
  bool open_devices = true;
  /// The deployment's rover description (camera calibration and mounts, sun); never null when
  /// built by the Application. Mock scenes render with it, so geometry is declared once.
  const RoverDescription* rover = nullptr;
};

using CameraFactory = std::function<std::unique_ptr<Camera>(Params&, const DeviceContext&)>;
using EncoderFactory = std::function<std::unique_ptr<WheelEncoders>(Params&, const DeviceContext&)>;

class BackendRegistry {
 public:
  static BackendRegistry& instance();

  void add_camera(const std::string& name, const std::string& doc, CameraFactory f);
  void add_encoders(const std::string& name, const std::string& doc, EncoderFactory f);

  /// Build the backend named by `p`'s `backend` key; throws ConfigError (with did-you-mean).
  std::unique_ptr<Camera> make_camera(Params& p, const DeviceContext& ctx) const;
  std::unique_ptr<WheelEncoders> make_encoders(Params& p, const DeviceContext& ctx) const;

  std::vector<std::pair<std::string, std::string>> cameras() const;
  std::vector<std::pair<std::string, std::string>> encoders() const;

 private:
  struct CameraEntry { std::string doc; CameraFactory make; };
  struct EncoderEntry { std::string doc; EncoderFactory make; };
  std::map<std::string, CameraEntry> cameras_;
  std::map<std::string, EncoderEntry> encoders_;
};

/// Resolve `path` relative to the configuration file's directory (absolute paths unchanged).
std::string resolve_path(const DeviceContext& ctx, const std::string& path);

}  // namespace regolith::hal
