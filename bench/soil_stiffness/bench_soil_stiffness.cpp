// Whole retrospective-soil-stiffness estimate on a 640x480 synthetic rear-camera frame versus its
// peer, the SfS step alone on the same rectified region, and the full-frame SfS. Prints the ratio.
#include <cstdio>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include "regolith/sfs/sfs.hpp"
#include "regolith/soil_stiffness/track_analysis.hpp"
#include "regolith/track_scene/camera_model.hpp"
#include "regolith/track_scene/track_scene.hpp"

using namespace regolith;

namespace {
struct Fixture {
  track_scene::TrackSceneParams p;
  track_scene::TrackScene scene;
  soil::CameraModel cam;
  soil::RoverConfig rover;
  Fixture() {
    p.tracks = {{0.4, 60.0}, {-0.4, 60.0}};
    scene = track_scene::generate_track_scene(p);
    cam = track_scene::camera_model_of(p.camera);
    rover.wheel_width_m = p.wheel_width_m;
    rover.wheel_diameter_m = p.wheel_diameter_m;
  }
};
Fixture& fx() {
  static Fixture f;
  return f;
}
double g_full_ns = 0, g_photo_ns = 0, g_sfs_ns = 0;

// The whole estimate, profiles from `ap.profile_source`.
void time_estimate(benchmark::State& st, const soil::TrackAnalysisParams& ap) {
  auto& f = fx();
  soil::SoilStiffnessEstimator est(f.cam, f.rover, ap);
  soil::SoilEstimate out;
  for (auto _ : st) {
    est.estimate(f.scene.image, {f.p.sun.azimuth_rad, f.p.sun.elevation_rad}, out);
    benchmark::DoNotOptimize(out.k_fixed);
  }
  if (!out.ok) st.SkipWithError(out.reason.c_str());
}

void BM_SoilEstimate(benchmark::State& st) {
  time_estimate(st, {});
}  // rut-template profiles
BENCHMARK(BM_SoilEstimate)->Unit(benchmark::kMillisecond);

// The same with the 1-D photoclinometry profiles (what a deployment on sunlit ruts without cast
// shadows may choose: components/soil_stiffness/example_rover.yaml).
void BM_SoilEstimatePhotoclinometry(benchmark::State& st) {
  soil::TrackAnalysisParams ap;
  ap.profile_source = soil::ProfileSource::kPhotoclinometry;
  time_estimate(st, ap);
}
BENCHMARK(BM_SoilEstimatePhotoclinometry)->Unit(benchmark::kMillisecond);

void BM_SfsOnRegion(benchmark::State& st) {
  auto& f = fx();
  soil::SoilStiffnessEstimator est(f.cam, f.rover, {});
  soil::SoilEstimate out;
  est.estimate(f.scene.image, {f.p.sun.azimuth_rad, f.p.sun.elevation_rad}, out);
  const cv::Mat e = est.rectified().clone();
  sfs::SfsParams sp;
  sp.method = sfs::Method::kPentland;
  sp.normalise_albedo = false;
  sfs::ShapeFromShading solver(sp);
  sfs::SfsResult r;
  sfs::LightDirection l{0.7854, 3.14159};
  for (auto _ : st) {
    solver.compute(e, l, r);
    benchmark::DoNotOptimize(r.height.data);
  }
}
BENCHMARK(BM_SfsOnRegion)->Unit(benchmark::kMillisecond);

void BM_TsaiShahFullFrame(benchmark::State& st) {
  auto& f = fx();
  sfs::SfsParams sp;
  sp.iterations = 50;
  sp.tolerance = 0.0;
  sfs::ShapeFromShading solver(sp);
  sfs::SfsResult r;
  for (auto _ : st) {
    solver.compute(f.scene.image, sfs::LightDirection{0.7854, 3.14159}, r);
    benchmark::DoNotOptimize(r.height.data);
  }
}
BENCHMARK(BM_TsaiShahFullFrame)->Unit(benchmark::kMillisecond);

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs) {
      const double ns = r.GetAdjustedRealTime();
      if (r.benchmark_name() == "BM_SoilEstimate") g_full_ns = ns;
      if (r.benchmark_name() == "BM_SoilEstimatePhotoclinometry") g_photo_ns = ns;
      if (r.benchmark_name() == "BM_SfsOnRegion") g_sfs_ns = ns;
    }
    ConsoleReporter::ReportRuns(runs);
  }
};
}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core
  benchmark::Initialize(&argc, argv);
  RatioReporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  if (g_full_ns > 0 && g_sfs_ns > 0)
    std::printf("whole soil estimate / SfS(Pentland) of the same region = %.2f (rut-template profiles)\n",
                g_full_ns / g_sfs_ns);
  if (g_photo_ns > 0 && g_sfs_ns > 0)
    std::printf("whole soil estimate / SfS(Pentland) of the same region = %.2f (photoclinometry profiles)\n",
                g_photo_ns / g_sfs_ns);
  benchmark::Shutdown();
  return 0;
}
