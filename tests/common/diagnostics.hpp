#pragma once
// A component's diagnostics() in tests, one lookup for every test (header-only, on every test
// target's include path, like error_of.hpp):
//
//   namespace rt = regolith::testing;
//   EXPECT_EQ(rt::diagnostic(*app, "sfs", "frames_out_of_order"), "2");
//   const auto kv = rt::diagnostics_of(*app, "wheel_sinkage");  // key -> value
//
// A missing component or key reads "<no component NAME>" / "<no key KEY>", so that the expectation
// that compares it fails with a message saying which. And one entry of a health snapshot:
//
//   const runtime::HealthEntry* io = rt::health_entry(*snapshot, "io", runtime::HealthEntry::Kind::kRateGroup);
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "regolith/runtime/application.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/health.hpp"

namespace regolith::testing {

/// The key -> value pairs of `c.diagnostics()`.
inline std::map<std::string, std::string> diagnostics_of(const runtime::Component& c) {
  std::vector<std::pair<std::string, std::string>> kv;
  c.diagnostics(kv);
  return {kv.begin(), kv.end()};
}

/// The diagnostics of the component named `name`; empty when there is none.
inline std::map<std::string, std::string> diagnostics_of(const runtime::Application& app, const std::string& name) {
  for (const runtime::Component* c : app.view().components)
    if (c->name() == name) return diagnostics_of(*c);
  return {};
}

/// One diagnostics() value of the component `c`.
inline std::string diagnostic(const runtime::Component& c, const std::string& key) {
  const auto kv = diagnostics_of(c);
  const auto it = kv.find(key);
  return it != kv.end() ? it->second : "<no key " + key + ">";
}

/// One diagnostics() value of the component named `name`.
inline std::string diagnostic(const runtime::Application& app, const std::string& name, const std::string& key) {
  for (const runtime::Component* c : app.view().components)
    if (c->name() == name) return diagnostic(*c, key);
  return "<no component " + name + ">";
}

/// The entry of `s` for `name` of `kind` (a rate group and a component may share a name), or nullptr.
inline const runtime::HealthEntry* health_entry(const runtime::HealthSnapshot& s, std::string_view name,
                                                runtime::HealthEntry::Kind kind) {
  for (std::uint32_t i = 0; i < s.count && i < s.entries.size(); ++i)
    if (s.entries[i].kind == kind && name == s.entries[i].name.data()) return &s.entries[i];
  return nullptr;
}

}  // namespace regolith::testing
