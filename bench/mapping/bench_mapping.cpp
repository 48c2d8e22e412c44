// Drive-long map per-frame cost (issues 13 and 14 "Speed"): ground visual odometry + wheel fusion,
// each height cue alone (plane sweep, rectified parallax, rock sightings) and the whole
// DriveMapper (VO + cues + world-map fusion), on rendered 320x240 and 640x480 navigation frames of
// a driving rover, against the textbook peer measured in the same run: OpenCV 5-point VO
// (goodFeaturesToTrack 300 + pyramidal LK + findEssentialMat RANSAC + recoverPose) on the same
// frame pairs. One thread (cv::setNumThreads(1)); prints the per-frame split and the ratios.
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "regolith/mapping/drive_mapper.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

namespace {
using namespace regolith;
using namespace regolith::mapping;

struct Drive {
  direct_depth::CameraModel model;
  std::vector<cv::Mat> frames;
  std::vector<Pose2> odometry;
  cv::Vec3d sun;
};

const Drive& drive(int w) {
  static std::map<int, Drive> cache;
  if (auto it = cache.find(w); it != cache.end()) return it->second;
  terrain_scene::SceneParams sp;
  sp.seed = 9;
  sp.resolution_m = 0.01;
  sp.fractal_rms_m = 0.01;
  sp.fractal_beta = 2.9;
  sp.x_min_m = -1;
  sp.x_max_m = 9;
  sp.y_min_m = -4;
  sp.y_max_m = 4;
  sp.num_rocks = 25;
  const terrain_scene::Terrain t(sp);
  const terrain_scene::Sun sun{2.3, 0.8};
  const double s = w / 320.0;
  terrain_scene::CameraPose cam;
  cam.fx = cam.fy = 220 * s;
  cam.cx = (w - 1) / 2.0;
  cam.cy = (w * 3 / 4 - 1) / 2.0;
  cam.width = w;
  cam.height = w * 3 / 4;
  cam.height_m = 0.67;
  cam.pitch_rad = 0.6;
  Drive d;
  d.model.fx = d.model.fy = cam.fx;
  d.model.cx = cam.cx;
  d.model.cy = cam.cy;
  d.model.width = cam.width;
  d.model.height = cam.height;
  d.model.mount_height_m = 0.67;
  d.model.pitch_rad = 0.6;
  d.sun = sun.vector();
  Pose2 p{};
  for (int k = 0; k < 16; ++k) {
    if (k) p = compose(p, Pose2{0.06, 0.0, 0.005});
    cam.x_m = p.x;
    cam.y_m = p.y;
    cam.yaw_rad = p.yaw;
    terrain_scene::RenderOptions ro;
    ro.noise_sigma = 0.004;
    d.frames.push_back(terrain_scene::to_u8(terrain_scene::render_camera(t, cam, sun, ro).image));
    d.odometry.push_back(compose(Pose2{}, Pose2{p.x * 1.01, p.y, p.yaw * 1.02}));
  }
  return cache.emplace(w, std::move(d)).first->second;
}

// One frame per iteration, in driving order; a new mapper (untimed) when the drive wraps.
void run_mapper(benchmark::State& st, bool terrain) {
  const Drive& d = drive(static_cast<int>(st.range(0)));
  DriveMapperParams p;
  p.fuse_terrain = terrain;
  p.map.length_x_m = p.map.length_y_m = 12;
  std::unique_ptr<DriveMapper> m;
  std::size_t k = 0;
  long vo_ok = 0;
  for (auto _ : st) {
    if (!m || k == d.frames.size()) {
      st.PauseTiming();
      if (m) vo_ok += m->counters().vo_ok;
      m = std::make_unique<DriveMapper>(d.model, CameraMount{}, d.sun, p, cv::Point2d{2, 0});
      k = 0;
      st.ResumeTiming();
    }
    benchmark::DoNotOptimize(m->add_frame(d.frames[k], d.odometry[k]));
    ++k;
  }
  st.counters["vo_ok_passes"] = static_cast<double>(vo_ok + m->counters().vo_ok);
}
void BM_GroundVoFusion(benchmark::State& st) {
  run_mapper(st, false);
}
void BM_DriveMapper(benchmark::State& st) {
  run_mapper(st, true);
}

// One cue on one frame pair 0.42 m apart (frames 0 and 7), with the VO's measurement of it.
struct CuePair {
  std::unique_ptr<direct_depth::DirectDepth> depth;
  VoMeasurement m;
};
const CuePair& cue_pair(int w) {
  static std::map<int, CuePair> cache;
  if (auto it = cache.find(w); it != cache.end()) return it->second;
  const Drive& d = drive(w);
  CuePair c;
  c.depth = std::make_unique<direct_depth::DirectDepth>(d.model);
  GroundVisualOdometry vo(*c.depth, GroundVoParams{});
  vo.track(d.frames[0], {});
  vo.promote_last();
  c.m = vo.track(d.frames[7], between(d.odometry[0], d.odometry[7]));
  return cache.emplace(w, std::move(c)).first->second;
}
void BM_PlaneSweep(benchmark::State& st) {
  const Drive& d = drive(static_cast<int>(st.range(0)));
  const CuePair& c = cue_pair(static_cast<int>(st.range(0)));
  PlaneSweep sweep(*c.depth, PlaneSweepParams{});
  sweep.set_frame(d.frames[0]);
  sweep.promote();
  for (auto _ : st) {
    sweep.set_frame(d.frames[7]);
    benchmark::DoNotOptimize(sweep.compute(c.m.pose, c.m.gain, c.m.bias_dn, {c.m.key_pitch_rad, c.m.key_roll_rad},
                                           {c.m.pitch_rad, c.m.roll_rad}));
  }
  st.counters["hypotheses_M"] = static_cast<double>(sweep.samples()) * 1e-6;
}
void BM_GroundParallax(benchmark::State& st) {
  const Drive& d = drive(static_cast<int>(st.range(0)));
  const CuePair& c = cue_pair(static_cast<int>(st.range(0)));
  GroundParallax plx(*c.depth, ParallaxParams{});
  plx.set_frame(d.frames[0]);
  plx.promote();
  for (auto _ : st) {
    plx.set_frame(d.frames[7]);
    benchmark::DoNotOptimize(plx.compute(c.m.pose, c.m.gain, c.m.bias_dn, {c.m.key_pitch_rad, c.m.key_roll_rad},
                                         {c.m.pitch_rad, c.m.roll_rad}));
  }
}
void BM_RockSightings(benchmark::State& st) {
  const Drive& d = drive(static_cast<int>(st.range(0)));
  const CuePair& c = cue_pair(static_cast<int>(st.range(0)));
  RockSightings sightings(*c.depth, RockSightingParams{});
  int n = 0;
  for (auto _ : st) benchmark::DoNotOptimize(n = sightings.compute(d.frames[7], {c.m.pitch_rad, c.m.roll_rad}));
  st.counters["sightings"] = n;
}

// The peer: sparse 5-point VO between consecutive frames.
void BM_RecoverPose5pt(benchmark::State& st) {
  const Drive& d = drive(static_cast<int>(st.range(0)));
  const cv::Matx33d K(d.model.fx, 0, d.model.cx, 0, d.model.fy, d.model.cy, 0, 0, 1);
  std::size_t k = 1;
  int inliers = 0;
  for (auto _ : st) {
    const cv::Mat& a = d.frames[k - 1];
    const cv::Mat& b = d.frames[k];
    std::vector<cv::Point2f> pa, pb;
    cv::goodFeaturesToTrack(a, pa, 300, 0.01, 7);
    std::vector<uchar> ok;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(a, b, pa, pb, ok, err);
    std::vector<cv::Point2f> ga, gb;
    for (std::size_t q = 0; q < ok.size(); ++q)
      if (ok[q]) ga.push_back(pa[q]), gb.push_back(pb[q]);
    if (ga.size() >= 5) {
      cv::Mat mask;
      const cv::Mat e = cv::findEssentialMat(ga, gb, K, cv::RANSAC, 0.999, 1.0, mask);
      cv::Mat r, t;
      if (e.rows == 3) inliers = cv::recoverPose(e, ga, gb, K, r, t, mask);
    }
    benchmark::DoNotOptimize(inliers);
    k = k + 1 == d.frames.size() ? 1 : k + 1;
  }
  st.counters["inliers"] = inliers;
}

BENCHMARK(BM_RecoverPose5pt)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GroundVoFusion)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlaneSweep)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GroundParallax)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RockSightings)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DriveMapper)->Arg(320)->Arg(640)->Unit(benchmark::kMillisecond);

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const auto& r : runs)
      if (r.run_type == Run::RT_Iteration && !r.error_occurred) ms_[r.benchmark_name()] = r.GetAdjustedRealTime();
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::printf("\nPer frame, 1 thread, same run (goal: VO + fusion <= 10 ms at 320x240, <= 25 ms at 640x480):\n");
    for (int w : {320, 640}) {
      const std::string s = "/" + std::to_string(w);
      const double peer = ms_["BM_RecoverPose5pt" + s], vo = ms_["BM_GroundVoFusion" + s],
                   all = ms_["BM_DriveMapper" + s];
      std::printf(
          "  %dx%d: ground VO + fusion %6.2f ms (%.2fx the 5-point peer's %.2f ms); with every cue + map %6.2f ms\n", w,
          w * 3 / 4, vo, peer > 0 ? vo / peer : 0.0, peer, all);
      for (const char* n : {"BM_PlaneSweep", "BM_GroundParallax", "BM_RockSightings"})
        if (const double ms = ms_[n + s]; ms > 0)
          std::printf("      %-18s %6.2f ms (%.2fx peer)\n", n + 3, ms, peer > 0 ? ms / peer : 0.0);
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
