#include "regolith/runtime/component.hpp"

#include "regolith/runtime/context.hpp"

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

InputWatch& Component::watch_input(const std::string& name, TimeNs timeout) {
  auto w = std::make_unique<InputWatch>();
  w->name = name;
  w->timeout = timeout;
  inputs_.push_back(std::move(w));
  return *inputs_.back();
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

void Context::add_camera(const std::string& name, std::unique_ptr<hal::Camera> cam) {
  cameras_[name] = std::move(cam);
}
void Context::add_encoders(const std::string& name, std::unique_ptr<hal::WheelEncoders> enc) {
  encoders_[name] = std::move(enc);
}

hal::Camera* Context::find_camera(const std::string& name) {
  auto it = cameras_.find(name);
  return it == cameras_.end() ? nullptr : it->second.get();
}

namespace {
template <class Map>
auto& find_device(Map& m, Params& p, std::string_view key, const char* kind) {
  const std::string name = p.require<std::string>(key, {.doc = std::string_view(kind)});
  auto it = m.find(name);
  if (it == m.end()) {
    std::vector<std::string> names;
    for (const auto& kv : m) names.push_back(kv.first);
    std::string msg = std::string("no ") + kind + " named '" + name + "' in devices";
    const std::string guess = did_you_mean(name, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    p.fail(key, msg);
  }
  return *it->second;
}
}  // namespace

const RoverCamera& Context::rover_camera(Params& p, std::string_view key) {
  find_device(cameras_, p, key, "camera");  // must exist: a missing key or unknown name is reported
  const std::string name = p.node()[std::string(key)].Scalar();
  declare(Port::Kind::kDevice, name, "calibration");  // reads the camera's geometry, not its frames
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

hal::Camera& Context::camera(Params& p, std::string_view key) {
  hal::Camera& c = find_device(cameras_, p, key, "camera");
  declare(Port::Kind::kDevice, p.node()[std::string(key)].Scalar(), "camera");
  return c;
}
hal::WheelEncoders& Context::encoders(Params& p, std::string_view key) {
  hal::WheelEncoders& e = find_device(encoders_, p, key, "encoder set");
  declare(Port::Kind::kDevice, p.node()[std::string(key)].Scalar(), "encoders");
  return e;
}

}  // namespace regolith::runtime
