// Thesis Tables 3.2 / 3.3 analogue: sizes of rocks of known dimensions measured from
// (a) SfS + direct depth (the project's monocular path) and (b) OpenCV StereoSGBM on a rendered
// stereo pair of the same scene, as deviation in % of the generator's truth.
//
// Per rock (generator pixel box of the left image, standing in for the detector's box):
//  * truth: width = 2 * radius_y (lateral extent; camera yaw 0), height = Rock::height_m.
//  * SfS + direct depth: width = DirectDepth::object_size(box).width_m (lateral extent of the box's
//    bottom edge on the flat ground); height = SfS heights converted to metres with the
//    traversability metric scale (TraversabilityMapper::compute_from_sfs -> metric_heights(),
//    default params: detrend 30 px, height_gain 1) as max over the box minus the median over the
//    ring between the box and the box grown by half its size on every side. Also reported: the
//    purely geometric direct-depth height of the box's top ray (object_size, round footprint).
//  * stereo: SGBM disparity -> 3D points (left optical frame -> world); ground = median z of the
//    same ring; height = 95th percentile z in the box - ground; width = lateral (world y) extent,
//    1st..99th percentile, of the box points more than max(1 cm, 25 % of that height) above ground.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
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

constexpr double kBaseline = 0.12;   // m, Bumblebee-like
constexpr int kNumDisp = 96;         // px, SGBM search range (covers ground at >= 0.4 m)
constexpr std::uint64_t kSeeds = 8;  // scenes of 4 rocks each

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

terrain_scene::CameraPose left_pose() {
  terrain_scene::CameraPose p;  // 640x480, fx = fy = 400 px
  p.height_m = 0.6;
  p.pitch_rad = 0.45;
  p.y_m = 0.5 * kBaseline;  // left camera: +y (REP-103 left)
  return p;
}

struct RockRow {
  int index = 0;
  double range_true = 0, width_true = 0, height_true = 0;
  double range_dd = 0, width_dd = 0, height_dd = 0;  // direct depth (geometric)
  double height_sfs[2] = {0, 0};                     // tsai_shah, pentland (traversability scale)
  double width_st = 0, height_st = 0;                // stereo
};

double pct(double est, double truth) {
  return 100.0 * (est - truth) / truth;
}

// Pixels of the ring between `box` and `box` grown by half its size on each side (clipped).
template <class F>
void for_ring(const cv::Rect& box, cv::Size size, F&& f) {
  const cv::Rect big = cv::Rect(box.x - box.width / 2, box.y - box.height / 2, 2 * box.width, 2 * box.height) &
                       cv::Rect(0, 0, size.width, size.height);
  for (int r = big.y; r < big.br().y; ++r)
    for (int c = big.x; c < big.br().x; ++c)
      if (!box.contains(cv::Point(c, r))) f(r, c);
}

struct Scene {
  terrain_scene::Terrain terrain;
  terrain_scene::CameraImage left, right;
};

// A scene with a few well separated rocks 1.3-3.6 m ahead, rendered from both cameras.
Scene make_scene(std::uint64_t seed) {
  terrain_scene::SceneParams sp;
  sp.seed = seed;
  sp.x_min_m = -0.5;
  sp.x_max_m = 7.0;
  sp.y_min_m = -4.0;
  sp.y_max_m = 4.0;
  sp.fractal_rms_m = 0.01;  // texture for the stereo matcher
  sp.num_craters = 0;
  sp.num_rocks = 4;
  sp.rock_radius_min_m = 0.08;
  sp.rock_radius_max_m = 0.20;
  sp.rock_height_ratio_min = 0.5;
  sp.rock_height_ratio_max = 0.9;
  sp.place_x_min_m = 1.3;
  sp.place_x_max_m = 3.6;
  sp.place_y_abs_max_m = 0.8;
  terrain_scene::Terrain t(sp);
  const terrain_scene::Sun sun{2.0, 0.6};
  terrain_scene::RenderOptions ro;
  ro.noise_sigma = 0.004;  // ~1 grey level of sensor noise, independent per camera
  ro.noise_seed = 11 + 2 * seed;
  const auto lp = left_pose();
  auto rp = lp;
  rp.y_m = -0.5 * kBaseline;
  auto l = terrain_scene::render_camera(t, lp, sun, ro);
  ro.noise_seed = 12 + 2 * seed;
  auto r = terrain_scene::render_camera(t, rp, sun, ro);
  return Scene{std::move(t), std::move(l), std::move(r)};
}

// World points (x, y, z) of every left pixel with a valid SGBM disparity (NaN elsewhere).
cv::Mat stereo_points(const Scene& s) {
  cv::setNumThreads(1);
  const cv::Mat l8 = terrain_scene::to_u8(s.left.image), r8 = terrain_scene::to_u8(s.right.image);
  const int bs = 5;
  auto sgbm =
      cv::StereoSGBM::create(0, kNumDisp, bs, 8 * bs * bs, 32 * bs * bs, 1, 63, 10, 100, 2, cv::StereoSGBM::MODE_SGBM);
  cv::Mat disp16;
  sgbm->compute(l8, r8, disp16);
  const auto p = left_pose();
  const cv::Matx33d R = p.world_from_optical();
  const cv::Vec3d o(p.x_m, p.y_m, p.height_m);
  cv::Mat pts(disp16.size(), CV_32FC3, cv::Scalar::all(std::nan("")));
  for (int r = 0; r < disp16.rows; ++r)
    for (int c = 0; c < disp16.cols; ++c) {
      const double d = disp16.at<short>(r, c) / 16.0;
      if (d <= 0.5) continue;
      const double z = p.fx * kBaseline / d;
      const cv::Vec3d w = o + R * cv::Vec3d((c - p.cx) / p.fx * z, (r - p.cy) / p.fy * z, z);
      pts.at<cv::Vec3f>(r, c) = cv::Vec3f(static_cast<float>(w[0]), static_cast<float>(w[1]), static_cast<float>(w[2]));
    }
  return pts;
}

TEST(TerrainStereo, StereoRangeMatchesTruth) {
  const Scene sc = make_scene(1);
  const auto* left_ = &sc.left;
  // Sanity of the stereo geometry itself: ground-truth range of the left camera vs stereo x.
  const cv::Mat pts = stereo_points(sc);
  std::vector<double> err;
  for (int r = 0; r < pts.rows; r += 2)
    for (int c = kNumDisp; c < pts.cols; c += 2) {
      const cv::Vec3f w = pts.at<cv::Vec3f>(r, c);
      const float t = left_->range_m.at<float>(r, c);
      if (!std::isfinite(w[0]) || !std::isfinite(t) || t < 1.0f || t > 5.0f) continue;
      err.push_back(((w[0] - left_pose().x_m) - t) / t);
    }
  ASSERT_GT(err.size(), 10000u);
  const double bias = percentile(err, 0.5);
  for (auto& e : err) e = std::abs(e);
  const double med = percentile(err, 0.5);
  std::printf("stereo range 1-5 m: %zu px, median error %+.2f %%, median |error| %.2f %%, 90th pct %.2f %%\n",
              err.size(), 100 * bias, 100 * med, 100 * percentile(err, 0.9));
  // Measured: median |error| 5.7 %, a +5.7 % bias (SGBM disparities 0.5-1 px short on this
  // rendered pair; see components/sfs/README.md "Rock sizes").
  EXPECT_LT(med, 0.08);
}

TEST(TerrainStereo, RockSizesSfsDirectDepthVsStereo) {
  const auto lp = left_pose();
  const direct_depth::DirectDepth dd(terrain_scene::camera_model_of(lp));
  std::vector<RockRow> rows;
  for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const Scene sc = make_scene(seed);
    const auto* left_ = &sc.left;
    const auto* terrain_ = &sc.terrain;
    const cv::Mat pts = stereo_points(sc);

    // SfS (known sun) + traversability metric scale, for both the component default and Pentland.
    cv::Mat metric[2];
    const sfs::Method methods[2] = {sfs::Method::kTsaiShah, sfs::Method::kPentland};
    const traversability::ImageLight light{left_->light_slant_rad, left_->light_tilt_rad};
    for (int k = 0; k < 2; ++k) {
      sfs::SfsParams sp;
      sp.method = methods[k];
      const auto res = sfs::shape_from_shading(terrain_scene::to_u8(left_->image),
                                               sfs::LightDirection{light.slant_rad, light.tilt_rad}, sp);
      traversability::TraversabilityParams tp;  // defaults (detrend 30 px, gain 1)
      tp.length_x_m = 6.0;
      tp.center_x_m = 3.0;
      traversability::TraversabilityMapper mapper(dd, tp);
      traversability::GridMap g;
      mapper.compute_from_sfs(res.height, res.valid, light, g);
      metric[k] = mapper.metric_heights().clone();
    }

    for (const auto& pb : left_->rock_boxes) {
      if (!pb.fully_inside || pb.box.x < kNumDisp || pb.box.width < 8 || pb.box.height < 6) continue;
      // Rocks touching or occluded by another rock in the image are left out (their detector box
      // would not be the rock's outline): no pixel of another rock within 2 px of the box.
      const cv::Rect grown = cv::Rect(pb.box.x - 2, pb.box.y - 2, pb.box.width + 4, pb.box.height + 4) &
                             cv::Rect(0, 0, lp.width, lp.height);
      bool touching = false;
      for (int r = grown.y; r < grown.br().y && !touching; ++r)
        for (int c = grown.x; c < grown.br().x; ++c) {
          const int id = left_->rock_id.at<int>(r, c);
          if (id >= 0 && id != pb.rock_index) touching = true;
        }
      if (touching) continue;
      const auto& rk = terrain_->rocks()[static_cast<std::size_t>(pb.rock_index)];
      RockRow row;
      row.index = static_cast<int>(seed) * 100 + pb.rock_index;
      row.range_true = rk.x_m - lp.x_m;
      row.width_true = 2 * rk.radius_y_m;
      row.height_true = rk.height_m;
      const auto os = dd.object_size(pb.box);
      if (!os.valid) continue;
      row.range_dd = os.range_m;
      row.width_dd = os.width_m;
      row.height_dd = os.height_m;
      for (int k = 0; k < 2; ++k) {
        double peak = -1e9;
        for (int r = pb.box.y; r < pb.box.br().y; ++r)
          for (int c = pb.box.x; c < pb.box.br().x; ++c) {
            const float v = metric[k].at<float>(r, c);
            if (std::isfinite(v)) peak = std::max(peak, static_cast<double>(v));
          }
        std::vector<double> ring;
        for_ring(pb.box, metric[k].size(), [&](int r, int c) {
          const float v = metric[k].at<float>(r, c);
          if (std::isfinite(v)) ring.push_back(v);
        });
        row.height_sfs[k] = peak - percentile(ring, 0.5);
      }
      // Stereo.
      std::vector<double> ring_z, box_z;
      for_ring(pb.box, pts.size(), [&](int r, int c) {
        const float z = pts.at<cv::Vec3f>(r, c)[2];
        if (std::isfinite(z)) ring_z.push_back(z);
      });
      for (int r = pb.box.y; r < pb.box.br().y; ++r)
        for (int c = pb.box.x; c < pb.box.br().x; ++c) {
          const float z = pts.at<cv::Vec3f>(r, c)[2];
          if (std::isfinite(z)) box_z.push_back(z);
        }
      if (ring_z.size() < 20 || box_z.size() < 20) continue;
      const double ground = percentile(ring_z, 0.5);
      row.height_st = percentile(box_z, 0.95) - ground;
      const double thr = ground + std::max(0.01, 0.25 * row.height_st);
      std::vector<double> ys;
      for (int r = pb.box.y; r < pb.box.br().y; ++r)
        for (int c = pb.box.x; c < pb.box.br().x; ++c) {
          const cv::Vec3f w = pts.at<cv::Vec3f>(r, c);
          if (std::isfinite(w[2]) && w[2] > thr) ys.push_back(w[1]);
        }
      if (ys.size() < 10) continue;
      row.width_st = percentile(ys, 0.99) - percentile(ys, 0.01);
      rows.push_back(row);
    }
  }
  std::sort(rows.begin(), rows.end(), [](const RockRow& a, const RockRow& b) { return a.range_true < b.range_true; });

  std::printf(
      "\nRock sizes (m) and deviation from truth (%%), 640x480 fx 400, h 0.6 m, pitch 0.45 rad, "
      "baseline %.2f m\n",
      kBaseline);
  std::printf(
      "| scene.rock | range | true W | true H | DD W (%%) | DD-box H (%%) | SfS-TS H (%%) | SfS-P H (%%) | "
      "stereo W (%%) | stereo H (%%) |\n|---|---|---|---|---|---|---|---|---|---|\n");
  double e_dd_w = 0, e_dd_h = 0, e_ts = 0, e_pe = 0, e_st_w = 0, e_st_h = 0;
  std::vector<double> ratio_pe, ratio_ts;
  for (const auto& r : rows) {
    std::printf(
        "| %d | %.2f | %.3f | %.3f | %.3f (%+.0f) | %.3f (%+.0f) | %.3f (%+.0f) | %.3f (%+.0f) | %.3f (%+.0f) | "
        "%.3f (%+.0f) |\n",
        r.index, r.range_true, r.width_true, r.height_true, r.width_dd, pct(r.width_dd, r.width_true), r.height_dd,
        pct(r.height_dd, r.height_true), r.height_sfs[0], pct(r.height_sfs[0], r.height_true), r.height_sfs[1],
        pct(r.height_sfs[1], r.height_true), r.width_st, pct(r.width_st, r.width_true), r.height_st,
        pct(r.height_st, r.height_true));
    e_dd_w += std::abs(pct(r.width_dd, r.width_true));
    e_dd_h += std::abs(pct(r.height_dd, r.height_true));
    e_ts += std::abs(pct(r.height_sfs[0], r.height_true));
    e_pe += std::abs(pct(r.height_sfs[1], r.height_true));
    e_st_w += std::abs(pct(r.width_st, r.width_true));
    e_st_h += std::abs(pct(r.height_st, r.height_true));
    ratio_ts.push_back(r.height_sfs[0] / r.height_true);
    ratio_pe.push_back(r.height_sfs[1] / r.height_true);
  }
  ASSERT_GE(rows.size(), 6u);
  const double n = static_cast<double>(rows.size());
  const double med_ts = percentile(ratio_ts, 0.5), med_pe = percentile(ratio_pe, 0.5);
  std::printf("| mean abs | | | | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f |\n", e_dd_w / n, e_dd_h / n, e_ts / n,
              e_pe / n, e_st_w / n, e_st_h / n);
  std::printf("median SfS height est/true: tsai_shah %.2f, pentland %.2f (%zu rocks)\n", med_ts, med_pe, rows.size());
  // Measured (17 rocks): mean |error| DD width 3 %, DD box height 8 %, stereo width 4 %, stereo
  // height 10 %, SfS Tsai-Shah height 35 % (median ratio 1.14), Pentland 29 % (median 0.76; 55 %
  // and 0.41 before its Tikhonov term went 0.05 -> 0.02 and masked pixels kept their brightness).
  EXPECT_LT(e_dd_w / n, 6.0);
  EXPECT_LT(e_dd_h / n, 14.0);
  EXPECT_LT(e_st_w / n, 8.0);
  EXPECT_LT(e_st_h / n, 16.0);
  EXPECT_LT(e_ts / n, 50.0);
  EXPECT_GT(med_ts, 0.6);
  EXPECT_LT(med_ts, 1.8);
  EXPECT_LT(e_pe / n, 45.0);
  EXPECT_GT(med_pe, 0.5);
  EXPECT_LT(med_pe, 1.3);
}

}  // namespace
