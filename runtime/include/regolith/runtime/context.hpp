#pragma once
// What a component sees at configure time: the clock, devices by name, named channels shared with
// other components, and the DDS participant. Everything here is resolved before anything runs.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <typeindex>

#include "regolith/core/channels.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/wheel_encoders.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

struct SystemView;

class Context {
 public:
  Context(Clock& clock, std::string config_dir) : clock_(clock), config_dir_(std::move(config_dir)) {}

  Clock& clock() { return clock_; }
  const std::string& config_dir() const { return config_dir_; }

  /// The deployment's rover description (`rover:` and `sun:` blocks), read before the devices.
  const RoverDescription& rover() const { return rover_; }
  void set_rover(RoverDescription d) { rover_ = std::move(d); }
  /// Calibration and mount of the camera device named by parameter `key` of `p`: ConfigError at
  /// `key` when the device does not exist or has no `rover.cameras.<name>` entry.
  const RoverCamera& rover_camera(Params& p, std::string_view key = "camera");
  /// The deployment sun; ConfigError at `p` (naming `who`) when the deployment has no `sun:` block.
  const Sun& sun(Params& p, const std::string& who) const;
  /// Body attitude in the local-level frame: level until an IMU provides it.
  Attitude attitude() const { return {}; }

  void add_camera(const std::string& name, std::unique_ptr<hal::Camera> cam);
  void add_encoders(const std::string& name, std::unique_ptr<hal::WheelEncoders> enc);
  /// The camera named by parameter `key` of `p` (e.g. `camera: front`); ConfigError if unknown.
  hal::Camera& camera(Params& p, std::string_view key = "camera");
  hal::WheelEncoders& encoders(Params& p, std::string_view key = "encoders");
  hal::Camera* find_camera(const std::string& name);
  const std::map<std::string, std::unique_ptr<hal::Camera>>& cameras() const { return cameras_; }
  const std::map<std::string, std::unique_ptr<hal::WheelEncoders>>& encoders() const { return encoders_; }

  /// A named latest-value channel between components (created by the first caller, shared by the
  /// rest). The type must match between producer and consumers.
  template <class T>
  LatestPool<T>& channel(const std::string& name, std::size_t max_readers = 4,
                         const std::function<T()>& make = [] { return T{}; }) {
    auto it = channels_.find(name);
    if (it == channels_.end()) {
      auto pool = std::make_shared<LatestPool<T>>(max_readers, make);
      channels_.emplace(name, ChannelEntry{std::type_index(typeid(T)), pool});
      return *pool;
    }
    if (it->second.type != std::type_index(typeid(T)))
      throw ConfigError("channel '" + name + "' is used with two different types");
    return *static_cast<LatestPool<T>*>(it->second.ptr.get());
  }

  /// The DDS participant, or nullptr when DDS is disabled in the deployment.
  dds::Participant* dds() { return dds_; }
  void set_dds(dds::Participant* p) { dds_ = p; }

  /// Rate groups and components of the deployment (for observers such as the health monitor).
  /// Complete once loading has finished; read it in activate()/step(), not in configure().
  const SystemView& system() const { return *system_; }
  void set_system(const SystemView* v) { system_ = v; }

 private:
  struct ChannelEntry {
    std::type_index type;
    std::shared_ptr<void> ptr;
  };
  Clock& clock_;
  std::string config_dir_;
  RoverDescription rover_;
  std::map<std::string, std::unique_ptr<hal::Camera>> cameras_;
  std::map<std::string, std::unique_ptr<hal::WheelEncoders>> encoders_;
  std::map<std::string, ChannelEntry> channels_;
  dds::Participant* dds_ = nullptr;
  const SystemView* system_ = nullptr;
};

}  // namespace regolith::runtime
