#pragma once
// What a component sees at configure time: the clock, devices by name, named channels shared with
// other components, and the DDS participant. Everything here is resolved before anything runs.
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <typeindex>
#include <vector>

#include "regolith/core/channels.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"
#include "regolith/hal/camera.hpp"
#include "regolith/hal/imu.hpp"
#include "regolith/hal/wheel_encoders.hpp"
#include "regolith/runtime/dataflow.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

struct SystemView;

/// A consumed channel as a component holds it: connected by the loader once every component is
/// configured (Context::link), so read it from activate() / step() only.
template <class T>
class Input {
 public:
  using Lease = typename LatestPool<T>::Lease;
  /// The newest value (empty lease when none was written yet).
  Lease acquire() const { return pool_ != nullptr ? pool_->acquire() : Lease{}; }
  bool connected() const { return pool_ != nullptr; }
  const std::string& name() const { return name_; }

 private:
  friend class Context;
  std::string name_;
  const LatestPool<T>* pool_ = nullptr;
};

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
  /// The IMU giving the body attitude (rover.imu), or null (a level rover). Records the
  /// component's device port; ask it per frame: Imu::attitude_at(capture time).
  const hal::Imu* attitude_imu();

  // ---- devices: one store for every kind (hal::Device), names unique within a kind ----
  void add_device(const std::string& name, std::unique_ptr<hal::Device> d);
  /// The device of kind T named by parameter `key` of `p` (e.g. `camera: front`); ConfigError at
  /// `key` (with did-you-mean) when there is none. Records the component's device port.
  template <class T>
  T& device(Params& p, std::string_view key) {
    T& d = static_cast<T&>(lookup(T::kKind, p, key));
    declare(Port::Kind::kDevice, d.id(), T::kKind);
    return d;
  }
  /// The device of kind T named `name`, or null.
  template <class T>
  T* find(const std::string& name) const {
    const auto k = devices_.find(T::kKind);
    if (k == devices_.end()) return nullptr;
    const auto it = k->second.find(name);
    return it == k->second.end() ? nullptr : static_cast<T*>(it->second.get());
  }
  /// Every device of kind T, by name.
  template <class T>
  std::vector<std::pair<std::string, T*>> devices_of() const {
    std::vector<std::pair<std::string, T*>> out;
    const auto k = devices_.find(T::kKind);
    if (k != devices_.end())
      for (const auto& [name, d] : k->second) out.emplace_back(name, static_cast<T*>(d.get()));
    return out;
  }
  /// Every device of every kind (start / stop / health).
  std::vector<hal::Device*> all_devices() const {
    std::vector<hal::Device*> out;
    for (const auto& [kind, m] : devices_)
      for (const auto& [name, d] : m) out.push_back(d.get());
    return out;
  }
  hal::Camera& camera(Params& p, std::string_view key = "camera") { return device<hal::Camera>(p, key); }
  hal::WheelEncoders& encoders(Params& p, std::string_view key = "encoders") {
    return device<hal::WheelEncoders>(p, key);
  }

  /// Declares that the component being configured produces channel `name` with payload T, and
  /// creates its slots now with `make` (one producer per channel, checked by link()).
  template <class T>
  LatestPool<T>& produce(
      const std::string& name, std::size_t max_readers = 4, const std::function<T()>& make = [] { return T{}; }) {
    declare(Port::Kind::kProduces, name, type_name(typeid(T)));
    auto it = channels_.find(name);
    if (it != channels_.end() && it->second.type != std::type_index(typeid(T)))
      throw ConfigError(component_where_ + ": components." + component_ + ": produces channel '" + name + "' as " +
                        type_name(typeid(T)) + " but it already carries " + it->second.type_name);
    return channel<T>(name, max_readers, make);
  }

  /// Declares that the component being configured consumes channel `name` with payload T. The
  /// input is connected by link() after every component is configured.
  template <class T>
  Input<T>& consume(const std::string& name) {
    declare(Port::Kind::kConsumes, name, type_name(typeid(T)));
    auto in = std::make_shared<Input<T>>();
    in->name_ = name;
    Input<T>& ref = *in;
    links_.push_back([this, name, in] {
      const auto it = channels_.find(name);
      if (it != channels_.end() && it->second.type == std::type_index(typeid(T)))
        in->pool_ = static_cast<const LatestPool<T>*>(it->second.ptr.get());
    });
    keep_.push_back(std::move(in));
    return ref;
  }

  /// Declares that the component being configured reads `part` of channel `name`'s payload (e.g.
  /// the "height" of terrain/dtm). A producer whose parts cost time asks wanted() in activate()
  /// (every component is configured by then) and skips the work nobody reads.
  void want(const std::string& name, const std::string& part) { wanted_.insert(name + '\n' + part); }
  bool wanted(const std::string& name, const std::string& part) const { return wanted_.count(name + '\n' + part) > 0; }

  /// The loader: which component is configuring now (its name and "file:line:col"), so that
  /// produce / consume / camera / encoders record its ports.
  void begin_component(const std::string& name, const std::string& where) {
    component_ = name;
    component_where_ = where;
  }
  void end_component() { component_.clear(); }
  const std::vector<Port>& ports() const { return ports_; }
  /// Connects every consumed input to its producer's channel; call after DataFlowGraph::check().
  void link() {
    for (auto& f : links_) f();
  }

  /// A named latest-value channel by name, for observers outside the component graph (the live
  /// summary, tests): created on first use, the type must match. Components use produce/consume.
  template <class T>
  LatestPool<T>& channel(
      const std::string& name, std::size_t max_readers = 4, const std::function<T()>& make = [] { return T{}; }) {
    auto it = channels_.find(name);
    if (it == channels_.end()) {
      auto pool = std::make_shared<LatestPool<T>>(max_readers, make);
      channels_.emplace(name, ChannelEntry{std::type_index(typeid(T)), type_name(typeid(T)), pool});
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
    std::string type_name;
    std::shared_ptr<void> ptr;
  };
  void declare(Port::Kind kind, const std::string& name, const std::string& type) {
    if (component_.empty()) return;
    for (const auto& q : ports_)
      if (q.kind == kind && q.component == component_ && q.name == name && q.type == type) return;
    ports_.push_back(Port{kind, component_, name, type, component_where_});
  }
  std::string component_, component_where_;
  std::vector<Port> ports_;
  std::vector<std::function<void()>> links_;
  std::vector<std::shared_ptr<void>> keep_;
  Clock& clock_;
  std::string config_dir_;
  RoverDescription rover_;
  hal::Device& lookup(const std::string& kind, Params& p, std::string_view key);
  std::map<std::string, std::map<std::string, std::unique_ptr<hal::Device>>> devices_;  ///< kind -> name
  std::map<std::string, ChannelEntry> channels_;
  std::set<std::string> wanted_;  // "channel\npart" declared by want()
  dds::Participant* dds_ = nullptr;
  const SystemView* system_ = nullptr;
};

}  // namespace regolith::runtime
