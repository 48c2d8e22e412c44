// SfS per-frame cost: Tsai-Shah (marching, default), Pentland (FFT),
// Bichsel-Pentland, against cv::GaussianBlur 5x5 on the same frame as a peer. Prints frames/s
// and ratios (one core: run with taskset -c 0).
// Issue 3 "Speed": SfS + traversability (the monocular terrain path) on a 640x480 rover camera
// frame against OpenCV StereoSGBM on a 640x480 stereo pair of the same scene (baseline 0.12 m,
// block 5, MODE_SGBM; cv::setNumThreads(1)), same run; prints the ratio. The ratio is against 64
// disparities, the peer the goals name (bench/pipeline uses the same); 96 (what the rock-size
// comparison in tests/terrain_stereo runs) is timed beside it.
#include <cstdio>
#include <map>
#include <string>

#include <benchmark/benchmark.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"
#include "regolith/terrain_scene/camera_model.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"
#include "regolith/traversability/traversability.hpp"

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

// 640x480 rover stereo pair of one scene (left image is also the SfS input).
struct Pair {
  terrain_scene::CameraPose left;
  cv::Mat l8, r8;
  sfs::LightDirection light;
};

const Pair& pair() {
  static const Pair p = [] {
    terrain_scene::SceneParams sp;
    sp.seed = 3;
    sp.x_min_m = -0.5;
    sp.x_max_m = 9.0;
    sp.y_min_m = -5.0;
    sp.y_max_m = 5.0;
    sp.fractal_rms_m = 0.01;
    sp.num_rocks = 12;
    const terrain_scene::Terrain t(sp);
    Pair q;
    q.left.height_m = 0.6;
    q.left.pitch_rad = 0.45;
    q.left.y_m = 0.06;
    auto right = q.left;
    right.y_m = -0.06;
    const terrain_scene::Sun sun{2.0, 0.6};
    terrain_scene::RenderOptions ro;
    ro.noise_sigma = 0.004;
    const auto l = terrain_scene::render_camera(t, q.left, sun, ro);
    ro.noise_seed = 8;
    const auto r = terrain_scene::render_camera(t, right, sun, ro);
    q.l8 = terrain_scene::to_u8(l.image);
    q.r8 = terrain_scene::to_u8(r.image);
    q.light = {l.light_slant_rad, l.light_tilt_rad};
    return q;
  }();
  return p;
}

void BM_StereoSGBM(benchmark::State& st) {
  const Pair& p = pair();
  const int bs = 5;
  const int disparities = static_cast<int>(st.range(0));
  auto sgbm = cv::StereoSGBM::create(0, disparities, bs, 8 * bs * bs, 32 * bs * bs, 1, 63, 10, 100, 2,
                                     cv::StereoSGBM::MODE_SGBM);
  cv::Mat disp;
  for (auto _ : st) {
    sgbm->compute(p.l8, p.r8, disp);
    benchmark::DoNotOptimize(disp.data);
  }
}

// SfS on the left image + traversability grid (metric scale, layers) from it: one frame of the
// monocular path (frame grab / vignetting excluded).
void run_sfs_trav(benchmark::State& st, sfs::Method m) {
  const Pair& p = pair();
  const direct_depth::DirectDepth dd(terrain_scene::camera_model_of(p.left));
  sfs::SfsParams sp;
  sp.method = m;
  sfs::ShapeFromShading s(sp);
  sfs::SfsResult r;
  traversability::TraversabilityMapper mapper(dd, traversability::TraversabilityParams{});
  traversability::GridMap g;
  const traversability::ImageLight il{p.light.slant_rad, p.light.tilt_rad};
  s.compute(p.l8, p.light, r);
  mapper.compute_from_sfs(r.height, r.valid, il, g);
  for (auto _ : st) {
    s.compute(p.l8, p.light, r);
    mapper.compute_from_sfs(r.height, r.valid, il, g);
    benchmark::DoNotOptimize(g.data[0].data);
  }
}
// Ground-rectified path (the traversability component's default, sfs_frame: ground): the grey
// frame resampled onto the map's ground grid (default 4 x 4 m at 2 cm: 200 x 200 cells),
// Tsai-Shah there with the sun in the ground frame, metric grid + layers.
void run_ground_trav(benchmark::State& st, sfs::Method m) {
  const Pair& p = pair();
  const direct_depth::DirectDepth dd(terrain_scene::camera_model_of(p.left));
  traversability::TraversabilityParams tp;
  tp.ground_sfs.method = m;
  traversability::TraversabilityMapper mapper(dd, tp);
  traversability::GridMap g;
  const traversability::ImageLight il{p.light.slant_rad, p.light.tilt_rad};
  mapper.compute_from_image(p.l8, il, g);
  for (auto _ : st) {
    mapper.compute_from_image(p.l8, il, g);
    benchmark::DoNotOptimize(g.data[0].data);
  }
}
void BM_GroundTsaiShahTrav(benchmark::State& st) {
  run_ground_trav(st, sfs::Method::kTsaiShah);
}
void BM_GroundPentlandTrav(benchmark::State& st) {
  run_ground_trav(st, sfs::Method::kPentland);
}

void BM_TsaiShahTrav(benchmark::State& st) {
  run_sfs_trav(st, sfs::Method::kTsaiShah);
}
void BM_PentlandTrav(benchmark::State& st) {
  run_sfs_trav(st, sfs::Method::kPentland);
}

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

void BM_TsaiShah(benchmark::State& st) {
  run_sfs(st, sfs::Method::kTsaiShah);
}
void BM_Pentland(benchmark::State& st) {
  run_sfs(st, sfs::Method::kPentland);
}
void BM_BichselPentland(benchmark::State& st) {
  run_sfs(st, sfs::Method::kBichselPentland);
}
void BM_GaussianBlur5x5(benchmark::State& st) {
  const Frame& f = frame(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  cv::Mat dst(f.img.size(), f.img.type());
  for (auto _ : st) {
    cv::GaussianBlur(f.img, dst, cv::Size(5, 5), 0);
    benchmark::DoNotOptimize(dst.data);
  }
}

BENCHMARK(BM_GaussianBlur5x5)->Args({640, 480})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Pentland)
    ->Args({320, 240})
    ->Args({640, 480})
    ->Args({1280, 960})
    ->Args({2048, 1536})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TsaiShah)
    ->Args({320, 240})
    ->Args({640, 480})
    ->Args({1280, 960})
    ->Args({2048, 1536})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BichselPentland)->Args({640, 480})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StereoSGBM)->Arg(64)->Arg(96)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TsaiShahTrav)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PentlandTrav)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GroundTsaiShahTrav)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GroundPentlandTrav)->Unit(benchmark::kMillisecond);

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
    for (const char* n :
         {"BM_GaussianBlur5x5/640/480", "BM_Pentland/640/480", "BM_TsaiShah/640/480", "BM_BichselPentland/640/480"}) {
      const double ms = ms_[n];
      if (ms <= 0) continue;
      std::printf("  %-28s %9.3f ms  %8.1f frames/s  %7.1fx GaussianBlur5x5\n", n, ms, 1000.0 / ms, ms / blur);
    }
    const double ts = ms_["BM_TsaiShah/640/480"], pe = ms_["BM_Pentland/640/480"];
    if (ts > 0 && pe > 0) std::printf("  Tsai-Shah / Pentland = %.1f\n", ts / pe);
    const double p1 = ms_["BM_Pentland/320/240"], p4 = ms_["BM_Pentland/1280/960"];
    if (p1 > 0 && p4 > 0) std::printf("  Pentland 1280x960 / 320x240 = %.1f (16x pixels)\n", p4 / p1);
    std::printf("\nSfS cost vs pixels (ms per Mpx; constant = linear):\n");
    for (const char* m : {"BM_TsaiShah", "BM_Pentland"})
      for (const auto& [w, h] :
           {std::pair{320, 240}, std::pair{640, 480}, std::pair{1280, 960}, std::pair{2048, 1536}}) {
        const double ms = ms_[std::string(m) + "/" + std::to_string(w) + "/" + std::to_string(h)];
        if (ms > 0) std::printf("  %-12s %4dx%-4d %9.2f ms  %7.2f ms/Mpx\n", m, w, h, ms, ms / (w * h * 1e-6));
      }
    const double sg = ms_["BM_StereoSGBM/64"], sg96 = ms_["BM_StereoSGBM/96"];
    std::printf("\n640x480 rover frame, same scene (1 thread): StereoSGBM 64 disparities %.2f ms (96: %.2f ms)\n", sg,
                sg96);
    for (const char* n : {"BM_TsaiShahTrav", "BM_PentlandTrav", "BM_GroundTsaiShahTrav", "BM_GroundPentlandTrav"}) {
      const double ms = ms_[n];
      if (ms > 0 && sg > 0)
        std::printf(
            "  %-22s (SfS + traversability) %8.2f ms  StereoSGBM-64 / this = %.1fx (goal >= 5x; SGBM-96: %.1fx)\n", n,
            ms, sg / ms, sg96 / ms);
    }
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
