#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "regolith/common/grid.hpp"
#include "regolith/core/error.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/sfs/sfs.hpp"
#include "regolith/terrain_scene/camera_model.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"
#include "regolith/traversability/traversability.hpp"

namespace {
using namespace regolith;
using traversability::GridMap;
using traversability::ImageLight;
using traversability::sun_elevation;
using traversability::TraversabilityMapper;
using traversability::TraversabilityParams;

direct_depth::CameraModel cam() {
  direct_depth::CameraModel m;
  m.fx = m.fy = 300;
  m.cx = 159.5;
  m.cy = 119.5;
  m.width = 320;
  m.height = 240;
  m.mount_height_m = 0.6;
  m.pitch_rad = 0.45;
  return m;
}

TraversabilityParams params() {
  TraversabilityParams p;
  p.resolution_m = 0.05;
  p.length_x_m = 4.0;
  p.length_y_m = 3.0;
  p.center_x_m = 1.5;  // map spans x = -0.5 .. 3.5: the near part is outside the camera view
  return p;
}

TEST(Traversability, FlatPlaneIsFullyTraversableAndNaNOutsideFootprint) {
  const direct_depth::DirectDepth dd(cam());
  TraversabilityMapper mapper(dd, params());
  const cv::Mat zero(240, 320, CV_32F, cv::Scalar(0));
  GridMap g;
  mapper.compute_from_metric(zero, cv::Mat(), g);
  ASSERT_EQ(g.layers, traversability::layer_names());
  EXPECT_EQ(g.size_x(), 80);
  EXPECT_EQ(g.size_y(), 60);
  const cv::Mat& t = g.layer("traversability");
  const cv::Mat& conf = g.layer("confidence");
  int known = 0, unknown = 0;
  for (int i = 0; i < g.size_x(); ++i)
    for (int j = 0; j < g.size_y(); ++j) {
      const cv::Point2d p = g.cell_center(i, j);
      const auto px = dd.project(p.x, p.y);
      const bool in_view = p.x > 0 && px && px->x >= 1 && px->x < 318 && px->y >= 1 && px->y < 238;
      const float v = t.at<float>(i, j);
      if (p.x < 0.5) {  // behind the camera / below the lowest row: never seen
        EXPECT_TRUE(std::isnan(v)) << i << "," << j;
        EXPECT_EQ(conf.at<float>(i, j), 0.0f);
        EXPECT_TRUE(std::isnan(g.layer("elevation").at<float>(i, j)));
        ++unknown;
      } else if (in_view && std::isfinite(v)) {
        EXPECT_FLOAT_EQ(v, 1.0f);
        EXPECT_FLOAT_EQ(g.layer("elevation").at<float>(i, j), 0.0f);
        ++known;
      }
    }
  EXPECT_GT(known, 1500);
  EXPECT_GT(unknown, 300);
}

TEST(Traversability, StepAndSlopeAboveCriticalAreFlagged) {
  TraversabilityParams p = params();
  GridMap g;
  g.resolution_m = p.resolution_m;
  g.length_x_m = 2.0;
  g.length_y_m = 2.0;
  g.layers = {"elevation"};
  cv::Mat e(40, 40, CV_32F);
  // Rows 0..19 (x > 0): a 0.2 m step at row 20; columns 0..19 flat, 20..39 a 30 deg slope.
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j)
      e.at<float>(i, j) =
          static_cast<float>((i < 20 ? 0.2 : 0.0) + (j >= 20 ? (j - 20) * 0.05 * std::tan(30 * CV_PI / 180) : 0.0));
  g.data = {e};
  traversability::compute_layers(g, p);
  const cv::Mat& st = g.layer("traversability_step");
  const cv::Mat& sl = g.layer("traversability_slope");
  const cv::Mat& t = g.layer("traversability");
  EXPECT_EQ(st.at<float>(19, 5), 0.0f);  // at the step
  EXPECT_EQ(st.at<float>(20, 5), 0.0f);
  EXPECT_EQ(t.at<float>(20, 5), 0.0f);
  EXPECT_FLOAT_EQ(st.at<float>(10, 5), 1.0f);  // far from the step
  EXPECT_FLOAT_EQ(t.at<float>(10, 5), 1.0f);
  EXPECT_EQ(sl.at<float>(10, 30), 0.0f);  // 30 deg > 20 deg critical
  EXPECT_EQ(t.at<float>(10, 30), 0.0f);
  // A gentle 5 deg slope: 1 - 5/20.05 slope score.
  cv::Mat e5(40, 40, CV_32F);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) e5.at<float>(i, j) = static_cast<float>(i * 0.05 * std::tan(5 * CV_PI / 180));
  g.layers = {"elevation"};
  g.data = {e5};
  traversability::compute_layers(g, p);
  EXPECT_NEAR(g.layer("traversability_slope").at<float>(20, 20), 1.0 - (5 * CV_PI / 180) / p.critical_slope_rad, 1e-4);
  EXPECT_NEAR(g.layer("traversability_roughness").at<float>(20, 20), 1.0, 1e-3);
  // Step of 0.06 m (half critical): step score 0.5.
  cv::Mat e6(40, 40, CV_32F, cv::Scalar(0));
  e6(cv::Rect(0, 0, 40, 20)).setTo(0.06);
  g.layers = {"elevation"};
  g.data = {e6};
  traversability::compute_layers(g, p);
  EXPECT_NEAR(g.layer("traversability_step").at<float>(20, 20), 0.5, 1e-4);
}

// The layers by definition, cell by cell over every disc cell (what compute_layers did before
// its prefix sums and running extremes): slope, roughness and step of cell (i, j).
struct DirectLayers {
  float slope, roughness, step;
};
DirectLayers direct_layers(const cv::Mat& e, int i, int j, double res, const TraversabilityParams& p) {
  const int rs = std::max(1, static_cast<int>(std::ceil(p.slope_radius_m / res - 1e-9)));
  const int rst = std::max(1, static_cast<int>(std::ceil(p.step_radius_m / res - 1e-9)));
  cv::Matx33d A = cv::Matx33d::zeros();
  cv::Vec3d b(0, 0, 0);
  double szz = 0;
  float zmin = e.at<float>(i, j), zmax = zmin;
  for (int di = -std::max(rs, rst); di <= std::max(rs, rst); ++di)
    for (int dj = -std::max(rs, rst); dj <= std::max(rs, rst); ++dj) {
      const int ii = i + di, jj = j + dj;
      if (ii < 0 || jj < 0 || ii >= e.rows || jj >= e.cols || !std::isfinite(e.at<float>(ii, jj))) continue;
      const float zf = e.at<float>(ii, jj);
      if (di * di + dj * dj <= rst * rst) zmin = std::min(zmin, zf), zmax = std::max(zmax, zf);
      if (di * di + dj * dj > rs * rs) continue;
      const cv::Vec3d r(1.0, di * res, dj * res);
      A += r * r.t();
      b += r * static_cast<double>(zf);
      szz += static_cast<double>(zf) * zf;
    }
  cv::Vec3d sol;
  cv::solve(A, b, sol, cv::DECOMP_LU);
  const double slope = std::atan(std::hypot(sol[1], sol[2]));
  const double rough = std::sqrt(std::max(0.0, szz - sol.dot(b)) / A(0, 0));
  const auto score = [](double v, double critical) {
    return static_cast<float>(v >= critical ? 0.0 : 1.0 - v / critical);
  };
  return {score(slope, p.critical_slope_rad), score(rough, p.critical_roughness_m),
          score(zmax - zmin, p.critical_step_m)};
}

// compute_layers sums its discs from row prefix sums and takes the step from running row extremes;
// on rough ground with unknown holes, at the grid's edges, far from zero elevation and with discs
// from 1 to 25 cells across, every layer agrees with the definition computed cell by cell (the
// step exactly), and a reused workspace gives the same layers again.
TEST(Traversability, LayersEqualTheirDefinitionOnEveryDisc) {
  cv::RNG rng(7);
  cv::Mat e(41, 57, CV_32F);
  for (int i = 0; i < e.rows; ++i)
    for (int j = 0; j < e.cols; ++j)
      e.at<float>(i, j) = static_cast<float>(12.0 + 0.02 * i + 0.3 * std::sin(0.21 * j) * std::cos(0.13 * i) +
                                             rng.gaussian(0.01) + (rng.uniform(0, 40) == 0 ? 0.15 : 0.0));
  for (int k = 0; k < 300; ++k) e.at<float>(rng.uniform(0, e.rows), rng.uniform(0, e.cols)) = std::nanf("");
  e(cv::Rect(20, 10, 6, 5)).setTo(std::numeric_limits<float>::quiet_NaN());
  traversability::LayerWorkspace ws;
  for (const double res : {0.05, 0.01, 0.004}) {
    TraversabilityParams p = params();
    p.resolution_m = res;
    p.critical_roughness_m = 0.03;
    GridMap g;
    g.resolution_m = res;
    g.length_x_m = e.rows * res;
    g.length_y_m = e.cols * res;
    for (int pass = 0; pass < 2; ++pass) {  // the second reuses the workspace
      g.layers = {"elevation"};
      g.data = {e.clone()};
      traversability::compute_layers(g, p, ws);
      int compared = 0;
      for (int i = 0; i < e.rows; ++i)
        for (int j = 0; j < e.cols; ++j) {
          if (!std::isfinite(e.at<float>(i, j))) {
            EXPECT_TRUE(std::isnan(g.layer("traversability").at<float>(i, j)));
            continue;
          }
          const DirectLayers d = direct_layers(e, i, j, res, p);
          ASSERT_NEAR(g.layer("traversability_slope").at<float>(i, j), d.slope, 1e-5) << res << " at " << i << "," << j;
          ASSERT_NEAR(g.layer("traversability_roughness").at<float>(i, j), d.roughness, 1e-5)
              << res << " at " << i << "," << j;
          ASSERT_EQ(g.layer("traversability_step").at<float>(i, j), d.step) << res << " at " << i << "," << j;
          ++compared;
        }
      EXPECT_GT(compared, 1900);
    }
  }
}

TEST(Traversability, MetricRockFromCameraIsFlagged) {
  // A 0.2 m tall block in the metric height image lands in the right cells.
  const direct_depth::DirectDepth dd(cam());
  TraversabilityMapper mapper(dd, params());
  // Exact per-pixel heights of a 0.2 m tall box spanning x = 2.0 .. 2.4 m, y = -0.3 .. 0.3 m.
  cv::Mat h(240, 320, CV_32F, cv::Scalar(0));
  const double hc = cam().mount_height_m;
  for (int r = 0; r < 240; ++r)
    for (int c = 0; c < 320; ++c) {
      const float R = dd.range_map().at<float>(r, c), L = dd.lateral_map().at<float>(r, c);
      if (!std::isfinite(R)) continue;
      const double k_front = 2.0 / R;  // ray parameter where it reaches x = 2.0
      const double z_front = hc * (1 - k_front);
      const double y_front = L * k_front;
      if (R > 2.0 && z_front <= 0.2 && std::abs(y_front) < 0.3) {
        h.at<float>(r, c) = static_cast<float>(z_front);  // front face
        continue;
      }
      const double kt = 1 - 0.2 / hc;  // ray reaches z = 0.2
      const double xt = R * kt, yt = L * kt;
      if (xt >= 2.0 && xt <= 2.4 && std::abs(yt) < 0.3) h.at<float>(r, c) = 0.2f;  // top
    }
  GridMap g;
  mapper.compute_from_metric(h, cv::Mat(), g);
  int i, j;
  ASSERT_TRUE(g.cell_of(2.2, 0.0, i, j));
  EXPECT_NEAR(g.layer("elevation").at<float>(i, j), 0.2, 1e-4);
  ASSERT_TRUE(g.cell_of(2.01, 0.0, i, j));
  EXPECT_EQ(g.layer("traversability").at<float>(i, j), 0.0f);  // step edge
  ASSERT_TRUE(g.cell_of(2.5, 1.0, i, j));
  EXPECT_FLOAT_EQ(g.layer("traversability").at<float>(i, j), 1.0f);
}

struct RockStats {
  double median_ratio = 0;  // median of (estimated / true) rock height
  double mean_abs_err_pct = 0;
  int rocks = 0;
};

// Rock heights from the grid: max elevation over the cells within 0.7 of the rock's normalised
// radius minus the median elevation of the ring 1.5..2.5 radii around it (rocks ranged 1.2..3 m).
RockStats rock_heights(const GridMap& g, const terrain_scene::Terrain& t, bool print) {
  std::vector<double> ratios;
  double err = 0;
  for (const auto& rk : t.rocks()) {
    if (rk.x_m < 1.2 || rk.x_m > 3.0 || std::min(rk.radius_x_m, rk.radius_y_m) < 0.06) continue;
    double peak = -1e9;
    std::vector<double> ring;
    for (int i = 0; i < g.size_x(); ++i)
      for (int j = 0; j < g.size_y(); ++j) {
        const float e = g.layer("elevation").at<float>(i, j);
        if (!std::isfinite(e)) continue;
        const cv::Point2d p = g.cell_center(i, j);
        const double d = std::hypot((p.x - rk.x_m) / rk.radius_x_m, (p.y - rk.y_m) / rk.radius_y_m);
        if (d < 0.7)
          peak = std::max(peak, static_cast<double>(e));
        else if (d > 1.5 && d < 2.5)
          ring.push_back(e);
      }
    if (peak < -1e8 || ring.size() < 5) continue;
    std::nth_element(ring.begin(), ring.begin() + static_cast<long>(ring.size() / 2), ring.end());
    const double est = peak - ring[ring.size() / 2];
    ratios.push_back(est / rk.height_m);
    err += std::abs(est - rk.height_m) / rk.height_m;
    if (print)
      std::printf("  rock at %.2f,%.2f r %.2f: true %.3f m est %.3f m\n", rk.x_m, rk.y_m, rk.radius_x_m, rk.height_m,
                  est);
  }
  RockStats s;
  s.rocks = static_cast<int>(ratios.size());
  if (ratios.empty()) return s;
  std::sort(ratios.begin(), ratios.end());
  s.median_ratio = ratios[ratios.size() / 2];
  s.mean_abs_err_pct = 100.0 * err / static_cast<double>(ratios.size());
  return s;
}

terrain_scene::SceneParams rock_field() {
  terrain_scene::SceneParams sp;
  sp.seed = 21;
  sp.fractal_rms_m = 0.005;
  sp.num_craters = 0;
  sp.num_rocks = 25;
  sp.place_x_min_m = 1.0;
  sp.place_x_max_m = 3.0;
  sp.place_y_abs_max_m = 1.0;
  return sp;
}

// Pearson correlation of the grid elevation with the true terrain height over known cells at
// 1.2 .. 3 m (where the rocks are).
double elevation_correlation(const GridMap& g, const terrain_scene::Terrain& t) {
  double n = 0, sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (int i = 0; i < g.size_x(); ++i)
    for (int j = 0; j < g.size_y(); ++j) {
      const float e = g.layer("elevation").at<float>(i, j);
      const cv::Point2d p = g.cell_center(i, j);
      if (!std::isfinite(e) || p.x < 1.2 || p.x > 3.0) continue;
      const double a = e, b = t.height_at(p.x, p.y);
      n += 1;
      sa += a;
      sb += b;
      saa += a * a;
      sbb += b * b;
      sab += a * b;
    }
  const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  return (sab - sa * sb / n) / std::sqrt(va * vb);
}

TEST(Traversability, SfsScaleRecoveryOnRenderedScene) {
  // End to end: rendered rover image -> SfS -> metric grid; rock heights against the generator's
  // truth. Before the light-aware scale (lateral footprint only) the median ratio was 0.2 (5x low).
  const direct_depth::CameraModel m = cam();
  const direct_depth::DirectDepth dd(m);
  const terrain_scene::Terrain t(rock_field());
  const terrain_scene::CameraPose pose = terrain_scene::camera_pose_of(m);
  for (const terrain_scene::Sun sun : {terrain_scene::Sun{2.5, 0.4}, terrain_scene::Sun{2.0, 0.6}}) {
    const auto img = terrain_scene::render_camera(t, pose, sun);
    const ImageLight light{img.light_slant_rad, img.light_tilt_rad};
    std::printf("sun az %.2f el %.2f: image slant %.1f deg tilt %.1f deg, ground elevation %.1f deg\n", sun.azimuth_rad,
                sun.elevation_rad, light.slant_rad * 180 / CV_PI, light.tilt_rad * 180 / CV_PI,
                sun_elevation(m, light) * 180 / CV_PI);
    EXPECT_NEAR(sun_elevation(m, light), sun.elevation_rad, 1e-6);
    for (auto method : {sfs::Method::kTsaiShah, sfs::Method::kPentland}) {
      sfs::SfsParams spar;
      spar.method = method;
      const auto res = sfs::shape_from_shading(img.image, sfs::LightDirection{light.slant_rad, light.tilt_rad}, spar);
      TraversabilityMapper mapper(dd, params());
      GridMap g;
      mapper.compute_from_sfs(res.height, res.valid, light, g);
      const RockStats s = rock_heights(g, t, false);
      std::printf("  %s: %d rocks, median est/true height %.2f, mean |error| %.0f %%, elevation r %.2f\n",
                  sfs::to_string(method), s.rocks, s.median_ratio, s.mean_abs_err_pct, elevation_correlation(g, t));
      ASSERT_GE(s.rocks, 5);
      // Measured (README): Pentland 0.16 / 0.24, Tsai-Shah 0.00 / 0.69 -- rock heights are
      // still underestimated on perspective frames (known limitation). Guard against a sign or
      // scale regression only for the more stable Pentland path.
      if (method == sfs::Method::kPentland) {
        EXPECT_GT(s.median_ratio, 0.1);
        EXPECT_LT(s.median_ratio, 1.0);
      }
    }
  }
}

TEST(Traversability, GroundLightIsTheOrthographicSun) {
  // The image-frame light converted to the rectified ground frame equals the generator's sun in
  // its orthographic image frame (same axes: columns = -y, rows = -x, up).
  const direct_depth::CameraModel m = cam();
  for (const terrain_scene::Sun sun :
       {terrain_scene::Sun{2.5, 0.4}, terrain_scene::Sun{-1.0, 0.9}, terrain_scene::Sun{3.0, 0.2}}) {
    const cv::Vec2d il = terrain_scene::camera_light(terrain_scene::camera_pose_of(m), sun);
    const cv::Vec2d ol = terrain_scene::ortho_light(sun);
    const ImageLight g = traversability::ground_light(m, {il[0], il[1]});
    EXPECT_NEAR(g.slant_rad, ol[0], 1e-9);
    EXPECT_NEAR(std::remainder(g.tilt_rad - ol[1], 2 * CV_PI), 0.0, 1e-9);
  }
  // Below the horizon: NaN slant.
  EXPECT_TRUE(std::isnan(traversability::ground_light(m, {1.5, CV_PI / 2}).slant_rad));
}

TEST(Traversability, GroundRectifiedSfsFlatGroundIsTraversable) {
  // Uniform grey = flat ground for any sun: elevation 0, traversability 1 wherever seen, NaN and
  // confidence 0 behind the camera; confidence falls with range (fewer pixels per cell).
  const direct_depth::DirectDepth dd(cam());
  TraversabilityMapper mapper(dd, params());
  GridMap g;
  mapper.compute_from_image(cv::Mat(240, 320, CV_8U, cv::Scalar(120)), {0.8, -2.5}, g);
  int known = 0;
  for (int i = 0; i < g.size_x(); ++i)
    for (int j = 0; j < g.size_y(); ++j) {
      const cv::Point2d p = g.cell_center(i, j);
      const float e = g.layer("elevation").at<float>(i, j);
      if (p.x < 0.5) {
        EXPECT_TRUE(std::isnan(e));
        EXPECT_EQ(g.layer("confidence").at<float>(i, j), 0.0f);
      } else if (std::isfinite(e)) {
        EXPECT_NEAR(e, 0.0f, 1e-6);
        if (std::isfinite(g.layer("traversability").at<float>(i, j))) {
          EXPECT_FLOAT_EQ(g.layer("traversability").at<float>(i, j), 1.0f);
        }
        ++known;
      }
    }
  EXPECT_GT(known, 1500);
  int i_near, j_near, i_far, j_far;
  ASSERT_TRUE(g.cell_of(1.2, 0.0, i_near, j_near));
  ASSERT_TRUE(g.cell_of(3.4, 0.0, i_far, j_far));
  EXPECT_FLOAT_EQ(g.layer("confidence").at<float>(i_near, j_near), 1.0f);
  EXPECT_LT(g.layer("confidence").at<float>(i_far, j_far), 0.8f);
  EXPECT_GT(g.layer("confidence").at<float>(i_far, j_far), 0.0f);
  EXPECT_EQ(cv::countNonZero(mapper.rectified_valid()) > 0, true);
}

TEST(Traversability, GroundRectifiedSfsRecoversRockHeights) {
  // Rendered rover frames -> ground-rectified Tsai-Shah -> grid; rock heights against the
  // generator's truth, next to the image-frame path on the same frames. Four suns, including
  // one ahead of the rover (image-frame slant > 90 deg: only the ground path can use it).
  // Measured (README "Two SfS paths"): ground median est/true 0.74 / 0.53 / 0.73 / 0.65
  // (image-frame Tsai-Shah 0.01 / 0.58 / n.a. / 1.15); elevation-vs-truth correlation is weak in
  // both paths (ground -0.10 / -0.02 / 0.34 / 0.23; wrong sun -0.12 / -0.21 / 0.01 / -0.05):
  // layover and occlusion of the grazing view (README limitations).
  double r_sum = 0, rw_sum = 0;
  const direct_depth::CameraModel m = cam();
  const direct_depth::DirectDepth dd(m);
  const terrain_scene::Terrain t(rock_field());
  for (const terrain_scene::Sun sun : {terrain_scene::Sun{2.5, 0.4}, terrain_scene::Sun{2.0, 0.6},
                                       terrain_scene::Sun{0.5, 0.5}, terrain_scene::Sun{-1.5, 0.7}}) {
    const auto img = terrain_scene::render_camera(t, terrain_scene::camera_pose_of(m), sun);
    cv::Mat img8;
    img.image.convertTo(img8, CV_8U, 255.0);
    const ImageLight light{img.light_slant_rad, img.light_tilt_rad};
    TraversabilityMapper mapper(dd, params());
    GridMap g;
    mapper.compute_from_image(img8, light, g);
    const RockStats s = rock_heights(g, t, false);
    // The sun reversed in azimuth (a wrong light): heights come out inverted / flat.
    const ImageLight wrong = [&] {
      const cv::Vec2d l = terrain_scene::camera_light(terrain_scene::camera_pose_of(m),
                                                      terrain_scene::Sun{sun.azimuth_rad + CV_PI, sun.elevation_rad});
      return ImageLight{l[0], l[1]};
    }();
    GridMap gw;
    mapper.compute_from_image(img8, wrong, gw);
    const double r = elevation_correlation(g, t), rw = elevation_correlation(gw, t);
    std::printf(
        "sun az %.1f el %.1f: ground Tsai-Shah %d rocks, median est/true %.2f, mean |err| %.0f %%, "
        "elevation r %.2f; wrong sun r %.2f\n",
        sun.azimuth_rad, sun.elevation_rad, s.rocks, s.median_ratio, s.mean_abs_err_pct, r, rw);
    ASSERT_GE(s.rocks, 15);
    EXPECT_GT(s.median_ratio, 0.4);
    EXPECT_LT(s.median_ratio, 1.3);
    EXPECT_LT(s.mean_abs_err_pct, 120.0);
    r_sum += r;
    rw_sum += rw;
  }
  // A wrong sun must score clearly worse on average.
  EXPECT_GT(r_sum / 4, rw_sum / 4 + 0.1);
}

TEST(Traversability, ElevationOnlyGridsLeaveTheTraversabilityLayersUnknown) {
  // traversability_layers false (the drive-long map's per-frame grid): the same elevation and
  // confidence, no slope / roughness / step / traversability (NaN), whatever the last frame left.
  const direct_depth::CameraModel m = cam();
  const direct_depth::DirectDepth dd(m);
  const terrain_scene::Terrain t(rock_field());
  const auto img = terrain_scene::render_camera(t, terrain_scene::camera_pose_of(m), terrain_scene::Sun{2.0, 0.6});
  cv::Mat img8;
  img.image.convertTo(img8, CV_8U, 255.0);
  const ImageLight light{img.light_slant_rad, img.light_tilt_rad};
  TraversabilityParams only = params();
  only.traversability_layers = false;
  TraversabilityMapper full_mapper(dd, params()), only_mapper(dd, only);
  GridMap full, g;
  full_mapper.compute_from_image(img8, light, full);
  full_mapper.compute_from_image(img8, light, g);  // layers filled: the elevation-only frame must clear them
  only_mapper.compute_from_image(img8, light, g);
  ASSERT_EQ(g.layers, full.layers);
  // Cells with a value, and cells whose value differs from the other grid's (NaN = NaN).
  const auto known = [](const cv::Mat& layer) {
    int n = 0;
    for (int i = 0; i < layer.rows; ++i)
      for (int j = 0; j < layer.cols; ++j) n += !std::isnan(layer.at<float>(i, j));
    return n;
  };
  const auto differing = [](const cv::Mat& a, const cv::Mat& b) {
    int n = 0;
    for (int i = 0; i < a.rows; ++i)
      for (int j = 0; j < a.cols; ++j) {
        const float x = a.at<float>(i, j), y = b.at<float>(i, j);
        n += !(x == y || (std::isnan(x) && std::isnan(y)));
      }
    return n;
  };
  EXPECT_GT(known(full.layer("elevation")), 1000);
  for (const char* kept : {"elevation", "confidence"}) EXPECT_EQ(differing(full.layer(kept), g.layer(kept)), 0) << kept;
  EXPECT_GT(known(full.layer("traversability")), 1000);
  for (const char* gone : {"traversability_slope", "traversability_roughness", "traversability_step", "traversability"})
    EXPECT_EQ(known(g.layer(gone)), 0) << gone;  // every cell NaN
}

TEST(Traversability, ColumnMajorExport) {
  GridMap g;
  g.resolution_m = 1;
  g.length_x_m = 2;
  g.length_y_m = 3;
  g.layers = {"elevation"};
  cv::Mat e(2, 3, CV_32F);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) e.at<float>(i, j) = static_cast<float>(10 * i + j);
  g.data = {e};
  const auto v = traversability::export_column_major(g, 0);
  const std::vector<float> expect{0, 10, 1, 11, 2, 12};
  EXPECT_EQ(v, expect);
  // (0,0) is the +x/+y corner.
  const cv::Point2d c00 = g.cell_center(0, 0), c12 = g.cell_center(1, 2);
  EXPECT_GT(c00.x, c12.x);
  EXPECT_GT(c00.y, c12.y);
  float small[3];
  EXPECT_THROW(traversability::export_column_major(g, 0, small, 3), std::invalid_argument);
  EXPECT_THROW(traversability::export_column_major(g, 4), std::invalid_argument);
}

TEST(Traversability, AHugeDetrendSigmaEndsAndKeepsTheGridFinite) {
  // detrend_sigma_px 1e9 summed a 2e9-pixel window per line at configure (still running after
  // 60 s; found by probing every deployment parameter at its bounds). A window wider than the
  // line is now summed in closed form: about the same cells are known as with an ordinary sigma
  // (cells move along their rays by their heights, so not exactly the same), every one finite.
  const direct_depth::DirectDepth dd(cam());
  cv::Mat h(240, 320, CV_32F);
  cv::randu(h, -3.0, 3.0);
  int known[2] = {0, 0};
  int finite_elevation[2] = {0, 0};
  const double sigmas[2] = {1e9, 30.0};
  for (int s = 0; s < 2; ++s) {
    TraversabilityParams p = params();
    p.detrend_sigma_px = sigmas[s];
    TraversabilityMapper m(dd, p);
    GridMap g;
    m.compute_from_sfs(h, cv::Mat(), {0.5, 1.0}, g);
    const cv::Mat& e = g.layer("elevation");
    const cv::Mat& c = g.layer("confidence");
    for (int i = 0; i < e.rows; ++i)
      for (int j = 0; j < e.cols; ++j) {
        known[s] += c.at<float>(i, j) > 0.f;
        finite_elevation[s] += std::isfinite(e.at<float>(i, j));
      }
  }
  EXPECT_GT(known[1], 1000);
  EXPECT_NEAR(known[0], known[1], 0.02 * known[1]);
  EXPECT_EQ(finite_elevation[0], known[0]);
  EXPECT_EQ(finite_elevation[1], known[1]);
}

TEST(Traversability, AnAbsurdGridIsTooManyCellsNotAnOverflow) {
  // length 1e9 m at 5 cm: 2e10 cells per side overflowed int, came out negative, passed the
  // 4096-cell check and ended in an OpenCV assertion at configure (sams.length_x_m, found by
  // probing every deployment parameter at its bounds).
  for (const double len : {1e9, 1e300}) {
    regolith::common::GridGeometry g;
    g.resolution_m = 0.05;
    g.length_x_m = len;
    g.length_y_m = 2.0;
    EXPECT_EQ(g.size_x(), std::numeric_limits<int>::max());
    try {
      g.validate();
      ADD_FAILURE() << len;
    } catch (const regolith::FieldError& e) {
      EXPECT_NE(std::string(e.what()).find("length_x_m: more than 4096 cells per side"), std::string::npos) << e.what();
    }
  }
}

TEST(Traversability, BadInput) {
  const direct_depth::DirectDepth dd(cam());
  TraversabilityMapper mapper(dd, params());
  GridMap g;
  try {
    mapper.compute_from_metric(cv::Mat(100, 100, CV_32F, cv::Scalar(0)), cv::Mat(), g);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("differs from the camera model"), std::string::npos);
  }
  EXPECT_THROW(mapper.compute_from_sfs(cv::Mat(), cv::Mat(), {0.5, 1.0}, g), std::invalid_argument);
  EXPECT_THROW(mapper.compute_from_sfs(cv::Mat(240, 320, CV_8U), cv::Mat(), {0.5, 1.0}, g), std::invalid_argument);
  // Ground path: wrong type / size / empty name the input; sun below the ground horizon -> unknown.
  try {
    mapper.compute_from_image(cv::Mat(240, 320, CV_16U, cv::Scalar(0)), {0.5, 1.0}, g);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("gray: must be CV_8UC1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mapper.compute_from_image(cv::Mat(10, 10, CV_8U), {0.5, 1.0}, g), std::invalid_argument);
  EXPECT_THROW(mapper.compute_from_image(cv::Mat(), {0.5, 1.0}, g), std::invalid_argument);
  mapper.compute_from_image(cv::Mat(240, 320, CV_8U, cv::Scalar(100)), {1.5, CV_PI / 2}, g);
  EXPECT_EQ(cv::countNonZero(g.layer("confidence")), 0);
  TraversabilityParams pr = params();
  pr.rectify_resolution_m = 0.0;
  EXPECT_THROW(TraversabilityMapper(dd, pr), std::invalid_argument);
  // Sun below the ground horizon (tilt towards the image bottom with a large slant for a camera
  // pitched down): no shading information -> all unknown, confidence 0.
  mapper.compute_from_sfs(cv::Mat(240, 320, CV_32F, cv::Scalar(0)), cv::Mat(), {1.5, CV_PI / 2}, g);
  EXPECT_EQ(cv::countNonZero(g.layer("confidence")), 0);
  TraversabilityParams p = params();
  p.critical_step_m = std::nan("");
  try {
    TraversabilityMapper bad(dd, p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("critical_step_m"), std::string::npos);
  }
  // Camera looking above the horizon: an all-NaN map with confidence 0, no crash.
  direct_depth::CameraModel up = cam();
  up.pitch_rad = -0.8;
  const direct_depth::DirectDepth ddu(up);
  TraversabilityMapper mu(ddu, params());
  mu.compute_from_metric(cv::Mat(240, 320, CV_32F, cv::Scalar(0)), cv::Mat(), g);
  EXPECT_EQ(cv::countNonZero(g.layer("confidence")), 0);
  const cv::Mat& e = g.layer("elevation");
  EXPECT_EQ(cv::countNonZero(e == e), 0);  // all NaN
}

}  // namespace
