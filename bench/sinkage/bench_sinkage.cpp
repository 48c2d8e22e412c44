// Frames/s of the full sinkage estimator at 640x480 on one core (dynamic mask), next to the same
// estimator segmenting the whole frame (no dynamic mask) on the same frames in the same run.
// Also reports heap allocations per frame (global operator new counted in this binary).
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <new>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "regolith/sinkage/sinkage.hpp"
#include "regolith/wheel_scene/sinkage_setup.hpp"

namespace rs = regolith::sinkage;
namespace ws = regolith::wheel_scene;

namespace {

struct Data {
  ws::SceneParams scene;
  std::vector<ws::SequenceFrame> frames;
};

const Data& data(bool poor) {
  static std::map<bool, Data> cache;
  auto it = cache.find(poor);
  if (it != cache.end()) return it->second;
  Data d;
  d.scene.light = poor ? ws::Illumination::poor() : ws::Illumination::normal();
  d.scene.misalignment_rad = 2.0 * 3.14159265358979 / 180.0;
  ws::WheelSceneGenerator gen(d.scene);
  ws::SequenceSpec spec;
  spec.frames = 32;
  spec.angle_step_rad = 0.05;
  d.frames = ws::make_sequence(gen, spec);
  return cache.emplace(poor, std::move(d)).first->second;
}

void run(benchmark::State& state, bool masked, bool poor) {
  const Data& d = data(poor);
  rs::SinkageParams p = ws::sinkage_params(d.scene.wheel);
  p.use_dynamic_mask = masked;
  rs::SinkageEstimator est(ws::sinkage_geometry(d.scene.wheel), p, d.scene.size);
  rs::SinkageResult r;
  std::size_t i = 0;
  for (const auto& f : d.frames) est.process(f.bgr, f.truth.encoder_angle_rad, r);  // warm-up
  const long news0 = static_cast<long>(regolith::testing::allocations());
  double err = 0;
  for (auto _ : state) {
    const auto& f = d.frames[i];
    est.process(f.bgr, f.truth.encoder_angle_rad, r);
    const double z = r.sinkage_mm;
    benchmark::DoNotOptimize(&z);
    err += std::abs(z - f.truth.sinkage_mm);
    i = (i + 1) % d.frames.size();
  }
  const long news = static_cast<long>(regolith::testing::allocations()) - news0;
  state.SetItemsProcessed(state.iterations());
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["allocs_per_frame"] =
      static_cast<double>(news) / static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
  state.counters["mean_err_mm"] = err / static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
}

void BM_Sinkage_DynamicMask_Normal(benchmark::State& s) {
  run(s, true, false);
}
void BM_Sinkage_FullFrame_Normal(benchmark::State& s) {
  run(s, false, false);
}
void BM_Sinkage_DynamicMask_Poor(benchmark::State& s) {
  run(s, true, true);
}
void BM_Sinkage_FullFrame_Poor(benchmark::State& s) {
  run(s, false, true);
}
BENCHMARK(BM_Sinkage_DynamicMask_Normal)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Sinkage_FullFrame_Normal)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Sinkage_DynamicMask_Poor)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Sinkage_FullFrame_Poor)->Unit(benchmark::kMicrosecond);

/// Console output plus a record of the per-frame real time of every benchmark.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> seconds, cpu_seconds;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs) {
      if (r.iterations <= 0) continue;
      seconds[r.benchmark_name()] = r.real_accumulated_time / static_cast<double>(r.iterations);
      cpu_seconds[r.benchmark_name()] = r.cpu_accumulated_time / static_cast<double>(r.iterations);
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RatioReporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  std::printf("\n640x480, one thread; target >= 500 frames/s for the dynamic-mask estimator\n");
  for (const char* light : {"Normal", "Poor"}) {
    const std::string m = std::string("BM_Sinkage_DynamicMask_") + light;
    const std::string f = std::string("BM_Sinkage_FullFrame_") + light;
    if (rep.seconds.count(m) == 0 || rep.seconds.count(f) == 0) continue;
    std::printf(
        "%-6s light, CPU time : dynamic mask %6.0f frames/s | full-frame segmentation %6.0f "
        "frames/s | ratio %.2fx\n",
        light, 1.0 / rep.cpu_seconds[m], 1.0 / rep.cpu_seconds[f], rep.cpu_seconds[f] / rep.cpu_seconds[m]);
    std::printf(
        "%-6s light, wall time: dynamic mask %6.0f frames/s | full-frame segmentation %6.0f "
        "frames/s | ratio %.2fx\n",
        light, 1.0 / rep.seconds[m], 1.0 / rep.seconds[f], rep.seconds[f] / rep.seconds[m]);
  }
  benchmark::Shutdown();
  return 0;
}
