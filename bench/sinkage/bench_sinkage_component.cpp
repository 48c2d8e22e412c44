// Cost of one wheel_sinkage component step inside a rate group (frame lease from the mock camera,
// angle interpolation at the capture time, estimator, channel publish, bench-log queue) next to the
// bare estimator on frames of the same scene, measured in the same run. Simulated clock: every
// cycle of the "sinkage" group takes exactly one new frame.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/sinkage/component.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"

namespace rs = regolith::sinkage;
namespace ws = regolith::wheel_scene;
using namespace regolith;

namespace {

constexpr double kRateHz = 100.0;

std::string deployment(bool log) {
  const std::string log_keys =
      log ? "    log_csv: " + (std::filesystem::temp_directory_path() / "regolith_bench_sinkage_log.csv").string() +
                "\n    transducer_encoders: lvdt\n    transducer: z\n"
          : "";
  return "name: bench\n"
         "dds: {enabled: false}\n"
         "devices:\n"
         "  cameras:\n"
         "    cam: &scene {backend: synthetic_wheel, rate_hz: 100, frames: 32, speed_rad_s: 5.0, sinkage_mm: 25}\n"
         "  encoders:\n"
         "    enc: *scene\n"
         "    lvdt: {backend: scripted, wheels: [z], speed_rad_s: 0.001}\n"
         "rate_groups:\n"
         "  - {name: sinkage, rate_hz: 100, members: [sinkage]}\n"
         "components:\n"
         "  sinkage:\n"
         "    type: wheel_sinkage\n"
         "    camera: cam\n"
         "    encoders: enc\n"
         "    geometry: {hub_center_px: [320, 110], leg_length_px: 300, leg_width_px: 28}\n"
         "    mm_per_px: 0.5\n" +
         log_keys;
}

void register_all() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  mocks::register_mock_backends(hal::BackendRegistry::instance());
  rs::register_component();
}

std::uint64_t frames_of(const runtime::Application& app) {
  std::vector<std::pair<std::string, std::string>> kv;
  app.view().components.front()->diagnostics(kv);
  for (const auto& [k, v] : kv)
    if (k == "frames") return std::stoull(v);
  return 0;
}

void BM_ComponentStep(benchmark::State& state, bool log) {
  register_all();
  runtime::AppOptions opts;
  opts.sim_time = true;
  opts.enable_dds = false;
  auto app = runtime::Application::load(Params::load_string(deployment(log), "bench.yaml"), opts);
  std::atomic<bool> stop{false};
  app->start();
  app->run(from_seconds(0.32), stop);  // warm-up: one loop of the frames
  const std::uint64_t f0 = frames_of(*app);
  const TimeNs period = static_cast<TimeNs>(1e9 / kRateHz);
  for (auto _ : state) app->run(period, stop);
  const std::uint64_t frames = frames_of(*app) - f0;
  app->stop();
  state.SetItemsProcessed(static_cast<std::int64_t>(frames));
  state.counters["frames_per_iter"] = static_cast<double>(frames) / static_cast<double>(state.iterations());
}

void BM_EstimatorOnly(benchmark::State& state) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  ws::SequenceSpec spec;
  spec.frames = 32;
  spec.angle_step_rad = 5.0 / kRateHz;
  spec.max_sinkage_mm = 25.0;
  const auto frames = ws::make_sequence(gen, spec);
  rs::WheelGeometry g;  // defaults = the synthetic 640x480 scene
  rs::SinkageParams p;
  p.mm_per_px = sp.wheel.mm_per_px;
  rs::SinkageEstimator est(g, p, sp.size);
  rs::SinkageResult r;
  for (const auto& f : frames) est.process(f.bgr, f.truth.encoder_angle_rad, r);
  std::size_t i = 0;
  for (auto _ : state) {
    est.process(frames[i].bgr, frames[i].truth.encoder_angle_rad, r);
    benchmark::DoNotOptimize(r.sinkage_mm);
    i = (i + 1) % frames.size();
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_Component(benchmark::State& s) {
  BM_ComponentStep(s, false);
}
void BM_ComponentWithLog(benchmark::State& s) {
  BM_ComponentStep(s, true);
}
BENCHMARK(BM_EstimatorOnly)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Component)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ComponentWithLog)->Unit(benchmark::kMicrosecond);

class Reporter : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> cpu_per_item;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      const auto it = r.counters.find("items_per_second");
      if (it != r.counters.end() && it->second.value > 0) cpu_per_item[r.benchmark_name()] = 1.0 / it->second.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  Reporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  const auto& m = rep.cpu_per_item;
  if (m.count("BM_EstimatorOnly") && m.count("BM_Component")) {
    const double e = m.at("BM_EstimatorOnly"), c = m.at("BM_Component");
    std::printf(
        "\n640x480: estimator alone %.0f us/frame (%.0f frames/s); component step in its rate group "
        "%.0f us/frame (%.0f frames/s); ratio %.2fx",
        e * 1e6, 1.0 / e, c * 1e6, 1.0 / c, c / e);
    if (m.count("BM_ComponentWithLog")) {
      std::printf("; with bench log + transducer %.0f us/frame (%.2fx)", m.at("BM_ComponentWithLog") * 1e6,
                  m.at("BM_ComponentWithLog") / e);
    }
    std::printf("\n(the component time includes the mock camera copying each new 640x480 frame into its pool)\n");
  }
  benchmark::Shutdown();
  return 0;
}
