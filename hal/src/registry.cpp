#include "regolith/hal/registry.hpp"

#include <filesystem>

namespace regolith::hal {

BackendRegistry& BackendRegistry::instance() {
  static BackendRegistry r;
  return r;
}

void BackendRegistry::add_camera(const std::string& name, const std::string& doc, CameraFactory f) {
  cameras_[name] = CameraEntry{doc, std::move(f)};
}
void BackendRegistry::add_encoders(const std::string& name, const std::string& doc, EncoderFactory f) {
  encoders_[name] = EncoderEntry{doc, std::move(f)};
}

namespace {
template <class Map>
const typename Map::mapped_type& lookup(const Map& m, Params& p, const char* kind) {
  const std::string name = p.require<std::string>("backend", {.doc = "backend name"});
  auto it = m.find(name);
  if (it == m.end()) {
    std::vector<std::string> names;
    for (const auto& kv : m) names.push_back(kv.first);
    std::string msg = std::string("unknown ") + kind + " backend '" + name + "'";
    const std::string guess = did_you_mean(name, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    msg += "; available:";
    for (const auto& n : names) msg += " " + n;
    p.fail("backend", msg);
  }
  return it->second;
}
}  // namespace

std::unique_ptr<Camera> BackendRegistry::make_camera(Params& p, const DeviceContext& ctx) const {
  return lookup(cameras_, p, "camera").make(p, ctx);
}
std::unique_ptr<WheelEncoders> BackendRegistry::make_encoders(Params& p, const DeviceContext& ctx) const {
  return lookup(encoders_, p, "encoder").make(p, ctx);
}

std::vector<std::pair<std::string, std::string>> BackendRegistry::cameras() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& kv : cameras_) out.emplace_back(kv.first, kv.second.doc);
  return out;
}
std::vector<std::pair<std::string, std::string>> BackendRegistry::encoders() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& kv : encoders_) out.emplace_back(kv.first, kv.second.doc);
  return out;
}

std::string resolve_path(const DeviceContext& ctx, const std::string& path) {
  std::filesystem::path p(path);
  if (p.is_absolute() || ctx.config_dir.empty()) return path;
  return (std::filesystem::path(ctx.config_dir) / p).lexically_normal().string();
}

}  // namespace regolith::hal
