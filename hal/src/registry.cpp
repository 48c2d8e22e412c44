#include "regolith/hal/registry.hpp"

#include <filesystem>

namespace regolith::hal {

BackendRegistry& BackendRegistry::instance() {
  static BackendRegistry r;
  return r;
}

const BackendRegistry::Entry& BackendRegistry::lookup(const std::string& kind, Params& p) const {
  const std::string name = p.require<std::string>("backend", {.doc = "backend name"});
  static const std::map<std::string, Entry> kNone;
  const auto k = kinds_.find(kind);
  const auto& m = k == kinds_.end() ? kNone : k->second;
  auto it = m.find(name);
  if (it == m.end()) {
    std::vector<std::string> names;
    for (const auto& kv : m) names.push_back(kv.first);
    std::string msg = "unknown " + std::string(kind == "encoders" ? "encoder" : kind) + " backend '" + name + "'";
    const std::string guess = did_you_mean(name, names);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    msg += "; available:";
    for (const auto& n : names) msg += " " + n;
    p.fail("backend", msg);
  }
  return it->second;
}

std::vector<std::pair<std::string, std::string>> BackendRegistry::backends(const std::string& kind) const {
  std::vector<std::pair<std::string, std::string>> out;
  const auto k = kinds_.find(kind);
  if (k != kinds_.end())
    for (const auto& kv : k->second) out.emplace_back(kv.first, kv.second.doc);
  return out;
}

std::vector<std::string> BackendRegistry::kinds() const {
  std::vector<std::string> out;
  for (const auto& kv : kinds_) out.push_back(kv.first);
  return out;
}

std::string resolve_path(const DeviceContext& ctx, const std::string& path) {
  std::filesystem::path p(path);
  if (p.is_absolute() || ctx.config_dir.empty()) return path;
  return (std::filesystem::path(ctx.config_dir) / p).lexically_normal().string();
}

}  // namespace regolith::hal
