#pragma once
// Backends are chosen by name in the deployment YAML (`backend: v4l2`). Each backend library
// registers a factory here; unknown names are rejected with a did-you-mean.
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::hal {

/// What a backend gets besides its own parameters.
struct DeviceContext {
  std::string id;           ///< device name in the YAML (e.g. "front")
  std::uint16_t index = 0;  ///< index among devices of its kind
  Clock* clock = nullptr;   ///< the process clock (simulated under --sim-time)
  std::string config_dir;   ///< directory of the YAML file: relative paths resolve from here
  /// false for `regolith config check`: validate parameters only, do not open or probe devices.
  bool open_devices = true;
  /// The deployment's rover description (camera calibration and mounts, sun); never null when
  /// built by the Application. Mock scenes render with it, so geometry is declared once.
  const RoverDescription* rover = nullptr;
};

/// Builds a device of kind T (Camera, WheelEncoders, Imu) from its YAML mapping.
template <class T>
using Factory = std::function<std::unique_ptr<T>(Params&, const DeviceContext&)>;
using CameraFactory = Factory<Camera>;
using EncoderFactory = Factory<WheelEncoders>;
using ImuFactory = Factory<Imu>;

/// Backends by device kind and name. One implementation for every kind (`add<T>` / `make<T>`).
class BackendRegistry {
 public:
  static BackendRegistry& instance();

  template <class T>
  void add(const std::string& backend, const std::string& doc, Factory<T> f) {
    kinds_[T::kKind][backend] = Entry{doc, std::make_shared<Factory<T>>(std::move(f))};
  }
  /// Build the device of kind T named by `p`'s `backend` key; ConfigError (with did-you-mean and
  /// the available backends of that kind) for an unknown backend.
  template <class T>
  std::unique_ptr<T> make(Params& p, const DeviceContext& ctx) const {
    return (*static_cast<const Factory<T>*>(lookup(T::kKind, p).factory.get()))(p, ctx);
  }
  /// (backend, doc) of one kind, sorted by name.
  std::vector<std::pair<std::string, std::string>> backends(const std::string& kind) const;
  /// kinds with at least one backend, sorted.
  std::vector<std::string> kinds() const;

  /// A hardware backend's "what is attached" listing for `regolith devices` (device nodes with
  /// their formats, CAN interfaces...). `slow`: takes seconds (skipped with --no-libcamera).
  struct Lister {
    std::string backend;
    bool slow = false;
    std::function<void(std::ostream&)> list;
  };
  void add_lister(std::string backend, std::function<void(std::ostream&)> list, bool slow = false) {
    listers_.push_back({std::move(backend), slow, std::move(list)});
  }
  const std::vector<Lister>& listers() const { return listers_; }

  // Spelled-out forms used by the backends' registration functions.
  void add_camera(const std::string& n, const std::string& doc, CameraFactory f) { add<Camera>(n, doc, std::move(f)); }
  void add_encoders(const std::string& n, const std::string& doc, EncoderFactory f) {
    add<WheelEncoders>(n, doc, std::move(f));
  }
  std::unique_ptr<Camera> make_camera(Params& p, const DeviceContext& ctx) const { return make<Camera>(p, ctx); }
  std::unique_ptr<WheelEncoders> make_encoders(Params& p, const DeviceContext& ctx) const {
    return make<WheelEncoders>(p, ctx);
  }
  std::vector<std::pair<std::string, std::string>> cameras() const { return backends(Camera::kKind); }
  std::vector<std::pair<std::string, std::string>> encoders() const { return backends(WheelEncoders::kKind); }

 private:
  struct Entry {
    std::string doc;
    std::shared_ptr<void> factory;  ///< a Factory<T> of the kind's T
  };
  const Entry& lookup(const std::string& kind, Params& p) const;
  std::map<std::string, std::map<std::string, Entry>> kinds_;
  std::vector<Lister> listers_;
};

/// Resolve `path` relative to the configuration file's directory (absolute paths unchanged).
std::string resolve_path(const DeviceContext& ctx, const std::string& path);

}  // namespace regolith::hal
