#pragma once
// Shared helpers for the wheel_sinkage pipeline tests: registration of the runtime, mock backends
// and the component, a probe component that records every sample of the "terrain/wheel_sinkage"
// channel (into a pre-reserved vector: it does not allocate in step), and deployment loading.
#include <atomic>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "diagnostics.hpp"
#include "regolith/core/error.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/sinkage/component.hpp"
#include "temp_dir.hpp"

namespace regolith::sinkage::testing {

/// Every sample the probe saw (one per new frame sequence), in order.
inline std::vector<WheelSinkageSample>& probe_samples() {
  static std::vector<WheelSinkageSample> v;
  return v;
}

class SinkageProbe final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    allocate_ = p.get<bool>("allocate_each_cycle", false, {.doc = "positive control of the allocation probe"});
    in_ = &ctx.channel<WheelSinkageSample>(kSinkageChannel, 4);
    probe_samples().clear();
    probe_samples().reserve(4096);
  }
  void step(const runtime::CycleInfo&) override {
    if (allocate_) control_.reset(new int(1));
    auto lease = in_->acquire();
    if (!lease || lease.generation() == last_gen_) return;
    last_gen_ = lease.generation();
    if (probe_samples().size() < probe_samples().capacity()) probe_samples().push_back(*lease);
  }

 private:
  LatestPool<WheelSinkageSample>* in_ = nullptr;
  std::uint64_t last_gen_ = 0;
  bool allocate_ = false;
  std::unique_ptr<int> control_;
};

inline void register_all() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  mocks::register_mock_backends(hal::BackendRegistry::instance());
  register_component();
  runtime::ComponentRegistry::instance().add("test_sinkage_probe", "records terrain/wheel_sinkage samples",
                                             [] { return std::make_unique<SinkageProbe>(); });
}

inline std::unique_ptr<runtime::Application> load(const std::string& yaml, const std::string& name = "deploy.yaml") {
  register_all();
  runtime::AppOptions opts;
  opts.sim_time = true;
  opts.enable_dds = false;
  return runtime::Application::load(Params::load_string(yaml, name), opts);
}

/// ConfigError message of loading `yaml` ("<no error>" when it loads).
inline std::string load_error(const std::string& yaml) {
  try {
    load(yaml);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "<no error>";
}

/// Runs for `seconds` of simulated time and stops (deactivate: the writer thread flushes).
inline void run_for(runtime::Application& app, double seconds) {
  std::atomic<bool> stop{false};
  app.start();
  app.run(from_seconds(seconds), stop);
  app.stop();
}

using regolith::testing::diagnostic;  // diagnostics() value of a named component

inline std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

/// A deployment: synthetic wheel camera + paired encoders, the sinkage component and the probe.
/// `scene` is spliced into the shared scene mapping, `component` into the component mapping.
inline std::string deployment(const std::string& scene, const std::string& component = "",
                              const std::string& extra_devices = "", double group_hz = 20.0) {
  return "name: sinkage_test\n"
         "dds: {enabled: false}\n"
         "devices:\n"
         "  cameras:\n"
         "    wheel_cam: &scene {backend: synthetic_wheel, " +
         scene +
         "}\n"
         "  encoders:\n"
         "    wheel_leg: *scene\n" +
         extra_devices +
         "rate_groups:\n"
         "  - name: sinkage\n"
         "    rate_hz: " +
         std::to_string(group_hz) +
         "\n"
         "    members: [sinkage, probe]\n"
         "components:\n"
         "  sinkage:\n"
         "    type: wheel_sinkage\n"
         "    camera: wheel_cam\n"
         "    encoders: wheel_leg\n"
         "    geometry:\n"
         "      hub_center_px: [320, 110]\n"
         "      leg_length_px: 300\n"
         "      leg_width_px: 28\n"
         "      hub_radius_px: 40\n"
         "      foot_width_px: 48\n"
         "      foot_thickness_px: 10\n"
         "    mm_per_px: 0.5\n" +
         component + "  probe: {type: test_sinkage_probe}\n";
}

}  // namespace regolith::sinkage::testing
