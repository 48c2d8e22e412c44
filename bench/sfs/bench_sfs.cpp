// SfS per-frame cost: Tsai-Shah (marching, default), Pentland (FFT),
// Bichsel-Pentland, against cv::GaussianBlur 5x5 on the same frame as a peer. Prints frames/s
// and ratios (one core: run with taskset -c 0).
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <map>
#include <string>

#include "regolith/sfs/sfs.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

namespace {
using namespace regolith;

struct Frame {
  cv::Mat img;
  sfs::LightDirection light;
};

const Frame& frame(int w, int h) {
  static std::map<int, Frame> cache;
  auto it = cache.find(w);
  if (it != cache.end()) return it->second;
  terrain_scene::SceneParams sp;
  sp.resolution_m = 0.02;
  sp.x_min_m = 0;
  sp.x_max_m = (h - 1) * 0.02;
  sp.y_min_m = 0;
  sp.y_max_m = (w - 1) * 0.02;
  sp.place_x_min_m = 0.2;
  sp.place_x_max_m = sp.x_max_m - 0.2;
  sp.place_y_abs_max_m = 100;  // clipped to the grid
  const terrain_scene::Terrain t(sp);
  const auto o = terrain_scene::render_ortho(t, {3.5, 0.6});
  Frame f{terrain_scene::to_u8(o.image), {o.light_slant_rad, o.light_tilt_rad}};
  return cache.emplace(w, f).first->second;
}

std::map<std::string, double> g_ms;

void run_sfs(benchmark::State& st, sfs::Method m) {
  const int w = static_cast<int>(st.range(0)), h = static_cast<int>(st.range(1));
  const Frame& f = frame(w, h);
  sfs::SfsParams p;
  p.method = m;
  p.tolerance = 0;  // fixed iteration count
  sfs::ShapeFromShading s(p);
  sfs::SfsResult r;
  s.compute(f.img, f.light, r);
  for (auto _ : st) {
    s.compute(f.img, f.light, r);
    benchmark::DoNotOptimize(r.height.data);
  }
  st.counters["iterations"] = r.iterations;
}

void BM_TsaiShah(benchmark::State& st) { run_sfs(st, sfs::Method::kTsaiShah); }
void BM_Pentland(benchmark::State& st) { run_sfs(st, sfs::Method::kPentland); }
void BM_BichselPentland(benchmark::State& st) { run_sfs(st, sfs::Method::kBichselPentland); }
void BM_GaussianBlur5x5(benchmark::State& st) {
  const Frame& f = frame(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  cv::Mat dst(f.img.size(), f.img.type());
  for (auto _ : st) {
    cv::GaussianBlur(f.img, dst, cv::Size(5, 5), 0);
    benchmark::DoNotOptimize(dst.data);
  }
}

BENCHMARK(BM_GaussianBlur5x5)->Args({640, 480})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Pentland)->Args({320, 240})->Args({640, 480})->Args({1280, 960})->Args({2048, 1536})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TsaiShah)->Args({320, 240})->Args({640, 480})->Args({1280, 960})->Args({2048, 1536})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BichselPentland)->Args({640, 480})->Unit(benchmark::kMillisecond);

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& r : runs)
      if (r.run_type == Run::RT_Iteration && !r.error_occurred)
        ms_[r.benchmark_name()] = r.GetAdjustedRealTime();  // in the benchmark's unit (ms)
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    const double blur = ms_["BM_GaussianBlur5x5/640/480"];
    std::printf("\n640x480 per frame (same run, 1 thread):\n");
    for (const char* n : {"BM_GaussianBlur5x5/640/480", "BM_Pentland/640/480", "BM_TsaiShah/640/480",
                          "BM_BichselPentland/640/480"}) {
      const double ms = ms_[n];
      if (ms <= 0) continue;
      std::printf("  %-28s %9.3f ms  %8.1f frames/s  %7.1fx GaussianBlur5x5\n", n, ms, 1000.0 / ms, ms / blur);
    }
    const double ts = ms_["BM_TsaiShah/640/480"], pe = ms_["BM_Pentland/640/480"];
    if (ts > 0 && pe > 0) std::printf("  Tsai-Shah / Pentland = %.1f\n", ts / pe);
    const double p1 = ms_["BM_Pentland/320/240"], p4 = ms_["BM_Pentland/1280/960"];
    if (p1 > 0 && p4 > 0) std::printf("  Pentland 1280x960 / 320x240 = %.1f (16x pixels)\n", p4 / p1);
  }

 private:
  std::map<std::string, double> ms_;
};

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  RatioReporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  benchmark::Shutdown();
  return 0;
}
