// The "sams" component behind the "sfs" component in a deployment under the simulated clock
// (synthetic_terrain camera, DDS off). The rocks published on "terrain/rocks" are matched against
// the rocks of the rendered scene (terrain_scene::render_camera boxes, one-to-one Hungarian
// matching at IoU 0.2), their ranged positions against the rocks' true positions, the
// rock_probability layer against the rocks' cells; heap allocations inside rate-group cycles are
// counted; configuration errors must name the field.
// The replaced global operator new/delete pair malloc/free; GCC cannot see that they match.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <regex>
#include <string>
#include <vector>

#include <execinfo.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "regolith/core/error.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/mocks/backends.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/rate_group.hpp"
#include "regolith/saliency/component.hpp"
#include "regolith/saliency/evaluate.hpp"
#include "regolith/sfs/component.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new

namespace {
using namespace regolith;
namespace ts = regolith::terrain_scene;

void register_once() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  mocks::register_mock_backends(hal::BackendRegistry::instance());
  sfs::register_component();
  saliency::register_component();
}

// Camera and sun of the deployment (synthetic_terrain defaults except the sun; static rover).
constexpr int kW = 320, kH = 240;
constexpr double kHfov = 1.349, kCamH = 0.5, kPitch = 0.35, kSunAz = 2.5, kSunEl = 0.6;
constexpr int kRocks = 40;       // rocks in the scene (synthetic_terrain `rocks`)
constexpr int kMinGtArea = 100;  // px, = the component's min_area_px: smaller rocks are "ignored"

ts::CameraPose camera_pose() {
  ts::CameraPose cam;
  cam.width = kW;
  cam.height = kH;
  cam.fx = cam.fy = 0.5 * kW / std::tan(0.5 * kHfov);
  cam.cx = 0.5 * (kW - 1);
  cam.cy = 0.5 * (kH - 1);
  cam.height_m = kCamH;
  cam.pitch_rad = kPitch;
  return cam;
}

std::string deployment(int seed, const std::string& sams_extra = "") {
  const ts::CameraPose cam = camera_pose();
  // The scene sun (counter-clockwise from +x) as the deployment's compass azimuth (clockwise).
  const double az_deg = -kSunAz * 180.0 / CV_PI, el_deg = kSunEl * 180.0 / CV_PI;
  char buf[4096];
  std::snprintf(buf, sizeof buf, R"(name: saliency_test
dds: {enabled: false}
rover:
  cameras:
    front:
      camera_info: {width: %d, height: %d, k: [%.9f, 0, %.9f, 0, %.9f, %.9f, 0, 0, 1]}
      mount: {z_m: %.3f, pitch_rad: %.3f}
sun: {azimuth_deg: %.9f, elevation_deg: %.9f}
devices:
  cameras:
    front: {backend: synthetic_terrain, seed: %d, rate_hz: 2, frames: 1, speed_m_s: 0, noise_sigma: 0.01,
            rocks: %d}
rate_groups:
  - {name: terrain, rate_hz: 2, members: [sfs, sams]}
components:
  sfs: {type: sfs, camera: front, method: tsai_shah}
  sams:
    type: sams
    camera: front
    delta_max: 3
    map_level: 2
    threshold_scale: 2.0
%s)",
                kW, kH, cam.fx, cam.cx, cam.fy, cam.cy, kCamH, kPitch, az_deg, el_deg, seed, kRocks,
                sams_extra.c_str());
  return buf;
}

struct Truth {
  ts::SceneParams scene;
  std::vector<ts::Rock> rocks;
  ts::CameraImage image;
  saliency::FrameTruth frame;  // objects = rock boxes; small / cut rocks "ignored"
  std::vector<int> rock_of;    // frame.objects[k] -> rock index
};

Truth render_truth(int seed) {
  Truth t;
  t.scene.seed = static_cast<std::uint64_t>(seed);
  t.scene.num_rocks = kRocks;
  const ts::Terrain terrain(t.scene);
  t.rocks = terrain.rocks();
  ts::RenderOptions ro;
  ro.noise_sigma = 0.01;
  ro.noise_seed = t.scene.seed * 1000003ULL;
  t.image = ts::render_camera(terrain, camera_pose(), ts::Sun{kSunAz, kSunEl}, ro);
  t.frame.labels = cv::Mat(kH, kW, CV_32S, cv::Scalar(0));
  for (const ts::PixelBox& b : t.image.rock_boxes) {
    saliency::GtObject o;
    o.box = b.box;
    o.area = b.box.area();
    o.ignored = !b.fully_inside || b.box.area() < kMinGtArea;
    t.frame.objects.push_back(o);
    t.rock_of.push_back(b.rock_index);
  }
  return t;
}

struct RunResult {
  saliency::RockFrame rocks;
  saliency::RockProbabilityFrame grid;
  bool have_grid = false;
  std::uint64_t cycle_allocs = 0;
  std::uint64_t frames_in_window = 0;
  std::uint64_t errors = 0;
};

RunResult run_yaml(const std::string& yaml) {
  register_once();
  auto app = runtime::Application::load(Params::load_string(yaml, "<test>"), {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(2 * kNsPerSec, stop);  // warm-up: the first frames
  auto& ch = app->context().channel<saliency::RockFrame>(saliency::kRocksChannel);
  std::uint64_t seq0 = 0;
  if (auto l = ch.acquire()) seq0 = l->sequence;
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  if (const char* t = std::getenv("REGOLITH_TRACE_ALLOC")) regolith::testing::trace_cycle_allocations(std::atoi(t));
  app->run(4 * kNsPerSec, stop);
  regolith::testing::trace_cycle_allocations(0);
  RunResult r;
  r.cycle_allocs = regolith::testing::cycle_allocations() - a0;
  auto lease = ch.acquire();
  EXPECT_TRUE(lease);
  if (lease) {
    r.rocks = *lease;
    r.frames_in_window = lease->sequence - seq0;
  }
  auto& gch = app->context().channel<saliency::RockProbabilityFrame>(saliency::kRockProbabilityChannel);
  if (auto g = gch.acquire()) {
    r.grid = *g;
    r.grid.probability = g->probability.clone();
    r.have_grid = true;
  }
  for (const auto* c : app->view().components) r.errors += c->errors();
  app->stop();
  return r;
}

RunResult run(int seed, const std::string& extra = "") {
  return run_yaml(deployment(seed, extra));
}

// Valid rocks whose box centre lies inside a detection (coarse maps give boxes larger than the
// rock, which IoU punishes).
int centre_hits(const Truth& truth, const std::vector<cv::Rect>& boxes) {
  int hits = 0;
  for (const saliency::GtObject& o : truth.frame.objects) {
    if (o.ignored) continue;
    const cv::Point c(o.box.x + o.box.width / 2, o.box.y + o.box.height / 2);
    hits += std::any_of(boxes.begin(), boxes.end(), [&](const cv::Rect& b) { return b.contains(c); }) ? 1 : 0;
  }
  return hits;
}

// rock_probability over the cells under the valid rocks and over all visible (finite) cells.
struct OnRocks {
  double on = 0, all = 0;  // sums of the probability
  int n_on = 0, n_all = 0;
  int out_of_range = 0;  // finite cells outside [0, 1]
};
OnRocks probability_on_rocks(const RunResult& r, const Truth& truth) {
  OnRocks o;
  const cv::Mat& P = r.grid.probability;
  for (int i = 0; i < P.rows; ++i)
    for (int j = 0; j < P.cols; ++j) {
      const float v = P.at<float>(i, j);
      if (!std::isfinite(v)) continue;
      o.out_of_range += v < 0.f || v > 1.f ? 1 : 0;
      o.all += v;
      ++o.n_all;
      const double x = r.grid.center_x_m + 0.5 * r.grid.length_x_m - (i + 0.5) * r.grid.resolution_m;
      const double y = r.grid.center_y_m + 0.5 * r.grid.length_y_m - (j + 0.5) * r.grid.resolution_m;
      for (std::size_t k = 0; k < truth.frame.objects.size(); ++k) {
        if (truth.frame.objects[k].ignored) continue;
        const ts::Rock& rock = truth.rocks[static_cast<std::size_t>(truth.rock_of[k])];
        if (std::hypot((x - rock.x_m) / rock.radius_x_m, (y - rock.y_m) / rock.radius_y_m) < 1.0) {
          o.on += v;
          ++o.n_on;
          break;
        }
      }
    }
  return o;
}

// Pooled over three scenes (seeds 7, 8, 9: held out; the component settings of the deployment,
// map_level 2 and threshold_scale 2.0, were chosen on seeds 1-6). Measured numbers are in the
// README ("Component"); the thresholds below leave a margin under them.
TEST(SceneRocks, DetectedAndRangedLikeTheTruth) {
  int n_gt = 0, n_det = 0, matched = 0, ranged = 0, hazard_ok = 0, centre_hits = 0;
  double sum_range_rel = 0.0, max_range_rel = 0.0, max_lat = 0.0, sum_width_rel = 0.0;
  double prob_on = 0.0, prob_all = 0.0;
  std::uint64_t allocs = 0, frames = 0;
  for (const int seed : {7, 8, 9}) {
    const Truth truth = render_truth(seed);
    const RunResult r = run(seed);
    EXPECT_EQ(r.errors, 0u) << seed;
    EXPECT_EQ(r.rocks.image_width, kW);
    EXPECT_EQ(r.rocks.image_height, kH);
    EXPECT_GT(r.rocks.stamp, 0);
    EXPECT_EQ(r.rocks.stamp % (kNsPerSec / 2), 0);  // a capture time of the 2 Hz camera
    allocs += r.cycle_allocs;
    frames += r.frames_in_window;

    std::vector<cv::Rect> boxes;
    for (std::uint32_t i = 0; i < r.rocks.count; ++i) boxes.push_back(r.rocks.rocks[i].detection.box);
    const saliency::FrameMatch m = saliency::match_frame(boxes, truth.frame, 0.2);
    n_gt += m.n_gt;
    n_det += m.n_det;
    matched += m.matched;

    centre_hits += ::centre_hits(truth, boxes);

    // Ranging of each valid rock against its best-overlapping detection (IoU >= 0.2).
    for (std::size_t k = 0; k < truth.frame.objects.size(); ++k) {
      const saliency::GtObject& o = truth.frame.objects[k];
      if (o.ignored) continue;
      int best = -1;
      double best_iou = 0.2;
      for (std::uint32_t i = 0; i < r.rocks.count; ++i) {
        const double iou = saliency::iou(o.box, r.rocks.rocks[i].detection.box);
        if (iou >= best_iou) {
          best_iou = iou;
          best = static_cast<int>(i);
        }
      }
      if (best < 0) continue;
      const saliency::RangedRock& rr = r.rocks.rocks[static_cast<std::size_t>(best)];
      const ts::Rock& rock = truth.rocks[static_cast<std::size_t>(truth.rock_of[k])];
      ASSERT_TRUE(rr.ranged);
      // The box's base is the near edge of the rock's footprint.
      const double range_truth = rock.x_m - rock.radius_x_m;
      const double rel = std::abs(rr.range_m - range_truth) / range_truth;
      const double lat = std::abs(rr.lateral_m - rock.y_m);
      const double wrel = std::abs(rr.width_m - 2 * rock.radius_y_m) / (2 * rock.radius_y_m);
      const bool hazard_truth = 2 * rock.radius_y_m > 0.15 || rock.height_m > 0.15;
      std::printf(
          "seed %d rock %d: range %.3f (truth %.3f) lateral %.3f (truth %.3f) width %.3f (truth %.3f) "
          "height %.3f (truth %.3f) hazard %d (truth %d) IoU %.2f\n",
          seed, truth.rock_of[k], rr.range_m, range_truth, rr.lateral_m, rock.y_m, rr.width_m, 2 * rock.radius_y_m,
          rr.height_m, rock.height_m, rr.hazard ? 1 : 0, hazard_truth ? 1 : 0, best_iou);
      max_range_rel = std::max(max_range_rel, rel);
      max_lat = std::max(max_lat, lat);
      sum_range_rel += rel;
      sum_width_rel += wrel;
      hazard_ok += rr.hazard == hazard_truth ? 1 : 0;
      ++ranged;
    }

    // rock_probability: mean over the cells under the valid rocks vs over all visible cells.
    ASSERT_TRUE(r.have_grid);
    const OnRocks g = probability_on_rocks(r, truth);
    ASSERT_EQ(g.out_of_range, 0) << "rock_probability outside [0, 1]";
    ASSERT_GT(g.n_all, 1000);
    std::printf("seed %d: GT %d det %d matched %d; rock_probability on rocks %.3f (%d cells), visible %.3f (%d)\n",
                seed, m.n_gt, m.n_det, m.matched, g.n_on ? g.on / g.n_on : 0.0, g.n_on, g.all / g.n_all, g.n_all);
    if (g.n_on > 0) {
      prob_on += g.on / g.n_on;
      prob_all += g.all / g.n_all;
    }
  }
  const double recall = static_cast<double>(matched) / std::max(1, n_gt);
  const double precision = static_cast<double>(matched) / std::max(1, n_det);
  std::printf(
      "pooled: %d valid GT rocks, %d detections, matched %d: recall@0.2 %.2f precision@0.2 %.2f, GT centres inside a "
      "box %d; "
      "ranged %d: mean |range err| %.1f %%, max %.1f %%, max |lateral err| %.3f m, mean |width err| %.0f %%, "
      "hazard flag agrees %d/%d; heap allocations inside cycles: %llu over %llu frames\n",
      n_gt, n_det, matched, recall, precision, centre_hits, ranged, 100 * sum_range_rel / std::max(1, ranged),
      100 * max_range_rel, max_lat, 100 * sum_width_rel / std::max(1, ranged), hazard_ok, ranged,
      static_cast<unsigned long long>(allocs), static_cast<unsigned long long>(frames));
  // Measured (seeds 7-9): 21 GT, 12 detections, 3 matched (recall 0.14, precision 0.25), 11 GT
  // centres inside a box; ranged rocks: mean range error 17.5 %, max 28.9 %, lateral <= 0.30 m;
  // rock_probability on rocks ~2x the visible mean.
  ASSERT_GT(n_gt, 20);
  EXPECT_GE(matched, 2);
  EXPECT_GE(precision, 0.15);
  EXPECT_GE(centre_hits, 8);
  ASSERT_GE(ranged, 2);
  EXPECT_LT(sum_range_rel / ranged, 0.25);
  EXPECT_LT(max_range_rel, 0.40);
  EXPECT_LT(max_lat, 0.40);
  EXPECT_EQ(hazard_ok, ranged);
  EXPECT_GT(prob_on, 1.5 * prob_all);
  // Real-time rule: sfs (tsai_shah) + sams allocate nothing inside rate-group cycles once warmed
  // up (before the own filter / morphology / labelling / resize code: ~743 per frame).
  EXPECT_EQ(frames, 24u);  // 8 frames of the 2 Hz camera per 4 s window, 3 scenes
  EXPECT_EQ(allocs, 0u) << "heap allocations inside cycles over " << frames << " frames";
}

std::string config_error(const std::string& yaml) {
  register_once();
  try {
    runtime::Application::load(Params::load_string(yaml, "<test>"), {.sim_time = true, .enable_dds = false});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SceneRocks, TrainedMethodRunsInTheComponentWithoutAllocating) {
  // method trained (the shipped Mars model) on the rendered scenes: the same outputs as every
  // method, found rocks, and no heap allocation inside the cycles once running.
  int n_gt = 0, centre_hits = 0, detections = 0, matched = 0;
  std::uint64_t allocs = 0, frames = 0;
  double prob_on = 0.0, prob_all = 0.0;
  for (const int seed : {7, 8, 9}) {
    const Truth truth = render_truth(seed);
    const RunResult r = run(seed, "    method: trained\n");
    EXPECT_EQ(r.errors, 0u) << seed;
    EXPECT_EQ(r.rocks.image_width, kW);
    allocs += r.cycle_allocs;
    frames += r.frames_in_window;
    detections += static_cast<int>(r.rocks.count);
    std::vector<cv::Rect> boxes;
    for (std::uint32_t i = 0; i < r.rocks.count; ++i) boxes.push_back(r.rocks.rocks[i].detection.box);
    matched += saliency::match_frame(boxes, truth.frame, 0.2).matched;
    for (std::uint32_t i = 1; i < r.rocks.count; ++i)
      EXPECT_LE(r.rocks.rocks[i].detection.score, r.rocks.rocks[i - 1].detection.score);  // best first
    for (const saliency::GtObject& o : truth.frame.objects) {
      if (o.ignored) continue;
      ++n_gt;
      const cv::Point c(o.box.x + o.box.width / 2, o.box.y + o.box.height / 2);
      for (std::uint32_t i = 0; i < r.rocks.count; ++i)
        if (r.rocks.rocks[i].detection.box.contains(c)) {
          ++centre_hits;
          break;
        }
    }
    ASSERT_TRUE(r.have_grid);
    const cv::Mat& p = r.grid.probability;
    for (int i = 0; i < p.rows; ++i)
      for (int j = 0; j < p.cols; ++j) {
        const float v = p.at<float>(i, j);
        if (std::isnan(v)) continue;
        EXPECT_GE(v, 0.0f);
        EXPECT_LE(v, 1.0f);
        prob_all += v;
        prob_on += v > 0.0f ? 1.0 : 0.0;
      }
  }
  EXPECT_GT(frames, 0u);
  EXPECT_EQ(allocs, 0u) << "heap allocations inside the cycles (REGOLITH_TRACE_ALLOC=N prints their stacks)";
  std::printf(
      "trained in the component: %d detections, %d matched (IoU 0.2), %d of %d rocks' centres inside a box, "
      "%.0f grid cells > 0\n",
      detections, matched, centre_hits, n_gt, prob_on);
  EXPECT_GT(detections, 0);
  EXPECT_GE(matched, 1);
  EXPECT_GE(centre_hits, n_gt / 4);
  EXPECT_GT(prob_all, 0.0);
}

// The default pyramid (2^(4+4) = 256 px a side) on the 320x240 camera: its frames are processed
// enlarged to 342x256 and the map brought back, as `regolith rocks` does with small images (until
// 2026-12-05 the component refused such a camera at configure). Same scenes and checks as above.
TEST(SceneRocks, TheDefaultPyramidOnASmallCameraRunsOnTheFrameEnlarged) {
  int n_gt = 0, matched = 0, centre_hits = 0, detections = 0;
  double prob_on = 0.0, prob_all = 0.0;
  std::uint64_t allocs = 0, frames = 0;
  for (const int seed : {7, 8, 9}) {
    const Truth truth = render_truth(seed);
    const RunResult r = run_yaml(std::regex_replace(deployment(seed), std::regex("delta_max: 3"), "delta_max: 4"));
    EXPECT_EQ(r.errors, 0u) << seed;
    EXPECT_EQ(r.rocks.image_width, kW);
    EXPECT_EQ(r.rocks.image_height, kH);
    allocs += r.cycle_allocs;
    frames += r.frames_in_window;
    std::vector<cv::Rect> boxes;
    for (std::uint32_t i = 0; i < r.rocks.count; ++i) {
      const cv::Rect& b = r.rocks.rocks[i].detection.box;
      EXPECT_TRUE((b & cv::Rect(0, 0, kW, kH)) == b) << "a box outside the camera's image";
      boxes.push_back(b);
    }
    const saliency::FrameMatch m = saliency::match_frame(boxes, truth.frame, 0.2);
    n_gt += m.n_gt;
    matched += m.matched;
    detections += m.n_det;
    centre_hits += ::centre_hits(truth, boxes);
    ASSERT_TRUE(r.have_grid);
    const OnRocks g = probability_on_rocks(r, truth);
    EXPECT_EQ(g.out_of_range, 0) << "rock_probability outside [0, 1]";
    if (g.n_on > 0) {
      prob_on += g.on / g.n_on;
      prob_all += g.all / std::max(1, g.n_all);
    }
  }
  std::printf(
      "default pyramid on 320x240, enlarged: %d GT, %d detections, %d matched (IoU 0.2), %d centres inside a box; "
      "rock_probability on rocks %.3f vs visible %.3f; %llu allocations over %llu frames\n",
      n_gt, detections, matched, centre_hits, prob_on, prob_all, static_cast<unsigned long long>(allocs),
      static_cast<unsigned long long>(frames));
  EXPECT_EQ(frames, 24u);
  EXPECT_EQ(allocs, 0u) << "heap allocations inside cycles (REGOLITH_TRACE_ALLOC=N prints their stacks)";
  // Measured: 14 detections, 5 matched, 15 centres inside a box, on-rock probability 1.7x the visible mean.
  EXPECT_GE(matched, 3);
  EXPECT_GE(centre_hits, 10);
  EXPECT_GT(prob_on, 1.4 * prob_all);
}

TEST(SamsConfig, TrainedModelErrorsNameTheField) {
  const std::string e = config_error(deployment(7, "    method: trained\n    model: /nonexistent/rocks.yml\n"));
  EXPECT_NE(e.find("model"), std::string::npos) << e;
  EXPECT_NE(e.find("/nonexistent/rocks.yml"), std::string::npos) << e;
}

TEST(SamsConfig, ErrorsNameTheField) {
  const std::string y = deployment(1);
  auto with = [&](const std::string& from, const std::string& to) {
    const std::string out = std::regex_replace(y, std::regex(from), to);
    EXPECT_NE(out, y) << from;
    return out;
  };
  std::string e = config_error(with("    delta_max: 3\n", "    delta_max: 3\n    method: gbvs\n"));
  EXPECT_NE(e.find("method"), std::string::npos) << e;
  EXPECT_NE(e.find("gbvs"), std::string::npos) << e;
  // 2^(4+8) = 4096 px a side: 320x240 would be enlarged to 5462x4096, past the 4 Mpx the component allows
  e = config_error(with("    delta_max: 3\n", "    delta_max: 8\n"));
  EXPECT_NE(e.find("components.sams.delta_max: 320x240 px is too small for the 4096 px a side of the pyramid: "
                   "enlarged to that it would be 5462x4096 px: lower centre_max or delta_max"),
            std::string::npos)
      << e;
  e = config_error(with("    delta_max: 3\n", "    delta_max: 3\n    hazard_size_m: -0.1\n"));
  EXPECT_NE(e.find("hazard_size_m"), std::string::npos) << e;
  e = config_error(with("    delta_max: 3\n", "    delta_max: 3\n    w_structur: 0.4\n"));
  EXPECT_NE(e.find("w_structur"), std::string::npos) << e;
  EXPECT_NE(e.find("w_structure"), std::string::npos) << e;  // did you mean
  e = config_error(with("    camera: front\n", ""));         // which camera's DTM: required
  EXPECT_NE(e.find("components.sams.camera"), std::string::npos) << e;
  e = config_error(with("    camera: front\n", "    camera: front\n    camera_model: {fx: 200}\n"));  // old format
  EXPECT_NE(e.find("components.sams.camera_model: no longer read here: the camera is described once, in rover.cameras"),
            std::string::npos)
      << e;
  e = config_error(
      with("    delta_max: 3\n", "    delta_max: 3\n    w_intensity: 0\n    w_orientation: 0\n    w_structure: 0\n"));
  EXPECT_NE(e.find("w_structure"), std::string::npos) << e;
  e = config_error(with("    delta_max: 3\n", "    delta_max: 3\n    max_detections: 65\n"));
  EXPECT_NE(e.find("max_detections"), std::string::npos) << e;
}

TEST(SamsConfig, DtmOfAnotherSizeIsCountedNotCrashed) {
  register_once();
  // sams told to read another camera's geometry than the DTM's producer (sfs on `front`): every
  // DTM frame then has the wrong size for it.
  std::string y = std::regex_replace(
      deployment(1), std::regex("sun: \\{"),
      "    other:\n      camera_info: {width: 640, height: 480, k: [400, 0, 319.5, 0, 400, 239.5, 0, 0, 1]}\n"
      "      mount: {z_m: 0.5, pitch_rad: 0.35}\nsun: {");
  y = std::regex_replace(y, std::regex("    rocks: 40\\}\n"),
                         "    rocks: 40}\n    other: {backend: synthetic_terrain, frames: 1, rate_hz: 2}\n");
  y = std::regex_replace(y, std::regex("    type: sams\n    camera: front"), "    type: sams\n    camera: other");
  ASSERT_NE(y.find("camera: other"), std::string::npos) << y;
  ASSERT_NE(y.find("other: {backend"), std::string::npos) << y;
  auto app = runtime::Application::load(Params::load_string(y, "<test>"), {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(2 * kNsPerSec, stop);
  app->stop();
  bool seen = false;
  for (const auto* c : app->view().components)
    if (c->name() == "sams") {
      seen = true;
      EXPECT_GT(c->errors(), 0u);
      EXPECT_NE(std::string(c->status_message()).find("DTM size"), std::string::npos) << c->status_message();
    }
  EXPECT_TRUE(seen);
  EXPECT_FALSE(app->context().channel<saliency::RockFrame>(saliency::kRocksChannel).has_value());
}

}  // namespace
