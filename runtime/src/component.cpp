#include "regolith/runtime/component.hpp"

#include <algorithm>
#include <cstdio>

#include "regolith/runtime/context.hpp"
#include "regolith/runtime/input_timeout.hpp"
#include "regolith/runtime/worker_pool.hpp"

namespace regolith::runtime {

const char* to_string(Lifecycle s) {
  switch (s) {
    case Lifecycle::kUnconfigured: return "unconfigured";
    case Lifecycle::kInactive: return "inactive";
    case Lifecycle::kActive: return "active";
    case Lifecycle::kFinalized: return "finalized";
    case Lifecycle::kError: return "error";
  }
  return "unknown";
}

TimeNs Component::worker_cpu_ns() const {
  return workers_ != nullptr ? workers_->worker_cpu_ns() : 0;
}

InputWatch& Component::watch_input(const std::string& name, TimeNs timeout) {
  auto w = std::make_unique<InputWatch>();
  w->name = name;
  w->timeout = timeout;
  inputs_.push_back(std::move(w));
  return *inputs_.back();
}

TimeNs read_input_timeout(Params& p, double rate_hz, double slack_s) {
  // A camera that does not say its rate (libcamera's default sensor mode; an unopened device in
  // `regolith config check`) is taken as 1 Hz: 2 s + slack, not the 20 s of the 0.1 Hz floor, so
  // that an outage of the front camera of a rover is flagged within seconds.
  const double fallback = 2.0 / (rate_hz > 0.0 ? std::max(0.1, rate_hz) : 1.0) + slack_s;
  char doc[256];
  std::snprintf(doc, sizeof doc,
                "the camera input is stale after this long, and a frame stamped further back than this before "
                "the last one taken is a clock step (default 2 frame periods + %g s; a camera of unknown rate "
                "counts as 1 Hz)",
                slack_s);
  return from_seconds(
      p.get<double>("input_timeout_s", fallback, {.unit = "s", .min = 0.0, .min_exclusive = true, .doc = doc}));
}

ComponentRegistry& ComponentRegistry::instance() {
  static ComponentRegistry r;
  return r;
}

void ComponentRegistry::add(const std::string& type, const std::string& doc, Factory f) {
  entries_[type] = Entry{doc, std::move(f)};
}

std::unique_ptr<Component> ComponentRegistry::make(Params& params, const std::string& type) const {
  auto it = entries_.find(type);
  if (it == entries_.end()) {
    std::vector<std::string> names;
    for (const auto& kv : entries_) names.push_back(kv.first);
    std::string msg = "unknown component type '" + type + "'";
    const std::string guess = did_you_mean(type, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    msg += "; available:";
    for (const auto& n : names) msg += " " + n;
    params.fail("type", msg);
  }
  return it->second.make();
}

std::vector<std::pair<std::string, std::string>> ComponentRegistry::types() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& kv : entries_) out.emplace_back(kv.first, kv.second.doc);
  return out;
}

// ---- Context ----------------------------------------------------------------------------------

void Context::add_device(const std::string& name, std::unique_ptr<hal::Device> d) {
  const std::string kind = d->kind();
  devices_[kind][name] = std::move(d);
}

hal::Device& Context::lookup(const std::string& kind, Params& p, std::string_view key) {
  const std::string label = kind == hal::WheelEncoders::kKind ? "encoder set" : kind == hal::Imu::kKind ? "IMU" : kind;
  const std::string name = p.require<std::string>(key, {.doc = std::string_view(label)});
  const auto k = devices_.find(kind);
  if (k != devices_.end()) {
    const auto it = k->second.find(name);
    if (it != k->second.end()) return *it->second;
  }
  std::vector<std::string> names;
  if (k != devices_.end())
    for (const auto& kv : k->second) names.push_back(kv.first);
  std::string msg = "no " + label + " named '" + name + "' in devices";
  const std::string guess = did_you_mean(name, names);
  if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
  p.fail(key, msg);
}

const hal::Imu* Context::attitude_imu() {
  const hal::Imu* imu = rover_.imu.empty() ? nullptr : find<hal::Imu>(rover_.imu);
  if (imu != nullptr) declare(Port::Kind::kDevice, rover_.imu, hal::Imu::kKind);
  return imu;
}

const RoverCamera& Context::rover_camera(Params& p, std::string_view key) {
  const std::string name = lookup(hal::Camera::kKind, p, key).id();  // must exist (located error)
  declare(Port::Kind::kDevice, name, "calibration");                 // reads the camera's geometry, not its frames
  const RoverCamera* c = rover_.camera(name);
  if (c == nullptr)
    p.fail(key, "camera '" + name + "' has no calibration: declare it once as rover.cameras." + name +
                    " {camera_info: {width, height, k, distortion_model, d} or camera_info_url: file://..., mount: "
                    "{x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad}}");
  return *c;
}

const Sun& Context::sun(Params& p, const std::string& who) const {
  if (!rover_.sun) p.fail({}, who + " needs the sun: add a top-level `sun: {azimuth_deg, elevation_deg}` block");
  return *rover_.sun;
}

}  // namespace regolith::runtime
