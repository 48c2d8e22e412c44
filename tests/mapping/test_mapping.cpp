// regolith::mapping: planar poses, ground visual odometry, motion parallax, the world map, the
// drive mapper and the recorded-drive reader, against exact truth from the project's own
// renderer (mocks/terrain_scene) and, when present, the independent development drives.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <tuple>
#include <utility>
#include <vector>

#include <sys/wait.h>

#include <Eigen/LU>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/box.hpp"
#include "regolith/core/error.hpp"
#include "regolith/mapping/cost_minimum.hpp"
#include "regolith/mapping/drive_io.hpp"
#include "regolith/mapping/drive_mapper.hpp"
#include "regolith/mapping/evaluate.hpp"
#include "regolith/mapping/ground_vo.hpp"
#include "regolith/mapping/parallax.hpp"
#include "regolith/mapping/plane_sweep.hpp"
#include "regolith/mapping/rock_sightings.hpp"
#include "regolith/mapping/rock_tracker.hpp"
#include "regolith/mapping/shadow.hpp"
#include "regolith/mapping/world_map.hpp"
#include "regolith/terrain_scene/drive.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"
#include "temp_dir.hpp"

namespace {

using namespace regolith;
using namespace regolith::mapping;
namespace fs = std::filesystem;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

// The renderer's camera and the model the algorithms use, for the same 320x240 pinhole camera
// (principal point at the centre) `height_m` high, pitched `pitch_rad` down.
std::pair<terrain_scene::CameraPose, direct_depth::CameraModel> camera_320x240(double f_px, double height_m,
                                                                               double pitch_rad) {
  terrain_scene::CameraPose cam;
  direct_depth::CameraModel model;
  cam.fx = cam.fy = model.fx = model.fy = f_px;
  cam.cx = model.cx = 159.5;
  cam.cy = model.cy = 119.5;
  cam.width = model.width = 320;
  cam.height = model.height = 240;
  cam.height_m = model.mount_height_m = height_m;
  cam.pitch_rad = model.pitch_rad = pitch_rad;
  return {cam, model};
}

// A rover camera 0.67 m high, pitched 0.6 rad, 320x240, over rendered rocky terrain.
struct Rig {
  terrain_scene::Terrain terrain;
  terrain_scene::Sun sun;
  terrain_scene::CameraPose cam;
  direct_depth::CameraModel model;
  explicit Rig(std::uint64_t seed, int rocks = 15)
      : terrain([&] {
          terrain_scene::SceneParams sp;
          sp.seed = seed;
          sp.resolution_m = 0.01;
          sp.fractal_rms_m = 0.01;
          sp.fractal_beta = 2.9;
          sp.x_min_m = -1;
          sp.x_max_m = 8;
          sp.y_min_m = -4;
          sp.y_max_m = 4;
          sp.num_rocks = rocks;
          sp.num_craters = 1;
          return sp;
        }()),
        sun{2.3, 0.8} {
    std::tie(cam, model) = camera_320x240(220, 0.67, 0.6);
  }
  /// Another image size for the same camera: focal length `f_px`, principal point at the centre.
  void resize(int width, int height, double f_px) {
    cam.fx = cam.fy = model.fx = model.fy = f_px;
    cam.cx = model.cx = 0.5 * (width - 1);
    cam.cy = model.cy = 0.5 * (height - 1);
    cam.width = model.width = width;
    cam.height = model.height = height;
  }
  cv::Mat frame(const Pose2& foot, double pitch_offset = 0.0, double roll = 0.0, std::uint64_t noise_seed = 7) {
    cam.x_m = foot.x;
    cam.y_m = foot.y;
    cam.yaw_rad = foot.yaw;
    cam.pitch_rad = 0.6 + pitch_offset;
    cam.roll_rad = roll;
    terrain_scene::RenderOptions ro;
    ro.noise_sigma = 0.004;
    ro.noise_seed = noise_seed;
    return terrain_scene::to_u8(terrain_scene::render_camera(terrain, cam, sun, ro).image);
  }
};

TEST(Pose2, ComposeInverseAndBetweenAreConsistent) {
  const Pose2 a{1.0, -2.0, 0.7}, b{0.3, 0.1, -0.2};
  const Pose2 c = compose(a, b);
  const Pose2 back = between(a, c);
  EXPECT_NEAR(back.x, b.x, 1e-12);
  EXPECT_NEAR(back.y, b.y, 1e-12);
  EXPECT_NEAR(back.yaw, b.yaw, 1e-12);
  const Pose2 id = compose(a, inverse(a));
  EXPECT_NEAR(id.x, 0, 1e-12);
  EXPECT_NEAR(id.y, 0, 1e-12);
  EXPECT_NEAR(id.yaw, 0, 1e-12);
  EXPECT_NEAR(std::abs(wrap_angle(3 * 3.14159265358979323846)), 3.14159265358979323846, 1e-9);
  EXPECT_NEAR(wrap_angle(0.5 + 4 * 3.14159265358979323846), 0.5, 1e-9);
  // Covariance of a chain grows; a lever arm turns heading uncertainty into position uncertainty.
  Cov3 p = Cov3::Zero();
  p(2, 2) = 0.01;
  const Cov3 q = compose_covariance(Pose2{}, p, Pose2{2.0, 0.0, 0.0}, Cov3::Zero());
  EXPECT_NEAR(q(1, 1), 4.0 * 0.01, 1e-12);  // 2 m lever x 0.1 rad
}

TEST(GroundVisualOdometry, RecoversPlanarMotionOnRenderedTerrainToMillimetres) {
  Rig rig(3);
  const direct_depth::DirectDepth dd(rig.model);
  GroundVisualOdometry vo(dd, GroundVoParams{});
  Pose2 prev{};
  double worst_t = 0, worst_yaw = 0;
  for (int k = 0; k < 8; ++k) {
    const Pose2 pose{0.06 * k, 0.002 * k * k, 0.01 * k};
    const Pose2 truth = between(prev, pose);
    // A wheel prior 2 % long, 2 mm to the side and 0.17 deg off.
    const VoMeasurement& m = vo.track(rig.frame(pose), Pose2{truth.x * 1.02, truth.y + 0.002, truth.yaw + 0.003});
    if (k > 0) {
      ASSERT_TRUE(m.ok()) << k << ": " << to_string(m.status);
      worst_t = std::max(worst_t, std::hypot(m.pose.x - truth.x, m.pose.y - truth.y));
      worst_yaw = std::max(worst_yaw, std::abs(m.pose.yaw - truth.yaw));
      EXPECT_GT(m.inliers, 0.9 * m.points);
      EXPECT_LT(std::sqrt(m.covariance(0, 0)), 0.012);  // fit + 5 % scale model error
    }
    vo.promote_last();
    prev = pose;
  }
  // Measured 3.4 mm / 0.046 deg on x86-64 and 7.5 mm on arm64 (qemu): both cameras' tilts are
  // solved with the motion, which costs precision on 6 cm steps (0.9 mm / 0.018 deg with the
  // tilts fixed) and makes the fit sensitive to rounding, but removes the bias a tilted body puts
  // into every step on real ground (the development drives).
  EXPECT_LT(worst_t, 0.012);
  EXPECT_LT(worst_yaw, 0.12 * kDeg);
}

TEST(GroundVisualOdometry, SelfAlignmentIsIdentityAndUnusableFramesAreReported) {
  Rig rig(4);
  const direct_depth::DirectDepth dd(rig.model);
  GroundVisualOdometry vo(dd, GroundVoParams{});
  const cv::Mat f = rig.frame({});
  EXPECT_EQ(vo.track(f, {}).status, VoStatus::kNoKeyframe);
  vo.promote_last();
  const VoMeasurement& same = vo.track(f, Pose2{0.02, 0.01, 0.01});
  ASSERT_TRUE(same.ok());
  EXPECT_NEAR(same.pose.x, 0, 1e-4);
  EXPECT_NEAR(same.pose.y, 0, 1e-4);
  EXPECT_NEAR(same.pose.yaw, 0, 1e-4);
  // A fit that settles but fixes the motion more loosely than max_sigma_m is reported as such.
  GroundVoParams strict;
  strict.max_sigma_m = 1e-7;
  GroundVisualOdometry picky(dd, strict);
  picky.track(f, {});
  picky.promote_last();
  const VoMeasurement& loose = picky.track(rig.frame(Pose2{0.05, 0.0, 0.0}), Pose2{0.05, 0.0, 0.0});
  EXPECT_EQ(loose.status, VoStatus::kUncertain);
  EXPECT_GT(loose.inliers, strict.min_points);
  EXPECT_STREQ(to_string(loose.status), "the motion it fixes is too uncertain (translation sigma above max_sigma_m)");
  // Black and saturated frames have no usable ground: reported, never a pose.
  EXPECT_EQ(vo.track(cv::Mat(240, 320, CV_8U, cv::Scalar(0)), {}).status, VoStatus::kTooFewPoints);
  EXPECT_EQ(vo.track(cv::Mat(240, 320, CV_8U, cv::Scalar(255)), {}).status, VoStatus::kTooFewPoints);
  EXPECT_EQ(vo.last_frame_cells(), 0);
  try {
    vo.track(cv::Mat(100, 100, CV_8U, cv::Scalar(0)), {});
    FAIL();
  } catch (const FieldError& e) {
    EXPECT_NE(std::string(e.what()).find("gray"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("100x100"), std::string::npos) << e.what();
  }
}

TEST(GroundVisualOdometry, NeverConvergesByWarpingTheGroundOutOfView) {
  // Cameras tilted 0.02 rad against the ground (both frames), short baselines. A step that moves
  // far template cells out of the usable view must count them as outliers: before it did, 10 of
  // these 54 fits "converged" to tilts up to 0.18 rad and translations up to 6 cm off (now the
  // worst are 1.8 cm, on a pair where rocks pull the fit, and 0.039 rad of roll).
  for (std::uint64_t seed : {3, 5, 8}) {
    Rig rig(seed);
    const direct_depth::DirectDepth dd(rig.model);
    GroundVisualOdometry vo(dd, GroundVoParams{});
    for (double tilt : {0.0, 0.02, -0.02}) {
      vo.reset();
      vo.track(rig.frame({}, tilt), {});
      vo.promote_last();
      for (int k = 1; k <= 6; ++k) {
        const Pose2 pose{0.06 * k, 0.0, 0.0};
        const VoMeasurement& m = vo.track(rig.frame(pose, tilt), Pose2{pose.x * 1.02, 0.002, 0.003});
        SCOPED_TRACE(::testing::Message() << "seed " << seed << " tilt " << tilt << " step " << k);
        ASSERT_TRUE(m.ok()) << to_string(m.status);
        EXPECT_NEAR(m.key_pitch_rad, tilt, 0.045);
        EXPECT_NEAR(m.pitch_rad, tilt, 0.045);
        EXPECT_NEAR(m.roll_rad, 0.0, 0.045);
        EXPECT_LT(std::hypot(m.pose.x - pose.x, m.pose.y), 0.022);
      }
    }
  }
}

TEST(GroundVisualOdometry, SolvesTheCameraRisingBetweenKeyframeAndFrame) {
  // The rover climbs 2.5 cm over 0.24 m: the current camera is 0.695 m above the ground.
  Rig rig(5);
  const direct_depth::DirectDepth dd(rig.model);
  GroundVisualOdometry vo(dd, GroundVoParams{});
  vo.track(rig.frame({}), {});
  vo.promote_last();
  rig.cam.height_m = 0.695;
  const VoMeasurement& m = vo.track(rig.frame({0.24, 0.0, 0.0}), Pose2{0.245, 0.0, 0.0});
  ASSERT_TRUE(m.ok()) << to_string(m.status);
  EXPECT_NEAR(m.height_ratio, 0.67 / 0.695, 0.01);
  EXPECT_NEAR(m.pose.x, 0.24, 0.01);
  EXPECT_NEAR(m.pitch_rad, 0.0, 0.01);
  EXPECT_NEAR(m.key_pitch_rad, 0.0, 0.01);
}

TEST(GroundVisualOdometry, ExcludingTheRocksTakesTheirPullOffTheTilt) {
  // Rock-strewn ground, both cameras at the mount's tilt (0): the rocks' images (each smeared over
  // the rectified ground behind its foot) move faster than the ground and pull the joint fit's
  // pitch nose-down. Excluding their pixels (+3 px) from the keyframe refits the tilt nearer 0.
  double motion = 0.0, ground = 0.0, joint_len = 0.0, ground_len = 0.0;
  int fits = 0;
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    Rig rig(seed, 80);
    const direct_depth::DirectDepth dd(rig.model);
    GroundVisualOdometry vo(dd, GroundVoParams{});
    rig.cam.x_m = rig.cam.y_m = rig.cam.yaw_rad = 0.0;
    const terrain_scene::CameraImage key = terrain_scene::render_camera(rig.terrain, rig.cam, rig.sun, {});
    cv::Mat objects(key.rock_id.size(), CV_8U, cv::Scalar(0));
    for (int i = 0; i < objects.rows; ++i)
      for (int j = 0; j < objects.cols; ++j)
        if (key.rock_id.at<int>(i, j) >= 0)
          objects(cv::Rect(j - 3, i - 3, 7, 7) & cv::Rect({}, objects.size())).setTo(255);
    vo.track(rig.frame({}), {});
    vo.exclude(objects);
    vo.promote_last();
    for (double d : {0.3, 0.5}) {
      const VoMeasurement& m = vo.track(rig.frame({d, 0.0, 0.0}), Pose2{d * 1.02, 0.0, 0.0});
      SCOPED_TRACE(::testing::Message() << "seed " << seed << " baseline " << d);
      ASSERT_TRUE(m.ok()) << to_string(m.status);
      ASSERT_TRUE(m.ground_tilt);
      motion += std::abs(m.pitch_rad);
      ground += std::abs(m.ground_pitch_rad);
      joint_len += std::abs(std::hypot(m.pose.x, m.pose.y) - d);
      ground_len += std::abs(m.ground_distance_m - d);
      ++fits;
    }
  }
  // Measured: mean |pitch| 0.0105 rad for the joint fit, 0.0071 for the refit.
  EXPECT_LT(ground, 0.8 * motion);
  EXPECT_LT(ground / fits, 0.009);
  // The motion's length too: mean |error| 9.7 mm for the joint fit, 8.8 mm for the refit (0.3
  // and 0.5 m baselines).
  EXPECT_LT(ground_len, 0.95 * joint_len);
  // Without marks there is no refit; a mask of another size is refused naming it.
  Rig rig(1);
  const direct_depth::DirectDepth dd(rig.model);
  GroundVisualOdometry vo(dd, GroundVoParams{});
  vo.track(rig.frame({}), {});
  EXPECT_THROW(
      try { vo.exclude(cv::Mat(120, 160, CV_8U, cv::Scalar(0))); } catch (const FieldError& e) {
        EXPECT_NE(std::string(e.what()).find("objects"), std::string::npos) << e.what();
        throw;
      },
      FieldError);
  vo.promote_last();
  const VoMeasurement& m = vo.track(rig.frame({0.3, 0.0, 0.0}), Pose2{0.3, 0.0, 0.0});
  ASSERT_TRUE(m.ok());
  EXPECT_FALSE(m.ground_tilt);
  EXPECT_EQ(m.ground_pitch_rad, m.pitch_rad);
}

// ---- ShadowCue: exact top-down scenes ----

namespace {

// A ground-rectified frame (4 x 4 m, 2 cm cells; x forward, y left) with ground of brightness 100,
// a lit square block of `side` m centred at (x, y), and the shadow a block `h` m tall casts with the
// sun at azimuth `az` (counter-clockwise from +x, towards the sun) and elevation `el`: every ground
// point whose ray towards the sun meets the block's footprint below the block's height.
struct ShadowScene {
  direct_depth::RectifiedGrid grid{4.0, 2.0, 0.02, 200, 200};
  cv::Mat img = cv::Mat(200, 200, CV_32F, cv::Scalar(100.0f));
  cv::Mat valid = cv::Mat(200, 200, CV_8U, cv::Scalar(255));
  cv::Vec3d sun;
  ShadowScene(double x, double y, double side, double h, double az, double el) {
    sun = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
    const double len = h / std::tan(el);
    auto in_block = [&](double px, double py) {
      return std::abs(px - x) <= 0.5 * side && std::abs(py - y) <= 0.5 * side;
    };
    for (int i = 0; i < grid.rows; ++i)
      for (int j = 0; j < grid.cols; ++j) {
        const cv::Point2d c = grid.center(i, j);
        if (in_block(c.x, c.y)) {
          img.at<float>(i, j) = 150.0f;
          continue;
        }
        for (double t = 0.0; t <= len; t += 0.002)
          if (in_block(c.x + t * std::cos(az), c.y + t * std::sin(az))) {
            img.at<float>(i, j) = 20.0f;
            break;
          }
      }
  }
};

// The tallest caster height the cue found, and where.
struct Caster {
  double h = 0.0, x = 0.0, y = 0.0;
};
Caster tallest(const ShadowCue& cue) {
  Caster c;
  for (int i = 0; i < cue.height().rows; ++i)
    for (int j = 0; j < cue.height().cols; ++j) {
      const float v = cue.height().at<float>(i, j);
      if (std::isfinite(v) && v > c.h) c = {v, cue.x().at<float>(i, j), cue.y().at<float>(i, j)};
    }
  return c;
}

}  // namespace

TEST(ShadowCue, MeasuresACastersHeightFromItsShadowWhereverTheSunStands) {
  // A 0.2 m block 0.15 m tall at (2, 0.3): ahead of the camera (the shadow towards it), behind it
  // (the shadow away from it), to either side and diagonally, at a low and a middle sun. The height
  // is L tan(el) with L counted in 2 cm steps along the walk: within 1.5 cells of L.
  const double kH = 0.15, kX = 2.0, kY = 0.3, kSide = 0.2;
  for (const double el_deg : {20.0, 40.0})
    for (const double az_deg : {0.0, 180.0, 90.0, -90.0, 135.0, -45.0}) {
      SCOPED_TRACE(::testing::Message() << "sun azimuth " << az_deg << " deg, elevation " << el_deg << " deg");
      const double el = el_deg * CV_PI / 180.0, az = az_deg * CV_PI / 180.0;
      const ShadowScene scene(kX, kY, kSide, kH, az, el);
      ShadowCue cue(scene.grid, ShadowParams{});
      EXPECT_GT(cue.compute(scene.img, scene.valid, scene.sun), 0);
      const Caster c = tallest(cue);
      EXPECT_NEAR(c.h, kH, 1.5 * 0.02 * std::tan(el) + 1e-6);
      std::printf("shadow cue: sun az %4.0f el %2.0f deg: height %.3f m (true %.3f), foot (%.2f, %.2f)\n", az_deg,
                  el_deg, c.h, kH, c.x, c.y);
      // The caster's foot is the block's cell next to its shadow: on the block's anti-sun side.
      EXPECT_LE(std::abs(c.x - kX), 0.5 * kSide + 0.03);
      EXPECT_LE(std::abs(c.y - kY), 0.5 * kSide + 0.03);
      // Shadow cells: the dark ones, and nothing else (the block is lit, the ground too).
      EXPECT_EQ(cv::countNonZero(cue.shadow()), cv::countNonZero(scene.img < 50.0f));
    }
}

TEST(ShadowCue, NoHeightFromShadowsItCannotMeasure) {
  const double el = 30.0 * CV_PI / 180.0;
  {
    // The block outside the seen cells: every walk towards the sun leaves the view, so it is
    // dropped (unknown), not taken as a short shadow.
    ShadowScene scene(2.0, 0.0, 0.2, 0.15, CV_PI, el);  // sun behind: the shadow lies beyond the block
    for (int i = 0; i < scene.grid.rows; ++i)
      for (int j = 0; j < scene.grid.cols; ++j)
        if (scene.grid.center(i, j).x < 2.11) scene.valid.at<uchar>(i, j) = 0;  // the block and the near ground unseen
    ShadowCue cue(scene.grid, ShadowParams{});
    EXPECT_EQ(cue.compute(scene.img, scene.valid, scene.sun), 0);
    EXPECT_EQ(tallest(cue).h, 0.0);
  }
  {
    // A sun below min_elevation_rad (shadows everywhere) or above max_elevation_rad (none worth
    // measuring): no cue at all.
    const ShadowScene low(2.0, 0.0, 0.2, 0.01, 0.0, 0.03), high(2.0, 0.0, 0.2, 0.02, 0.0, 1.4);
    ShadowCue cue(low.grid, ShadowParams{});
    EXPECT_EQ(cue.compute(low.img, low.valid, low.sun), 0);
    EXPECT_EQ(cue.compute(high.img, high.valid, high.sun), 0);
    EXPECT_EQ(cv::countNonZero(cue.shadow()), 0);
  }
  {
    // A shadow shorter than min_length_m (4 cm: a 1 cm pebble at 30 deg) is noise.
    const ShadowScene pebble(2.0, 0.0, 0.04, 0.01, 0.0, el);
    ShadowCue cue(pebble.grid, ShadowParams{});
    EXPECT_EQ(cue.compute(pebble.img, pebble.valid, pebble.sun), 0);
  }
}

// The matching searches' window sums (one per hypothesis): equal to OpenCV's unnormalised box
// filter with replicated borders for the direct small radii and the running larger ones, on rows
// and columns shorter than the window too.
TEST(BoxSum, EqualsOpenCvBoxFilterWithReplicatedBorders) {
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(2, 3), cv::Size(7, 5), cv::Size(41, 33), cv::Size(280, 180)})
    for (int radius = 1; radius <= 6; ++radius)
      for (const bool running : {false, true}) {
        cv::Mat src(size, CV_32F), ref, dst, tmp, acc;
        rng.fill(src, cv::RNG::UNIFORM, 0.0, 65025.0);
        cv::boxFilter(src, ref, CV_32F, {2 * radius + 1, 2 * radius + 1}, {-1, -1}, false, cv::BORDER_REPLICATE);
        common::box_sum(src, dst, tmp, radius, running ? &acc : nullptr);
        double worst = 0;
        for (int i = 0; i < size.height; ++i)
          for (int j = 0; j < size.width; ++j)
            worst = std::max(worst, std::abs(static_cast<double>(dst.at<float>(i, j)) - ref.at<float>(i, j)) /
                                        static_cast<double>(ref.at<float>(i, j)));
        EXPECT_LT(worst, 1e-5) << size << " radius " << radius << (running ? " running" : " direct");
      }
  // box_sum_row at any radius (the plane sweep's window goes to 8; its rows are summed in
  // batches of nine), row by row over whole rows.
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(5, 3), cv::Size(41, 33)})
    for (int radius = 1; radius <= 9; ++radius) {
      cv::Mat src(size, CV_32F), ref, dst(size, CV_32F), tmp(size, CV_32F);
      rng.fill(src, cv::RNG::UNIFORM, 0.0, 65025.0);
      cv::boxFilter(src, ref, CV_32F, {2 * radius + 1, 2 * radius + 1}, {-1, -1}, false, cv::BORDER_REPLICATE);
      for (int i = 0; i < size.height; ++i) common::box_sum_row(src, dst, tmp, radius, i, {0, size.width});
      double worst = 0;
      for (int i = 0; i < size.height; ++i)
        for (int j = 0; j < size.width; ++j)
          worst = std::max(worst, std::abs(static_cast<double>(dst.at<float>(i, j)) - ref.at<float>(i, j)) /
                                      static_cast<double>(ref.at<float>(i, j)));
      EXPECT_LT(worst, 1e-5) << size << " radius " << radius << " rows";
    }
}

// The parallax search sums its windows only over each row's span of usable cells: every sum
// there is the whole image's bit for bit (spans at the borders, inside, empty, one column, the
// whole row), and nothing outside a span is written.
TEST(BoxSum, SpansGiveTheWholeImagesSumsBitForBitAndWriteNothingElse) {
  cv::RNG rng(5);
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(3, 4), cv::Size(41, 33), cv::Size(280, 180)})
    for (int radius = 1; radius <= 6; ++radius) {
      cv::Mat src(size, CV_32F), whole, tmp;
      rng.fill(src, cv::RNG::UNIFORM, 0.0, 65025.0);
      common::box_sum(src, whole, tmp, radius);
      std::vector<common::ColumnSpan> spans;
      for (int i = 0; i < size.height; ++i) {
        const int a = rng.uniform(0, size.width + 1), b = rng.uniform(0, size.width + 1);
        spans.push_back(i % 5 == 0   ? common::ColumnSpan{0, size.width}
                        : i % 5 == 1 ? common::ColumnSpan{a, a}
                                     : common::ColumnSpan{std::min(a, b), std::max(a, b)});
      }
      constexpr float kUntouched = -7.0f;
      cv::Mat dst(size, CV_32F, cv::Scalar(kUntouched)), tmp2(size, CV_32F);
      common::box_sum_spans(src, dst, tmp2, radius, spans.data());
      int inside = 0;
      for (int i = 0; i < size.height; ++i)
        for (int j = 0; j < size.width; ++j) {
          const bool in = j >= spans[static_cast<std::size_t>(i)].begin && j < spans[static_cast<std::size_t>(i)].end;
          if (in) {
            ++inside;
            EXPECT_EQ(dst.at<float>(i, j), whole.at<float>(i, j))
                << size << " radius " << radius << " at " << i << "," << j;
          } else if (radius <= common::kDirectBoxRadius) {
            EXPECT_EQ(dst.at<float>(i, j), kUntouched) << size << " radius " << radius << " at " << i << "," << j;
          }
        }
      EXPECT_GT(inside, 0);
    }
}

TEST(CostMinimum, BilinearCostsSampleInsideTheUsableFootprintAndPenaliseTheRest) {
  // The sample costs both searches make: against the four-weight bilinear sample in double where
  // the footprint is usable, the penalty everywhere else: an unusable key sample, an unusable
  // current pixel under the footprint, positions on the last row or column (no footprint),
  // outside, negative, NaN and infinite; nothing written outside the span.
  cv::RNG rng(5);
  const int rows = 9, cols = 13, n = 400;
  cv::Mat cur(rows, cols, CV_32F), ok(rows, cols, CV_8U, cv::Scalar(255)), ok4(rows, cols, CV_8U);
  rng.fill(cur, cv::RNG::UNIFORM, 0.0, 255.0);
  ok.at<uchar>(4, 6) = 0;
  bilinear_footprint_usable(ok, ok4);
  std::vector<float> at_row(n), at_col(n), key(n), e(n + 2, -1.0f);
  std::vector<uchar> key_ok(n);
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const float specials[] = {nan,
                            inf,
                            -inf,
                            -0.5f,
                            0.0f,
                            static_cast<float>(rows - 1),
                            static_cast<float>(cols - 1),
                            static_cast<float>(rows - 1) - 1e-3f,
                            1e9f};
  for (int j = 0; j < n; ++j) {
    at_row[j] = rng.uniform(-1.0f, static_cast<float>(rows));
    at_col[j] = rng.uniform(-1.0f, static_cast<float>(cols));
    if (j % 7 == 0) at_row[j] = specials[(j / 7) % 9];
    if (j % 11 == 0) at_col[j] = specials[(j / 11) % 9];
    key[j] = rng.uniform(0.0f, 255.0f);
    key_ok[j] = j % 13 == 0 ? 0 : 1;
  }
  const float gain = 1.1f, bias = -3.0f, penalty = kUnusableSampleCost;
  bilinear_costs(at_row.data(), at_col.data(), key.data(), key_ok.data(), cur, ok4, gain, bias, {0, n}, e.data() + 1);
  EXPECT_EQ(e[0], -1.0f);
  EXPECT_EQ(e[n + 1], -1.0f);
  int sampled = 0, near_hole = 0;
  for (int j = 0; j < n; ++j) {
    SCOPED_TRACE(::testing::Message() << "sample " << j << " at (" << at_row[j] << ", " << at_col[j] << ")");
    const float got = e[static_cast<std::size_t>(j) + 1];
    const float r = at_row[j], c = at_col[j];
    const bool inside = r >= 0 && c >= 0 && r < rows - 1 && c < cols - 1;
    const bool hole = inside && static_cast<int>(r) >= 3 && static_cast<int>(r) <= 4 && static_cast<int>(c) >= 5 &&
                      static_cast<int>(c) <= 6;  // the footprint holds pixel (4, 6)
    if (!key_ok[j] || !inside || hole) {
      EXPECT_EQ(got, penalty);
      near_hole += hole;
      continue;
    }
    const int i0 = static_cast<int>(std::floor(r)), j0 = static_cast<int>(std::floor(c));
    const double a = static_cast<double>(r) - i0, b = static_cast<double>(c) - j0;
    const double v = (1 - a) * (1 - b) * cur.at<float>(i0, j0) + (1 - a) * b * cur.at<float>(i0, j0 + 1) +
                     a * (1 - b) * cur.at<float>(i0 + 1, j0) + a * b * cur.at<float>(i0 + 1, j0 + 1);
    const double res = v - gain * key[j] - bias;
    EXPECT_NEAR(got, res * res, 1e-4 * (std::abs(res) + 1) * std::abs(res) + 1e-3);
    ++sampled;
  }
  EXPECT_GT(sampled, n / 2);
  EXPECT_GT(near_hole, 0);
  // A span: only its columns are written.
  std::fill(e.begin(), e.end(), -1.0f);
  bilinear_costs(at_row.data(), at_col.data(), key.data(), key_ok.data(), cur, ok4, gain, bias, {10, 20}, e.data() + 1);
  for (int j = 0; j < n; ++j) EXPECT_EQ(e[static_cast<std::size_t>(j) + 1] == -1.0f, j < 10 || j >= 20) << j;
}

TEST(CostMinimum, KeepsTheDeepestAndSecondDeepestValleyOfEachCellsCostCurve) {
  // Cost curves with ties, plateaus, NaN and a column count that is no multiple of the vector
  // width, fed slice by slice as the searches do, against a per-cell scan of the whole curve.
  cv::RNG rng(11);
  const int rows = 3, cols = 37, steps = 24;
  std::vector<cv::Mat> slices;
  for (int t = 0; t < steps; ++t) {
    cv::Mat s(rows, cols, CV_32F);
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) {
        const int pick = rng.uniform(0, 10);
        s.at<float>(i, j) = pick == 0   ? std::numeric_limits<float>::quiet_NaN()
                            : pick <= 3 ? 5.0f  // a plateau value shared by many steps
                                        : static_cast<float>(rng.uniform(0, 12));
      }
    slices.push_back(s);
  }
  constexpr float kNone = 1e30f;
  cv::Mat best(rows, cols, CV_32F, cv::Scalar(kNone)), second(rows, cols, CV_32F, cv::Scalar(kNone));
  cv::Mat at(rows, cols, CV_32F, cv::Scalar(-1)), left(rows, cols, CV_32F), right(rows, cols, CV_32F);
  for (int t = 2; t < steps; ++t)
    keep_bracketed_minimum(slices[t - 2], slices[t - 1], slices[t], best, at, left, right, t, 0, rows - 1, &second);
  int valleys = 0;
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      float b = kNone, s2 = kNone, where = -1, l = 0, r = 0;
      for (int t = 1; t + 1 < steps; ++t) {
        const float lo = slices[t - 1].at<float>(i, j), c = slices[t].at<float>(i, j),
                    hi = slices[t + 1].at<float>(i, j);
        if (!(c <= lo && c <= hi)) continue;
        ++valleys;
        if (c < b) {
          s2 = b, b = c, where = static_cast<float>(t), l = lo, r = hi;
        } else if (c < s2) {
          s2 = c;
        }
      }
      SCOPED_TRACE(::testing::Message() << "cell " << i << "," << j);
      EXPECT_EQ(best.at<float>(i, j), b);
      EXPECT_EQ(second.at<float>(i, j), s2);
      EXPECT_EQ(at.at<float>(i, j), where);
      if (where >= 0) {
        EXPECT_EQ(left.at<float>(i, j), l);
        EXPECT_EQ(right.at<float>(i, j), r);
      }
    }
  EXPECT_GT(valleys, rows * cols);  // the curves do have valleys to find

  // Limited to a span per row (as the parallax search runs it): the same records inside, none
  // outside.
  const std::vector<common::ColumnSpan> spans = {{0, cols}, {5, 30}, {9, 9}};
  cv::Mat best2(rows, cols, CV_32F, cv::Scalar(kNone)), second2(rows, cols, CV_32F, cv::Scalar(kNone));
  cv::Mat at2(rows, cols, CV_32F, cv::Scalar(-1)), left2(rows, cols, CV_32F), right2(rows, cols, CV_32F);
  for (int t = 2; t < steps; ++t)
    keep_bracketed_minimum(slices[t - 2], slices[t - 1], slices[t], best2, at2, left2, right2, t, 0, rows - 1, &second2,
                           spans.data());
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      SCOPED_TRACE(::testing::Message() << "span cell " << i << "," << j);
      const bool in = j >= spans[static_cast<std::size_t>(i)].begin && j < spans[static_cast<std::size_t>(i)].end;
      EXPECT_EQ(best2.at<float>(i, j), in ? best.at<float>(i, j) : kNone);
      EXPECT_EQ(second2.at<float>(i, j), in ? second.at<float>(i, j) : kNone);
      EXPECT_EQ(at2.at<float>(i, j), in ? at.at<float>(i, j) : -1.0f);
    }
}

TEST(GroundParallax, MeasuresRockHeightsAndFlatGroundFromTwoFrames) {
  Rig rig(5, 25);
  const direct_depth::DirectDepth dd(rig.model);
  GroundVisualOdometry vo(dd, GroundVoParams{});
  GroundParallax plx(dd, ParallaxParams{});
  const Pose2 a{0, 0, 0}, b{0.5, 0.01, 0.02};
  const cv::Mat fa = rig.frame(a), fb = rig.frame(b);
  vo.track(fa, {});
  vo.promote_last();
  plx.set_frame(fa);
  plx.promote();
  const VoMeasurement& m = vo.track(fb, between(a, b));
  ASSERT_TRUE(m.ok());
  plx.set_frame(fb);
  ASSERT_TRUE(plx.compute(m.pose, m.gain, m.bias_dn, {m.key_pitch_rad, m.key_roll_rad}, {m.pitch_rad, m.roll_rad},
                          m.height_ratio));
  // Heights against the true terrain at each cell's placed position (terrain relative to the
  // plane z = 0 of the camera's ground): median absolute error on confident cells.
  std::vector<double> err;
  int rocks_hit = 0;
  for (int i = 0; i < plx.height().rows; ++i)
    for (int j = 0; j < plx.height().cols; ++j) {
      const float z = plx.height().at<float>(i, j);
      if (!std::isfinite(z) || plx.confidence().at<float>(i, j) < 0.3f) continue;
      const double x = plx.x().at<float>(i, j), y = plx.y().at<float>(i, j);
      if (std::hypot(x, y) > 3.0) continue;
      const double t = rig.terrain.height_at(x, y);
      if (!std::isfinite(t)) continue;
      err.push_back(std::abs(z - t));
      if (t > 0.05 && std::abs(z - t) < 0.03) ++rocks_hit;
    }
  ASSERT_GT(err.size(), 2000u);
  std::nth_element(err.begin(), err.begin() + static_cast<long>(err.size() / 2), err.end());
  EXPECT_LT(err[err.size() / 2], 0.015);  // median |error| over 3 m, measured 12.5 mm
  EXPECT_GT(rocks_hit, 20);               // rock cells measured to 3 cm
  // Too short a baseline: nothing.
  EXPECT_FALSE(plx.compute(Pose2{0.1, 0, 0}, 1.0, 0.0));
  ParallaxParams bad;
  bad.uniqueness_ratio = 0.9;  // below 1 would keep nothing
  try {
    GroundParallax g(dd, bad);
    FAIL() << "no error";
  } catch (const FieldError& e) {
    EXPECT_NE(std::string(e.what()).find("uniqueness_ratio"), std::string::npos) << e.what();
  }
}

TEST(PlaneSweep, MeasuresRockHeightsAndFlatGroundFromTwoFrames) {
  Rig rig(5, 25);
  const direct_depth::DirectDepth dd(rig.model);
  GroundVisualOdometry vo(dd, GroundVoParams{});
  PlaneSweep sweep(dd, PlaneSweepParams{});
  const Pose2 a{0, 0, 0}, b{0.5, 0.01, 0.02};
  const cv::Mat fa = rig.frame(a), fb = rig.frame(b);
  vo.track(fa, {});
  vo.promote_last();
  sweep.set_frame(fa);
  sweep.promote();
  const VoMeasurement& m = vo.track(fb, between(a, b));
  ASSERT_TRUE(m.ok());
  sweep.set_frame(fb);
  ASSERT_TRUE(sweep.compute(m.pose, m.gain, m.bias_dn, {m.key_pitch_rad, m.key_roll_rad}, {m.pitch_rad, m.roll_rad},
                            m.height_ratio));
  EXPECT_GT(sweep.samples(), 0);
  // Heights against the true terrain at each pixel's placed position, within 3 m: median
  // absolute error over confident pixels, and rock pixels measured to 3 cm.
  std::vector<double> err;
  int rocks_hit = 0, rocks_seen = 0;
  for (int i = 0; i < sweep.height().rows; ++i)
    for (int j = 0; j < sweep.height().cols; ++j) {
      const float z = sweep.height().at<float>(i, j);
      if (!std::isfinite(z) || sweep.confidence().at<float>(i, j) < 0.05f) continue;
      const double x = sweep.x().at<float>(i, j), y = sweep.y().at<float>(i, j);
      if (std::hypot(x, y) > 3.0) continue;
      const double t = rig.terrain.height_at(x, y);
      if (!std::isfinite(t)) continue;
      err.push_back(std::abs(z - t));
      if (t > 0.05) ++rocks_seen, rocks_hit += std::abs(z - t) < 0.03;
    }
  ASSERT_GT(err.size(), 2000u);
  std::nth_element(err.begin(), err.begin() + static_cast<long>(err.size() / 2), err.end());
  EXPECT_LT(err[err.size() / 2], 0.015);  // median |error| within 3 m, measured 12.6 mm
  EXPECT_GT(rocks_hit, 20);
  EXPECT_GT(rocks_hit, rocks_seen / 2);
  // A narrower working width sweeps 2x2 block means: half-size outputs, still metric.
  PlaneSweepParams half;
  half.max_width_px = 160;
  PlaneSweep coarse(dd, half);
  EXPECT_EQ(coarse.scale(), 2);
  coarse.set_frame(fa);
  coarse.promote();
  coarse.set_frame(fb);
  ASSERT_TRUE(coarse.compute(m.pose, m.gain, m.bias_dn, {m.key_pitch_rad, m.key_roll_rad}, {m.pitch_rad, m.roll_rad},
                             m.height_ratio));
  ASSERT_EQ(coarse.height().cols, 160);
  std::vector<double> cerr;
  for (int i = 0; i < coarse.height().rows; ++i)
    for (int j = 0; j < coarse.height().cols; ++j) {
      const float z = coarse.height().at<float>(i, j);
      if (!std::isfinite(z) || coarse.confidence().at<float>(i, j) < 0.05f) continue;
      const double x = coarse.x().at<float>(i, j), y = coarse.y().at<float>(i, j);
      const double t = rig.terrain.height_at(x, y);
      if (std::hypot(x, y) <= 3.0 && std::isfinite(t)) cerr.push_back(std::abs(z - t));
    }
  ASSERT_GT(cerr.size(), 500u);
  std::nth_element(cerr.begin(), cerr.begin() + static_cast<long>(cerr.size() / 2), cerr.end());
  std::printf("plane sweep: median |error| %.4f m (scale 1), %.4f m (scale 2); rock pixels %d of %d within 3 cm\n",
              err[err.size() / 2], cerr[cerr.size() / 2], rocks_hit, rocks_seen);
  EXPECT_LT(cerr[cerr.size() / 2], 0.025);
  // Too short a baseline or a NaN pose: nothing, and nothing left from the last call.
  EXPECT_FALSE(sweep.compute(Pose2{0.1, 0, 0}, 1.0, 0.0));
  EXPECT_FALSE(sweep.compute(Pose2{std::nan(""), 0, 0}, 1.0, 0.0));
  EXPECT_EQ(cv::countNonZero(sweep.confidence() > 0), 0);
  // A frame of another size names the input; bad parameters name the field.
  EXPECT_THROW(sweep.set_frame(cv::Mat(10, 10, CV_8U, cv::Scalar(100))), FieldError);
  PlaneSweepParams bad;
  bad.window = 0;
  try {
    PlaneSweep s(dd, bad);
    FAIL() << "no error";
  } catch (const FieldError& e) {
    EXPECT_NE(std::string(e.what()).find("window"), std::string::npos) << e.what();
  }
}

TEST(PlaneSweep, AmbiguousMatchesOnSmoothGroundAreUnknownNotObstacles) {
  // The mocked rover's drive (mocks/terrain_scene drive tile at its defaults: smooth fractal
  // ground, 2 cm cells, no rock within 0.8 m of the path) seen by its front camera from two
  // positions 0.3 m apart. The low-contrast ripples repeat along the epipolar lines: without the
  // uniqueness test, pixels of the flat corridor ahead match a raised point 0.1-0.4 m high (the
  // false obstacle `regolith map` showed at the start of every mocked-rover recording); with it
  // they are unknown (a quarter of the corridor keeps a height: smooth ground is ambiguous for a
  // 5 x 5 window; the rectified parallax and the shading cue cover it in the map).
  terrain_scene::DrivePath path;
  path.duration_s = 10.0;
  const terrain_scene::Terrain tile = terrain_scene::make_drive_tile(path, terrain_scene::DriveTileParams{});
  terrain_scene::CameraPose cam;
  direct_depth::CameraModel model;
  std::tie(cam, model) = camera_320x240(200.0988, 0.5, 0.35);  // the mocked rover's front camera
  const direct_depth::DirectDepth dd(model);
  const terrain_scene::Sun sun{2.3, 0.6};
  auto frame = [&](double x, std::uint64_t seed) {
    cam.x_m = x;
    terrain_scene::RenderOptions ro;
    ro.noise_sigma = 0.005;
    ro.noise_seed = seed;
    return terrain_scene::to_u8(terrain_scene::render_camera(tile, cam, sun, ro).image);
  };
  const cv::Mat key = frame(0.0, 1), cur = frame(0.3, 2);
  int raised[2] = {0, 0}, known[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    PlaneSweepParams p;
    p.uniqueness_ratio = k == 0 ? 0.0 : PlaneSweepParams{}.uniqueness_ratio;
    PlaneSweep sweep(dd, p);
    sweep.set_frame(key);
    sweep.promote();
    sweep.set_frame(cur);
    ASSERT_TRUE(sweep.compute(Pose2{0.3, 0.0, 0.0}, 1.0, 0.0));
    for (int i = 0; i < sweep.height().rows; ++i)
      for (int j = 0; j < sweep.height().cols; ++j) {
        const float z = sweep.height().at<float>(i, j);
        const double x = sweep.x().at<float>(i, j), y = sweep.y().at<float>(i, j);
        if (!std::isfinite(z) || std::abs(y) > 0.6 || x > 4.0) continue;  // the clear corridor
        ++known[k];
        raised[k] += z > 0.1f;
      }
  }
  std::printf(
      "mocked drive corridor: %d of %d known pixels raised > 10 cm without the uniqueness test, %d of %d with it\n",
      raised[0], known[0], raised[1], known[1]);
  EXPECT_GT(raised[0], 50);
  EXPECT_LT(raised[1], raised[0] / 5);
  EXPECT_GT(known[1], known[0] / 8);  // measured: 3076 of 13436 pixels keep a height
  PlaneSweepParams bad;
  bad.uniqueness_ratio = 0.5;
  EXPECT_THROW(PlaneSweep(dd, bad), FieldError);
}

TEST(RockSightings, PixelScalesGrowWithTheImage) {
  const RockSightingParams ref;
  const RockSightingParams same = ref.scaled_to_width(RockSightingParams::kReferenceWidthPx);
  EXPECT_EQ(same.background_sigma_px, ref.background_sigma_px);
  EXPECT_EQ(same.min_pixels, ref.min_pixels);
  EXPECT_EQ(same.max_pixels, ref.max_pixels);
  EXPECT_EQ(same.row_band_px, ref.row_band_px);
  EXPECT_EQ(same.merge_gap_px, ref.merge_gap_px);
  // A camera up to max_width_px (480) wide is measured at its own size; a wider one in a working
  // frame halved until it is that narrow, for which its parameters are made.
  EXPECT_EQ(ref.reduction(320), 1);
  EXPECT_EQ(ref.reduction(480), 1);
  EXPECT_EQ(ref.reduction(640), 2);
  EXPECT_EQ(ref.reduction(1280), 4);
  EXPECT_EQ(ref.reduction(2048), 8);
  EXPECT_EQ(ref.scaled_to_width(640).background_sigma_px, ref.background_sigma_px);  // working frame 320 px
  EXPECT_EQ(ref.scaled_to_width(1280).min_pixels, ref.min_pixels);
  RockSightingParams full = ref;
  full.max_width_px = 0;
  EXPECT_EQ(full.reduction(4096), 1);
  const RockSightingParams wide = full.scaled_to_width(640);
  EXPECT_DOUBLE_EQ(wide.background_sigma_px, 2 * ref.background_sigma_px);  // lengths x2
  EXPECT_EQ(wide.row_band_px, 2 * ref.row_band_px);
  EXPECT_EQ(wide.min_pixels, 4 * ref.min_pixels);  // areas x4
  EXPECT_EQ(wide.max_pixels, 4 * ref.max_pixels);
  EXPECT_EQ(wide.merge_gap_px, 2 * ref.merge_gap_px);
  EXPECT_DOUBLE_EQ(wide.threshold, ref.threshold);         // not a pixel quantity
  EXPECT_NO_THROW(full.scaled_to_width(4096).validate());  // clamped to what validate() accepts
  EXPECT_NO_THROW(ref.scaled_to_width(16).validate());
  EXPECT_THROW(ref.scaled_to_width(0), FieldError);
  full.max_width_px = 8;
  EXPECT_THROW(full.validate(), FieldError);
}

TEST(RockSightings, RangesRocksSeenInOneFrame) {
  // Sightings from one rendered frame against the scene's exact rocks: at least 40 % of them lie
  // on a rock (within max(0.6 x its width, 0.10 m), the scoring rule of the drive maps), and most
  // of those have the rock's height to within a factor of two.
  Rig rig(11, 40);
  const direct_depth::DirectDepth dd(rig.model);
  RockSightings sightings(dd, RockSightingParams{});
  const cv::Mat f = rig.frame(Pose2{0, 0, 0});
  const int n = sightings.compute(f);
  ASSERT_GT(n, 2);
  int on_rock = 0, height_ok = 0;
  for (int k = 0; k < n; ++k) {
    const double x = sightings.x().at<float>(0, k), y = sightings.y().at<float>(0, k),
                 h = sightings.height().at<float>(0, k);
    EXPECT_GT(sightings.score().at<float>(0, k), 0.0f);
    EXPECT_GT(sightings.width().at<float>(0, k), 0.0f);
    for (const auto& r : rig.terrain.rocks()) {
      const double width = 2 * std::max(r.radius_x_m, r.radius_y_m);
      if (std::hypot(x - r.x_m, y - r.y_m) > std::max(0.6 * width, 0.10)) continue;
      ++on_rock;
      height_ok += h > 0.5 * r.height_m && h < 2.0 * r.height_m;
      break;
    }
  }
  std::printf("sightings %d, on a rock %d, height within x2 %d\n", n, on_rock, height_ok);
  EXPECT_GE(5 * on_rock, 2 * n);  // measured 8 of 14
  EXPECT_GE(on_rock, 5);
  EXPECT_GE(2 * height_ok, on_rock);
  EXPECT_TRUE(std::isnan(sightings.height().at<float>(0, n)) || n == sightings.height().cols);
  // A frame of another size names the input; an all-grey frame sights nothing.
  EXPECT_THROW(sightings.compute(cv::Mat(10, 10, CV_8U, cv::Scalar(100))), FieldError);
  EXPECT_EQ(sightings.compute(cv::Mat(240, 320, CV_8U, cv::Scalar(100))), 0);
  RockSightingParams bad;
  bad.threshold = 0;
  EXPECT_THROW(RockSightings(dd, bad), FieldError);
}

TEST(RockSightings, AWideFrameIsMeasuredHalvedAndReportedInCameraPixels) {
  // The same scene through a 640x480 camera (rendered at that size): measured in its 320x240
  // working frame (means of 2x2 pixels), the sightings stand on the scene's exact rocks as a
  // 320 px camera's do, while their image boxes and the object mask are the camera's.
  Rig rig(11, 40);
  rig.resize(640, 480, 440);
  const direct_depth::DirectDepth dd(rig.model);
  RockSightings sightings(dd, RockSightingParams{}.scaled_to_width(640));
  ASSERT_EQ(sightings.reduction(), 2);
  const cv::Mat f = rig.frame(Pose2{0, 0, 0});
  const int n = sightings.compute(f);
  ASSERT_GT(n, 2);
  EXPECT_EQ(sightings.mask().size(), cv::Size(320, 240));
  int on_rock = 0;
  for (int k = 0; k < n; ++k) {
    const double x = sightings.x().at<float>(0, k), y = sightings.y().at<float>(0, k);
    for (const auto& r : rig.terrain.rocks())
      if (std::hypot(x - r.x_m, y - r.y_m) <= std::max(1.2 * std::max(r.radius_x_m, r.radius_y_m), 0.10)) {
        ++on_rock;
        break;
      }
  }
  std::printf("640x480 frame: sightings %d, on a rock %d\n", n, on_rock);
  EXPECT_GE(5 * on_rock, 2 * n);  // measured 7 of 12 (the 320 px camera: 8 of 14)
  EXPECT_GE(on_rock, 5);
  // Boxes in camera pixels: a working pixel (c, r) covers camera pixels 2c..2c+1, 2r..2r+1.
  cv::Mat objects(480, 640, CV_8U), up;
  sightings.object_mask(objects, 0);
  cv::resize(sightings.mask(), up, objects.size(), 0, 0, cv::INTER_NEAREST);
  EXPECT_EQ(cv::countNonZero(up & ~objects), 0);  // every masked working pixel, 2x2 in the camera's
  for (int k = 0; k < n; ++k) {
    const auto at = [&](SightingRow r) { return static_cast<int>(sightings.table().at<float>(r, k)); };
    const cv::Rect box(at(kSightCol0), at(kSightRow0), at(kSightCol1) - at(kSightCol0) + 1,
                       at(kSightRow1) - at(kSightRow0) + 1);
    ASSERT_EQ(box & cv::Rect(0, 0, 640, 480), box);
    EXPECT_EQ(box.x % 2, 0);
    EXPECT_EQ(box.width % 2, 0);
    EXPECT_EQ(cv::countNonZero(objects(box)), box.area());
    // The blob's top and lowest (contact) rows are the box's first and last.
    EXPECT_GT(cv::countNonZero(up(cv::Rect(box.x, box.y, box.width, 1))), 0);
    EXPECT_GT(cv::countNonZero(up(cv::Rect(box.x, box.y + box.height - 1, box.width, 1))), 0);
  }
  cv::Mat small(240, 320, CV_8U);
  EXPECT_THROW(sightings.object_mask(small, 0), FieldError);  // the camera's size, not the working one
  EXPECT_THROW(sightings.compute(cv::Mat(240, 320, CV_8U, cv::Scalar(100))), FieldError);
  // An odd-sized camera: the last row and column are left out of the halving, and out of the mask.
  rig.resize(641, 481, 440);
  const direct_depth::DirectDepth odd_dd(rig.model);
  RockSightings odd(odd_dd, RockSightingParams{}.scaled_to_width(641));
  const int n_odd = odd.compute(rig.frame(Pose2{0, 0, 0}));
  EXPECT_GE(n_odd, n - 2);  // the same scene, half a pixel wider
  cv::Mat odd_objects(481, 641, CV_8U);
  odd.object_mask(odd_objects, 2);
  EXPECT_EQ(cv::countNonZero(odd_objects.row(480)), 0);
  for (int k = 0; k < n_odd; ++k) {
    EXPECT_LE(odd.table().at<float>(kSightCol1, k), 639.0f);
    EXPECT_LE(odd.table().at<float>(kSightRow1, k), 479.0f);
  }
  // A camera too flat to halve that often (8192 x 8: 32x to 256 px wide leaves no row) names the field.
  direct_depth::CameraModel flat = rig.model;
  flat.width = 8192, flat.height = 8, flat.cx = 4095.5, flat.cy = 3.5;
  const direct_depth::DirectDepth flat_dd(flat);
  try {
    RockSightings refused(flat_dd, RockSightingParams{});
    ADD_FAILURE() << "an 8192x8 camera was accepted";
  } catch (const FieldError& e) {
    EXPECT_NE(std::string(e.what()).find("max_width_px"), std::string::npos) << e.what();
  }
}

// Featureless textured ground for synthetic sightings: 320x240 grey 120 +- sigma (normal noise).
cv::Mat noisy_ground(int seed, double sigma) {
  cv::Mat f(240, 320, CV_8U);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(f, cv::RNG::NORMAL, 120, sigma);
  return f;
}

TEST(RockSightings, ARockCutByTheTopEdgeIsSightedWithItsContact) {
  // Far rocks enter a pitched camera's view through the top edge: their ground contact is in the
  // frame, their top is not. Textured grey ground with one dark object over rows 0..14: it is
  // sighted at the ground range of its lowest row, with a height that is a lower bound (the
  // visible part); with keep_top_cut false it is refused like any blob touching the border.
  Rig rig(11, 0);
  const direct_depth::DirectDepth dd(rig.model);
  cv::Mat f = noisy_ground(5, 6);
  f(cv::Rect(150, 0, 24, 15)).setTo(25);
  RockSightings kept(dd, RockSightingParams{});
  ASSERT_EQ(kept.compute(f), 1);
  // Contact: row 14 (lower pixel edge 14.5), column 161.5 (the object's middle): its flat-ground
  // point, pushed back by the footprint radius (at least half the width).
  const direct_depth::GroundPoint g = dd.ground(161.5, 14.5);
  ASSERT_TRUE(g.valid);
  const double x = kept.x().at<float>(0, 0), y = kept.y().at<float>(0, 0), h = kept.height().at<float>(0, 0);
  const double w = kept.width().at<float>(0, 0);
  std::printf("top-cut sighting at %.2f %.2f m (contact %.2f m), height >= %.2f m, width %.2f m\n", x, y, g.range_m, h,
              w);
  EXPECT_GT(x, g.range_m);
  EXPECT_LT(x, g.range_m + std::max(0.5 * w, h) + 0.02);
  EXPECT_NEAR(y, g.lateral_m, 0.05);
  EXPECT_NEAR(w, 24 * g.slant_m / 220.0, 0.05);  // 24 columns at that distance
  EXPECT_GT(h, 0.07);
  RockSightingParams refuse;
  refuse.keep_top_cut = false;
  RockSightings refused(dd, refuse);
  EXPECT_EQ(refused.compute(f), 0);
}

TEST(RockSightings, ASideLitRocksTwoHalvesMergeIntoOne) {
  // A rock lit from one side: its bright half is brighter than the ground, its shaded half
  // darker, and the mid-tone line between them contrasts with nothing: two blobs side by side.
  // merge_halves makes them one sighting as wide as both; off (the map's default) they stay two.
  Rig rig(11, 0);
  const direct_depth::DirectDepth dd(rig.model);
  cv::Mat f = noisy_ground(9, 5);
  f(cv::Rect(140, 40, 16, 20)).setTo(220);  // lit half, ~2 m ahead
  f(cv::Rect(158, 40, 16, 20)).setTo(30);   // shaded half, a 2 px mid-tone seam between
  f(cv::Rect(156, 40, 2, 20)).setTo(120);
  RockSightingParams apart;
  RockSightings two(dd, apart);
  ASSERT_EQ(two.compute(f), 2);
  RockSightingParams joined;
  joined.merge_halves = true;
  RockSightings one(dd, joined);
  ASSERT_EQ(one.compute(f), 1);
  const double w = one.width().at<float>(0, 0), w0 = two.width().at<float>(0, 0), w1 = two.width().at<float>(0, 1);
  std::printf("halves %.3f + %.3f m wide, merged %.3f m\n", w0, w1, w);
  EXPECT_NEAR(w, w0 + w1, 0.25 * (w0 + w1));
  EXPECT_EQ(one.row(kSightCol0).at<float>(0, 0), 140.0f);
  EXPECT_EQ(one.row(kSightCol1).at<float>(0, 0), 173.0f);
  EXPECT_TRUE(std::isnan(one.height().at<float>(0, 1)));
  // Two rocks one above the other (no vertical overlap) are not merged.
  cv::Mat g = noisy_ground(10, 5);
  g(cv::Rect(140, 20, 16, 16)).setTo(220);
  g(cv::Rect(140, 70, 16, 16)).setTo(220);
  EXPECT_EQ(one.compute(g), 2);
}

TEST(RockSightings, WithTheSunBehindTheTopRayGrazesTheSilhouetteNotTheApex) {
  // A dark object ~0.8 m ahead (a steep view): its top ray passes over the centre at h_ray. With the sun behind
  // or beside the camera a dome's far flank is darker than the ground and the blob's top is the
  // silhouette, which lies beyond the apex: the height is the half-ellipsoid's the ray grazes,
  // sqrt(h_ray^2 - (a tan alpha)^2) (a: the footprint radius, which also moves the centre the
  // ray is read over), never below 0.75 h_ray cos alpha. With the sun ahead (lit
  // flank), or no sun given, the top ray's height stands.
  Rig rig(11, 0);
  const direct_depth::DirectDepth dd(rig.model);
  cv::Mat f = noisy_ground(7, 5);
  f(cv::Rect(150, 170, 24, 30)).setTo(30);
  RockSightingParams near;
  near.min_range_m = 0.3;
  RockSightings s(dd, near);
  const auto height = [&](const cv::Vec3d& sun) {
    EXPECT_EQ(s.compute(f, {}, sun), 1);
    return static_cast<double>(s.height().at<float>(0, 0));
  };
  const double h_ray = height({});
  const double ahead = height({1.0, 0.2, 0.8}), behind = height({-1.0, 0.3, 0.8}), beside = height({0.0, 1.0, 0.5});
  // The top row's ray (row 170, upper pixel edge 169.5) and its depression.
  const direct_depth::GroundPoint top = dd.ground(161.5, 169.5);
  ASSERT_TRUE(top.valid);
  const double tan_alpha = dd.model().mount_height_m / top.range_m, cos_alpha = 1.0 / std::hypot(1.0, tan_alpha);
  std::printf("top ray %.3f m over the centre; sun ahead %.3f, behind %.3f, beside %.3f m (alpha %.1f deg)\n", h_ray,
              ahead, behind, beside, std::atan(tan_alpha) * 180 / 3.14159265358979);
  EXPECT_GT(h_ray, 0.05);
  EXPECT_DOUBLE_EQ(ahead, h_ray);
  EXPECT_LT(behind, h_ray - 0.005);  // measured 0.106 against 0.115
  EXPECT_GE(behind, 0.75 * h_ray * cos_alpha - 0.01);
  EXPECT_LT(beside, h_ray);
  // Off: the top ray's height whatever the sun; a sun that is not finite names the input.
  RockSightingParams off = near;
  off.silhouette_height = false;
  RockSightings plain(dd, off);
  ASSERT_EQ(plain.compute(f, {}, {-1.0, 0.3, 0.8}), 1);
  EXPECT_DOUBLE_EQ(plain.height().at<float>(0, 0), h_ray);
  EXPECT_THROW(s.compute(f, {}, {std::nan(""), 0.0, 1.0}), FieldError);
  RockSightingParams bad;
  bad.silhouette_floor = 1.5;
  EXPECT_THROW(RockSightings(dd, bad), FieldError);
}

// A 0.1 m world map window of lx by ly metres, and the cell (column, row) at world (wx, wy) in it.
WorldMapParams small_window(double lx, double ly) {
  WorldMapParams p;
  p.resolution_m = 0.1;
  p.length_x_m = lx;
  p.length_y_m = ly;
  return p;
}
cv::Point cell_of(const WorldMap& map, double wx, double wy) {
  return cv::Point(static_cast<int>(std::lround((wx - map.origin_x()) / map.resolution())),
                   static_cast<int>(std::lround((wy - map.origin_y()) / map.resolution())));
}
float layer_at(const WorldMap& map, const char* layer, double wx, double wy) {
  return map.layer(layer).at<float>(cell_of(map, wx, wy));
}

TEST(WorldMap, FusesWeightedLooksAndRecentersWithoutLosingCells) {
  WorldMapParams p = small_window(4, 4);
  WorldMap map(p, 0, 0);
  cv::Mat x(1, 2, CV_32F), y(1, 2, CV_32F), z(1, 2, CV_32F), w(1, 2, CV_32F);
  x.at<float>(0) = 1.0f, y.at<float>(0) = 0.0f, z.at<float>(0) = 0.10f, w.at<float>(0) = 1.0f;
  x.at<float>(1) = 1.0f, y.at<float>(1) = 0.0f, z.at<float>(1) = 0.20f, w.at<float>(1) = 3.0f;
  // Foot at (0.5, 0.5) facing +y: body (1, 0) is world (0.5, 1.5).
  EXPECT_EQ(map.fuse_points(x, y, z, w, Pose2{0.5, 0.5, 1.5707963267948966}), 2);
  map.finish();
  auto at = [&](const char* layer, double wx, double wy) { return layer_at(map, layer, wx, wy); };
  EXPECT_NEAR(at("elevation", 0.5, 1.5), 0.175, 1e-6);  // (0.1 * 1 + 0.2 * 3) / 4
  EXPECT_EQ(at("observed_count", 0.5, 1.5), 2.0f);
  EXPECT_GT(at("elevation_variance", 0.5, 1.5), 0.0f);
  EXPECT_TRUE(std::isnan(at("elevation", -1.0, -1.0)));
  // A NaN pose is never fused.
  EXPECT_EQ(map.fuse_points(x, y, z, w, Pose2{std::nan(""), 0, 0}), 0);
  // Driving 1.5 m north moves the window; the fused cell stays at its world position.
  map.recenter(0.0, 1.5, 1.0);
  map.finish();
  EXPECT_NEAR(map.origin_y(), -1.95 + 1.5, 1e-9);
  EXPECT_NEAR(at("elevation", 0.5, 1.5), 0.175, 1e-6);
}

TEST(WorldMap, AFaintLookGivesAnElevationButNoReliefOrHazard) {
  // One cell seen well, one seen once, faintly (weight between min_weight and
  // hazard_min_weight): both have an elevation; only the first has a relief and a hazard.
  WorldMapParams p = small_window(4, 4);
  ASSERT_LT(p.min_weight, p.hazard_min_weight);
  WorldMap map(p, 0, 0);
  cv::Mat x(1, 2, CV_32F), y(1, 2, CV_32F), z(1, 2, CV_32F), w(1, 2, CV_32F);
  x.at<float>(0) = 1.0f, y.at<float>(0) = 0.0f, z.at<float>(0) = 0.20f, w.at<float>(0) = 1.0f;
  x.at<float>(1) = 1.0f, y.at<float>(1) = 0.5f, z.at<float>(1) = 0.20f, w.at<float>(1) = 0.03f;  // x 1/(1 + (r/2)^2)
  EXPECT_EQ(map.fuse_points(x, y, z, w, Pose2{0.0, 0.0, 0.0}), 2);
  map.finish();
  auto at = [&](const char* layer, double wx, double wy) { return layer_at(map, layer, wx, wy); };
  EXPECT_NEAR(at("elevation", 1.0, 0.0), 0.20, 1e-6);
  EXPECT_TRUE(std::isfinite(at("relief", 1.0, 0.0)));
  EXPECT_TRUE(std::isfinite(at("hazard", 1.0, 0.0)));
  EXPECT_NEAR(at("elevation", 1.0, 0.5), 0.20, 1e-6);
  EXPECT_LT(at("confidence", 1.0, 0.5), 0.05f);
  EXPECT_TRUE(std::isnan(at("relief", 1.0, 0.5)));
  EXPECT_TRUE(std::isnan(at("hazard", 1.0, 0.5)));
  WorldMapParams bad = p;
  bad.hazard_min_weight = -1;
  EXPECT_THROW(bad.validate(), std::exception);
}

TEST(WorldMap, OneMismatchedCellDoesNotStandOutButARockDoes) {
  // Flat ground at 0 in every 4 cm cell of a 0.8 m patch, one cell 0.2 m up (one look matched on the
  // wrong texture) and a rock 0.12 m high and 5 x 5 cells (20 cm) wide. With the default 3 x 3
  // median of the known cells the lone cell takes its neighbours' ground (no relief, no hazard of
  // its own) while the rock keeps its height but for its corner cells; off, the lone cell stands
  // 0.2 m up. The fused means are kept: finishing twice gives the same layers.
  for (const double median : {WorldMapParams{}.elevation_median_m, 0.0}) {
    WorldMapParams p = small_window(2, 2);
    p.resolution_m = 0.04;
    p.elevation_median_m = median;
    p.hazard_blur_m = 0;  // each cell's own hazard
    WorldMap map(p, 0, 0);
    const cv::Point lone = cell_of(map, 0.4, 0.2), rock = cell_of(map, 0.6, -0.1);
    std::vector<cv::Vec3f> pts;
    for (int i = cell_of(map, 0.2, -0.4).y; i <= cell_of(map, 0.96, 0.4).y; ++i)  // ahead of the foot at (0, 0)
      for (int j = cell_of(map, 0.2, -0.4).x; j <= cell_of(map, 0.96, 0.4).x; ++j) {
        const cv::Point2d c = map.cell_center(i, j);
        const bool on_rock = std::abs(j - rock.x) <= 2 && std::abs(i - rock.y) <= 2;
        const float z = cv::Point(j, i) == lone ? 0.2f : on_rock ? 0.12f : 0.0f;
        pts.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y), z);
      }
    const int n = static_cast<int>(pts.size());
    cv::Mat x(1, n, CV_32F), y(1, n, CV_32F), z(1, n, CV_32F), w(1, n, CV_32F, cv::Scalar(1));
    for (int k = 0; k < n; ++k) x.at<float>(k) = pts[k][0], y.at<float>(k) = pts[k][1], z.at<float>(k) = pts[k][2];
    ASSERT_EQ(map.fuse_points(x, y, z, w, Pose2{}), n);
    for (int pass = 0; pass < 2; ++pass) {
      map.finish();
      const cv::Mat& el = map.layer("elevation");
      const auto at = [&](cv::Point c, int dx = 0, int dy = 0) { return el.at<float>(c + cv::Point(dx, dy)); };
      EXPECT_NEAR(at(rock), 0.12f, 1e-6) << median;
      EXPECT_NEAR(at(rock, 2, 0), 0.12f, 1e-6) << "an edge cell of the rock, " << median;
      EXPECT_NEAR(at(rock, 3, 0), 0.0f, 1e-6) << "beside the rock, " << median;
      if (median > 0) {
        EXPECT_NEAR(at(lone), 0.0f, 1e-6) << pass;
        EXPECT_NEAR(at(rock, 2, 2), 0.0f, 1e-6) << "a corner cell: 4 of its 9 on the rock";
        EXPECT_LT(map.layer("hazard").at<float>(lone), 0.01f);
      } else {
        EXPECT_NEAR(at(lone), 0.2f, 1e-6) << pass;
        EXPECT_NEAR(at(rock, 2, 2), 0.12f, 1e-6);
        EXPECT_GT(map.layer("hazard").at<float>(lone), 0.1f);
      }
    }
  }
  WorldMapParams bad;
  bad.elevation_median_m = -0.04;
  try {
    bad.validate();
    FAIL() << "a negative median window was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("elevation_median_m"), std::string::npos) << e.what();
  }
  // A map finer than the window asks for (0.04 m at 5 mm cells: 8) takes the largest window there
  // is (3 cells), so every resolution the mapper accepts still configures with the defaults.
  WorldMapParams fine = small_window(2, 2);
  fine.resolution_m = 0.005;
  EXPECT_NO_THROW(fine.validate());
  EXPECT_NO_THROW(WorldMap(fine, 0, 0).finish());
}

TEST(WorldMap, AFilledHoleTakesTheLocalGroundNotTheRockBesideIt) {
  // Flat ground at 0 seen everywhere on a 2 m patch but one cell, which a 0.3 m rock top borders
  // on one side. Filled (fill_radius_m): the hole takes the local ground (a neighbour average
  // would take a third of the rock), with a lowered confidence and no relief or hazard of its
  // own; a hole far from anything seen stays unknown. Off (the default): the hole stays unknown.
  for (const double fill : {0.0, 0.12}) {
    WorldMapParams p = small_window(4, 4);
    p.fill_radius_m = fill;
    WorldMap map(p, 0, 0);
    std::vector<cv::Vec3f> pts;
    for (int a = 1; a <= 19; ++a)  // ahead of the camera's foot (x > 0), inside the window
      for (int b = -10; b <= 10; ++b) {
        const float x = 0.1f * static_cast<float>(a), y = 0.1f * static_cast<float>(b);
        if (a == 10 && b == 0) continue;  // the hole at (1.0, 0)
        pts.emplace_back(x, y, a == 11 && std::abs(b) <= 1 ? 0.3f : 0.0f);
      }
    const int n = static_cast<int>(pts.size());
    cv::Mat x(1, n, CV_32F), y(1, n, CV_32F), z(1, n, CV_32F), w(1, n, CV_32F, cv::Scalar(1));
    for (int k = 0; k < n; ++k) x.at<float>(k) = pts[k][0], y.at<float>(k) = pts[k][1], z.at<float>(k) = pts[k][2];
    ASSERT_EQ(map.fuse_points(x, y, z, w, Pose2{}), n);
    map.finish();
    EXPECT_TRUE(std::isnan(layer_at(map, "elevation", -1.5, -1.5))) << fill;
    EXPECT_NEAR(layer_at(map, "elevation", 1.1, 0.0), 0.3, 1e-6);
    if (fill == 0.0) {
      EXPECT_TRUE(std::isnan(layer_at(map, "elevation", 1.0, 0.0)));
      continue;
    }
    const float hole = layer_at(map, "elevation", 1.0, 0.0);
    ASSERT_TRUE(std::isfinite(hole));
    EXPECT_LT(std::abs(hole), 0.03f) << "the local ground, not the rock's top";
    EXPECT_GT(layer_at(map, "confidence", 1.0, 0.0), 0.0f);
    EXPECT_LE(layer_at(map, "confidence", 1.0, 0.0), 0.5f);
    EXPECT_TRUE(std::isnan(layer_at(map, "relief", 1.0, 0.0)));
    EXPECT_TRUE(std::isnan(layer_at(map, "hazard", 1.0, 0.0)));
    EXPECT_TRUE(std::isfinite(layer_at(map, "hazard", 1.1, 0.0)));  // the rock itself is assessed
  }
}

TEST(WorldMap, RecenteringKeepsEveryCellAtItsWorldPositionInAnyDirection) {
  // A distinct height in every cell, then shifts with both signs on both axes (and one larger than
  // the window): each cell still inside keeps its value, every cell that came in is unknown.
  WorldMapParams p = small_window(3, 2);
  WorldMap map(p, 0, 0);
  const int n = 30 * 20;
  cv::Mat x(1, n, CV_32F), y(1, n, CV_32F), z(1, n, CV_32F), w(1, n, CV_32F, cv::Scalar(1));
  for (int k = 0; k < n; ++k) {
    x.at<float>(k) = static_cast<float>(map.origin_x() + (k % 30) * 0.1);
    y.at<float>(k) = static_cast<float>(map.origin_y() + (k / 30) * 0.1);
    z.at<float>(k) = 0.001f * static_cast<float>(k);
  }
  map.fuse_points(x, y, z, w, Pose2{});
  map.finish();
  cv::Mat before = map.layer("elevation").clone();
  double ox = map.origin_x(), oy = map.origin_y();
  for (const cv::Point2d to : {cv::Point2d{0.73, -0.48}, {-1.21, 0.35}, {0.3, 0.9}, {9.0, -9.0}}) {
    map.recenter(to.x, to.y, 0.9);
    map.finish();
    const cv::Mat& after = map.layer("elevation");
    const int dj = static_cast<int>(std::lround((map.origin_x() - ox) / 0.1)),
              di = static_cast<int>(std::lround((map.origin_y() - oy) / 0.1));
    SCOPED_TRACE(::testing::Message() << "shift " << di << ", " << dj);
    EXPECT_TRUE(di != 0 || dj != 0);
    int kept = 0;
    for (int i = 0; i < after.rows; ++i)
      for (int j = 0; j < after.cols; ++j) {
        const int si = i + di, sj = j + dj;
        const bool inside = si >= 0 && sj >= 0 && si < before.rows && sj < before.cols;
        const float v = after.at<float>(i, j), u = inside ? before.at<float>(si, sj) : std::nanf("");
        if (std::isnan(u)) {
          EXPECT_TRUE(std::isnan(v)) << i << " " << j;
          continue;
        }
        EXPECT_FLOAT_EQ(v, u) << i << " " << j;
        ++kept;
      }
    if (std::abs(di) < before.rows && std::abs(dj) < before.cols) {
      EXPECT_GT(kept, 0);
    }
    after.copyTo(before);
    ox = map.origin_x(), oy = map.origin_y();
  }
}

// A rendered drive with drifting wheel odometry and a body that wobbles (pitch, roll).
struct DriveRun {
  Pose2 truth, wheel, est;
  double path = 0;
  DriveCounters counters;
  std::vector<double> mahalanobis2;  ///< per frame after the first: position error^2 in the published covariance
  std::vector<double> heading_z;     ///< per frame after the first: heading error / its published sigma
};
DriveRun run_rendered_drive(std::uint64_t seed, bool vision, int black_frame = -1, int jump_frame = -1,
                            DriveMapperParams p = {}) {
  Rig rig(seed, 20);
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::normal_distribution<double> nd(0, 1);
  p.use_vision = vision;
  p.map.length_x_m = p.map.length_y_m = 10;
  DriveMapper dm(rig.model, CameraMount{}, rig.sun.vector(), p, {1.5, 0});
  DriveRun r;
  for (int k = 0; k < 30; ++k) {
    if (k) {
      const Pose2 step{0.06, 0.0, 0.004 * std::sin(k * 0.2)};
      r.truth = compose(r.truth, step);
      r.path += 0.06;
      r.wheel = compose(r.wheel, Pose2{0.06 * 1.015 + 0.0003 * nd(rng), 0, step.yaw + 0.0008 + 0.0003 * nd(rng)});
    }
    cv::Mat img =
        rig.frame(r.truth, 0.004 * std::sin(k * 0.3), 0.006 * std::cos(k * 0.25), static_cast<std::uint64_t>(k));
    if (k == black_frame) img = cv::Mat(240, 320, CV_8U, cv::Scalar(0));
    Pose2 odo = r.wheel;
    if (k == jump_frame) odo.x += 3.0;
    const FrameReport& f = dm.add_frame(img, odo);
    EXPECT_TRUE(f.pose.finite()) << k;
    EXPECT_TRUE(f.covariance.allFinite()) << k;
    if (k) {
      const Eigen::Vector2d e(f.pose.x - r.truth.x, f.pose.y - r.truth.y);
      r.mahalanobis2.push_back(e.dot(f.covariance.topLeftCorner<2, 2>().inverse() * e));
      r.heading_z.push_back(wrap_angle(f.pose.yaw - r.truth.yaw) / std::sqrt(f.covariance(2, 2)));
    }
  }
  r.est = dm.pose();
  r.counters = dm.counters();
  return r;
}

// One sighting as RockSightings reports it: a rock whose near contact is at `contact` (world,
// z above the ground plane the camera stands over) and whose top is `top_z` above that plane,
// seen by a camera `h` high at `foot` (world pose, x forward): the contact ray is met with the
// plane z = 0, as one frame has to.
void sight(cv::Mat& t, int k, const Pose2& foot, double h, const cv::Vec3d& contact, double top_z, double width,
           double radius, double score = 1.0) {
  const Eigen::Vector2d b = inverse(foot).apply(contact[0], contact[1]);  // body frame
  const double r = b.norm(), s = h / (h - contact[2]);                    // the ray meets z = 0 at s x the body point
  const Eigen::Vector2d g = s * b, u = b / r;
  const Eigen::Vector2d c = g + radius * u;
  // Top ray: towards the point top_z high at the true centre's distance.
  const double slope = (top_z - h) / (r + radius);
  const double single_h = h + c.norm() * slope;
  for (auto [row, v] : {std::pair{kSightX, c.x()},
                        {kSightY, c.y()},
                        {kSightHeight, single_h},
                        {kSightWidth, width},
                        {kSightScore, score},
                        {kSightSigmaRange, 0.1},
                        {kSightSigmaLateral, 0.03},
                        {kSightContactX, g.x()},
                        {kSightContactY, g.y()},
                        {kSightTopSlope, slope}})
    t.at<float>(row, k) = static_cast<float>(v);
}

TEST(RockTracker, TriangulatesAContactOffTheGroundPlaneAcrossFrames) {
  // A rock 0.15 m tall on ground 5 cm above the plane under the rover, 4 m ahead and 0.5 m
  // aside: one frame puts it 0.3 m too far; 16 exact frames approaching over 1.5 m put it
  // right (rays as sharp as exact data; with the default ray sigmas the ground prior holds it
  // back: half way).
  const double h = 0.6, radius = 0.1;
  const cv::Vec3d contact(4.0, 0.5, 0.05);
  RockTrackerParams sharp;
  sharp.ray_sigma_m = 0.002;
  sharp.ray_sigma_per_m = 0.001;
  RockTracker tracker(sharp, 8), loose(RockTrackerParams{}, 8);
  cv::Mat t(kSightRows, 8, CV_32F);
  double first_error = 0.0;
  for (int f = 0; f <= 15; ++f) {
    t.setTo(std::numeric_limits<float>::quiet_NaN());
    const Pose2 foot{0.1 * f, 0.0, 0.0};
    sight(t, 0, foot, h, contact, 0.05 + 0.15, 0.2, radius);
    ASSERT_EQ(tracker.update(t, foot, h), 1) << f;
    ASSERT_EQ(loose.update(t, foot, h), 1) << f;
    ASSERT_EQ(tracker.count(), 1) << "frame " << f << ": one rock is one track";
    ASSERT_EQ(loose.count(), 1) << f;
    const double ex = tracker.table().at<float>(kTrackX, 0) - (contact[0] + radius);
    if (f == 0) first_error = ex;
  }
  const cv::Mat& r = tracker.table();
  EXPECT_GT(first_error, 0.25);
  EXPECT_NEAR(r.at<float>(kTrackX, 0), contact[0] + radius, 0.03);
  EXPECT_NEAR(r.at<float>(kTrackY, 0), contact[1], 0.03);
  EXPECT_NEAR(r.at<float>(kTrackHeight, 0), 0.15, 0.015);
  EXPECT_NEAR(r.at<float>(kTrackWidth, 0), 0.2, 1e-5);
  EXPECT_NEAR(r.at<float>(kTrackScore, 0), 16.0, 1e-4);
  EXPECT_EQ(r.at<float>(kTrackFrames, 0), 16.0f);
  EXPECT_LT(r.at<float>(kTrackSxx, 0), 0.005f);
  EXPECT_GT(loose.table().at<float>(kTrackSxx, 0), r.at<float>(kTrackSxx, 0));
  EXPECT_EQ(tracker.closed_count(), 0);
  const double loose_error = loose.table().at<float>(kTrackX, 0) - (contact[0] + radius);
  EXPECT_GT(loose_error, 0.02);
  EXPECT_LT(loose_error, 0.7 * first_error);
  // The covariance to report adds what all 16 frames share: along the nearest frame's view (from
  // the last foot, 1.5 m, to the rock) the far-ground tilt and height errors, (R^2 + h^2) / h x 0.02
  // and R / h x 0.03 (R = 2.78 m, that frame's ground range of the contact, met on the plane), and
  // a quarter of the width; across it the sighting's lateral sigma (0.03) and half the footprint
  // radius (the height, 0.15 m, exceeds the sighted radius, 0.1 m).
  const double range = std::hypot(2.5, 0.5) * h / (h - contact[2]);
  const double along = std::hypot((range * range + h * h) / h * 0.02, range / h * 0.03, 0.05);
  const double across = std::hypot(0.03, 0.5 * 0.15);
  const cv::Mat& lt = loose.table();
  const double dxx = lt.at<float>(kTrackPosXx, 0) - lt.at<float>(kTrackSxx, 0);
  const double dxy = lt.at<float>(kTrackPosXy, 0) - lt.at<float>(kTrackSxy, 0);
  const double dyy = lt.at<float>(kTrackPosYy, 0) - lt.at<float>(kTrackSyy, 0);
  const double mid = 0.5 * (dxx + dyy), rad = std::hypot(0.5 * (dxx - dyy), dxy);
  EXPECT_NEAR(std::sqrt(mid + rad), along, 0.03 * along);
  EXPECT_NEAR(std::sqrt(mid - rad), across, 0.1 * across);
  const double axis = 0.5 * std::atan2(2 * dxy, dxx - dyy), view = std::atan2(0.5, 4.1 - 1.5);
  EXPECT_NEAR(axis, view, 0.02) << "the long axis lies along the view";
}

TEST(RockTracker, KeepsRocksApartClosesStaleTracksAndRefusesBadParameters) {
  const double h = 0.6;
  RockTrackerParams p;
  p.max_age_frames = 3;
  RockTracker tracker(p, 8);
  cv::Mat t(kSightRows, 8, CV_32F);
  // Two rocks side by side, 0.5 m apart, for 5 frames; then nothing.
  for (int f = 0; f < 5; ++f) {
    t.setTo(std::numeric_limits<float>::quiet_NaN());
    const Pose2 foot{0.1 * f, 0.0, 0.0};
    sight(t, 0, foot, h, {3.0, -0.25, 0.0}, 0.12, 0.15, 0.07);
    sight(t, 1, foot, h, {3.0, 0.25, 0.0}, 0.12, 0.15, 0.07);
    EXPECT_EQ(tracker.update(t, foot, h), 2);
    EXPECT_EQ(tracker.count(), 2) << f;
  }
  t.setTo(std::numeric_limits<float>::quiet_NaN());
  for (int f = 0; f < 2; ++f) EXPECT_EQ(tracker.update(t, {0.5, 0.0, 0.0}, h), 0);
  EXPECT_EQ(tracker.count(), 2);
  EXPECT_EQ(tracker.closed_count(), 0);
  tracker.update(t, {0.5, 0.0, 0.0}, h);  // third frame unseen: both close, handed over once
  EXPECT_EQ(tracker.count(), 0);
  ASSERT_EQ(tracker.closed_count(), 2);
  const float y0 = tracker.closed().at<float>(kTrackY, 0), y1 = tracker.closed().at<float>(kTrackY, 1);
  EXPECT_NEAR(std::min(y0, y1), -0.25, 0.02);
  EXPECT_NEAR(std::max(y0, y1), 0.25, 0.02);
  EXPECT_EQ(tracker.closed().at<float>(kTrackFrames, 0), 5.0f);
  tracker.update(t, {0.5, 0.0, 0.0}, h);
  EXPECT_EQ(tracker.closed_count(), 0);
  // A NaN pose uses nothing; tracking off closes every sighting at once (one-frame tracks).
  sight(t, 0, {}, h, {3.0, 0.0, 0.0}, 0.12, 0.15, 0.07);
  EXPECT_EQ(tracker.update(t, Pose2{std::nan(""), 0, 0}, h), 0);
  RockTrackerParams off;
  off.enabled = false;
  RockTracker single(off, 8);
  EXPECT_EQ(single.update(t, {}, h), 1);
  EXPECT_EQ(single.count(), 0);
  EXPECT_EQ(single.closed_count(), 1);
  // When every slot is taken the track unseen longest closes for the newcomer.
  RockTrackerParams two;
  two.max_tracks = 2;
  RockTracker small(two, 8);
  for (double y : {-1.0, 0.0, 1.0}) {
    t.setTo(std::numeric_limits<float>::quiet_NaN());
    sight(t, 0, {}, h, {3.0, y, 0.0}, 0.12, 0.15, 0.07);
    small.update(t, {}, h);
  }
  EXPECT_EQ(small.count(), 2);
  ASSERT_EQ(small.closed_count(), 1);
  EXPECT_NEAR(small.closed().at<float>(kTrackY, 0), -1.0, 0.03);
  for (int bad = 0; bad < 4; ++bad) {
    RockTrackerParams q;
    (bad == 0 ? q.max_tracks : q.max_age_frames) = 0;
    if (bad == 2) q.ground_sigma_m = 0, q.max_age_frames = 1;
    if (bad == 3) q.gate = -1, q.max_age_frames = 1;
    EXPECT_THROW(RockTracker(q, 8), FieldError) << bad;
  }
}

TEST(WorldMap, TrackedRocksBecomeRocksAndHazard) {
  WorldMapParams p;
  p.resolution_m = 0.04;
  p.length_x_m = 8;
  p.length_y_m = 8;
  p.hazard_blur_m = 0;  // each cell's own hazard (the blur: TheHazardIsAveragedOverTheKnownCellsAroundIt)
  WorldMap map(p, 0, 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat live(kTrackRows, 4, CV_32F, cv::Scalar(nan)), closed(kTrackRows, 4, CV_32F, cv::Scalar(nan));
  auto set = [](cv::Mat& t, int k, double x, double y, double h, double w, double score, double sd, int frames) {
    for (auto [row, v] : {std::pair{kTrackX, x},
                          {kTrackY, y},
                          {kTrackHeight, h},
                          {kTrackWidth, w},
                          {kTrackScore, score},
                          {kTrackSxx, sd * sd},
                          {kTrackSxy, 0.0},
                          {kTrackSyy, sd * sd},
                          {kTrackFrames, double(frames)}})
      t.at<float>(row, k) = static_cast<float>(v);
  };
  // A closed track (kept for good), a live one, a live one seen in too few frames.
  set(closed, 0, 1.0, 1.0, 0.2, 0.25, 4.0, 0.03, 6);
  set(live, 0, 0.0, 2.0, 0.12, 0.2, 3.0, 0.03, 4);
  set(live, 1, -2.0, 2.0, 0.3, 0.2, 3.0, 0.03, 2);
  map.fuse_rock_tracks(closed, 1, live, 2);
  map.finish();
  auto sorted = [&] {
    std::vector<MapRock> r = map.rocks();
    std::sort(r.begin(), r.end(), [](const MapRock& a, const MapRock& b) { return a.x_m < b.x_m; });
    return r;
  };
  std::vector<MapRock> rocks = sorted();
  ASSERT_EQ(rocks.size(), 2u);
  EXPECT_NEAR(rocks[0].x_m, 0.0, 1e-6);
  EXPECT_NEAR(rocks[0].y_m, 2.0, 1e-6);
  EXPECT_NEAR(rocks[0].height_m, 0.12, 1e-6);
  EXPECT_NEAR(rocks[1].width_m, 0.25, 1e-6);
  auto cell = [&](double x, double y) { return cell_of(map, x, y); };
  // Hazard = 1 - exp(-evidence / hazard_evidence_scale) where the rocks are taller than
  // hazard_height_m; the evidence of a live track goes when the next frame replaces it.
  const float ev = map.layer("rock_evidence").at<float>(cell(0.0, 2.0));
  EXPECT_GT(ev, 1.0f);
  EXPECT_NEAR(map.layer("hazard").at<float>(cell(0.0, 2.0)), 1.0 - std::exp(-ev / p.hazard_evidence_scale), 1e-5);
  EXPECT_TRUE(std::isnan(map.layer("hazard").at<float>(cell(3.0, -3.0))));
  map.fuse_rock_tracks(closed, 0, live, 0);
  map.finish();
  rocks = sorted();
  ASSERT_EQ(rocks.size(), 1u);
  EXPECT_NEAR(rocks[0].x_m, 1.0, 1e-6);
  EXPECT_TRUE(std::isnan(map.layer("rock_evidence").at<float>(cell(0.0, 2.0))));
  EXPECT_GT(map.layer("hazard").at<float>(cell(1.0, 1.0)), 0.9f);
}

TEST(WorldMap, TheHazardIsAveragedOverTheKnownCellsAroundIt) {
  // A sighted rock (evidence painted as a Gaussian of its 3 cm position uncertainty) on a map
  // finished with and without hazard_blur_m (default 4 cm = 1 cell): with it, every known cell's
  // hazard is the Gaussian-weighted mean (sigma 1 cell, cut at 2) of the known cells' hazards
  // without it; unknown cells stay unknown, and the rock's cells stay above its surroundings.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat live(kTrackRows, 4, CV_32F, cv::Scalar(nan)), closed(kTrackRows, 4, CV_32F, cv::Scalar(nan));
  for (auto [row, v] : {std::pair{kTrackX, 1.0},
                        {kTrackY, 1.0},
                        {kTrackHeight, 0.2},
                        {kTrackWidth, 0.25},
                        {kTrackScore, 2.0},
                        {kTrackSxx, 0.03 * 0.03},
                        {kTrackSxy, 0.0},
                        {kTrackSyy, 0.03 * 0.03},
                        {kTrackFrames, 6.0}})
    closed.at<float>(row, 0) = static_cast<float>(v);
  WorldMapParams p;
  p.resolution_m = 0.04;
  p.length_x_m = p.length_y_m = 4;
  ASSERT_DOUBLE_EQ(p.hazard_blur_m, 0.04);
  WorldMapParams off = p;
  off.hazard_blur_m = 0;
  WorldMap blurred(p, 0, 0), sharp(off, 0, 0);
  for (WorldMap* m : {&blurred, &sharp}) {
    m->fuse_rock_tracks(closed, 1, live, 0);
    m->finish();
  }
  const cv::Mat& h = blurred.layer("hazard");
  const cv::Mat& h0 = sharp.layer("hazard");
  int known = 0;
  for (int i = 0; i < h.rows; ++i)
    for (int j = 0; j < h.cols; ++j) {
      if (!std::isfinite(h0.at<float>(i, j))) {
        EXPECT_TRUE(std::isnan(h.at<float>(i, j))) << i << "," << j;
        continue;
      }
      double s = 0, w = 0;
      for (int a = -2; a <= 2; ++a)
        for (int b = -2; b <= 2; ++b) {
          if (i + a < 0 || j + b < 0 || i + a >= h.rows || j + b >= h.cols) continue;
          const float v = h0.at<float>(i + a, j + b);
          if (!std::isfinite(v)) continue;
          const double g = std::exp(-0.5 * (a * a + b * b));
          s += g * v, w += g;
        }
      EXPECT_NEAR(h.at<float>(i, j), s / w, 1e-5) << i << "," << j;
      ++known;
    }
  EXPECT_GT(known, 20);
  const cv::Point c = cell_of(blurred, 1.0, 1.0);
  EXPECT_GT(h.at<float>(c), 0.5f);
  EXPECT_LT(h.at<float>(c), h0.at<float>(c));  // the peak spread over its neighbours
  EXPECT_GT(h.at<float>(c), h.at<float>(c + cv::Point(3, 0)));
  WorldMapParams bad = p;
  bad.hazard_blur_m = std::nan("");
  EXPECT_THROW(bad.validate(), std::exception);
}

TEST(WorldMap, ARockSeenAgainByANewTrackKeepsItsFirstNumber) {
  WorldMapParams p;
  p.resolution_m = 0.04;
  p.length_x_m = p.length_y_m = 8;
  WorldMap map(p, 0, 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat live(kTrackRows, 4, CV_32F, cv::Scalar(nan)), closed(kTrackRows, 4, CV_32F, cv::Scalar(nan)),
      none(kTrackRows, 4, CV_32F, cv::Scalar(nan));
  auto set = [](cv::Mat& t, int k, double x, double y, double score, long id) {
    for (auto [row, v] : {std::pair{kTrackX, x},
                          {kTrackY, y},
                          {kTrackHeight, 0.15},
                          {kTrackWidth, 0.2},
                          {kTrackScore, score},
                          {kTrackSxx, 1e-3},
                          {kTrackSxy, 0.0},
                          {kTrackSyy, 1e-3},
                          {kTrackFrames, 5.0},
                          {kTrackPosXx, 1e-2},
                          {kTrackPosXy, 0.0},
                          {kTrackPosYy, 1e-2},
                          {kTrackId, double(id)}})
      t.at<float>(row, k) = static_cast<float>(v);
  };
  // Track 3 saw the rock and closed; track 9 opens on it later, and a rock 1 m away is track 7.
  set(closed, 0, 1.0, 1.0, 1.2, 3);
  map.fuse_rock_tracks(closed, 1, none, 0);
  ASSERT_EQ(map.rocks().size(), 1u);
  EXPECT_EQ(map.rocks()[0].id, 3);
  set(live, 0, 1.12, 1.02, 1.8, 9);
  set(live, 1, 2.0, 1.0, 3.0, 7);
  map.fuse_rock_tracks(none, 0, live, 2);
  std::vector<MapRock> rocks = map.rocks();
  std::sort(rocks.begin(), rocks.end(), [](const MapRock& a, const MapRock& b) { return a.x_m < b.x_m; });
  ASSERT_EQ(rocks.size(), 2u);
  // The new track is stronger: its position, the rock's first number.
  EXPECT_NEAR(rocks[0].x_m, 1.12, 1e-6);
  EXPECT_EQ(rocks[0].id, 3);
  EXPECT_NEAR(rocks[1].x_m, 2.0, 1e-6);
  EXPECT_EQ(rocks[1].id, 7);
}

TEST(DriveMapper, VisionCorrectsWheelDriftOnARenderedDrive) {
  const DriveRun vo = run_rendered_drive(11, true), wheel = run_rendered_drive(11, false);
  const double e_vo = std::hypot(vo.est.x - vo.truth.x, vo.est.y - vo.truth.y);
  const double e_w = std::hypot(wheel.est.x - wheel.truth.x, wheel.est.y - wheel.truth.y);
  const double h_vo = std::abs(wrap_angle(vo.est.yaw - vo.truth.yaw)),
               h_w = std::abs(wrap_angle(wheel.est.yaw - wheel.truth.yaw));
  EXPECT_LT(h_vo, 0.5 * h_w) << "heading error vision " << h_vo / kDeg << " deg, wheels " << h_w / kDeg << " deg";
  EXPECT_LT(e_vo, e_w) << "position error vision " << e_vo << " m, wheels " << e_w << " m";
  EXPECT_GE(vo.counters.vo_ok, 24);  // of 29 (measured 25)
  EXPECT_EQ(wheel.counters.vo_ok, 0);
}

TEST(DriveMapper, ThePublishedCovarianceCoversThePoseErrorOnRenderedDrives) {
  // Rendered drives whose body wobbles in pitch and roll (a tilt the VO's fit cannot see): the
  // pose error of every frame against the covariance published with it (squared Mahalanobis
  // distance: mean 2 and 95 % of frames within 5.99 when honest). The fit's covariance alone
  // claims too much across the track; with the lateral VO bias (the default) it covers the error.
  // Measured over seeds 11-18: bias 0 mean 9.2, 39 % inside; 0.01 mean 1.3, 97 %; 0.02 1.1, 97 %.
  // Heading (error / published sigma, rms; honest: 1), seeds 11-18: the fit alone 5.9, with the
  // default yaw bias (0.0015 rad per segment) 2.3: still too tight here (the dev drives: 0.96 /
  // 0.76 / 0.80; 0.004 would fit these drives and claim 2.5x too much on those).
  struct Score {
    double mean, inside, heading_z_rms;
  };
  const auto score = [](double bias, double yaw_bias) {
    DriveMapperParams p;
    p.fuse_terrain = false;
    p.vo_lateral_bias = bias;
    p.vo_yaw_bias_rad = yaw_bias;
    std::vector<double> d2, z;
    for (std::uint64_t seed = 11; seed <= 14; ++seed) {
      const DriveRun r = run_rendered_drive(seed, true, -1, -1, p);
      d2.insert(d2.end(), r.mahalanobis2.begin(), r.mahalanobis2.end());
      z.insert(z.end(), r.heading_z.begin(), r.heading_z.end());
    }
    double mean = 0, inside = 0, zz = 0;
    for (double v : d2) mean += v / static_cast<double>(d2.size()), inside += v <= kChi2TwoDof95 ? 1.0 : 0.0;
    for (double v : z) zz += v * v / static_cast<double>(z.size());
    const Score s{mean, inside / static_cast<double>(d2.size()), std::sqrt(zz)};
    std::printf("bias %.3f yaw bias %.4f: mean d2 %.2f inside %.3f heading z rms %.2f\n", bias, yaw_bias, s.mean,
                s.inside, s.heading_z_rms);
    return s;
  };
  const Score fit = score(0.0, 0.0),
              def = score(DriveMapperParams{}.vo_lateral_bias, DriveMapperParams{}.vo_yaw_bias_rad);
  EXPECT_GT(fit.mean, 4.0) << "the fit's covariance alone is over-confident on these drives";
  EXPECT_LT(fit.inside, 0.8);
  EXPECT_GE(def.inside, 0.9) << "frames whose error lies inside the published 95 % ellipse";
  EXPECT_LT(def.mean, 4.0);
  EXPECT_GT(def.mean, 0.5) << "not so wide it tells a planner nothing";
  EXPECT_GT(fit.heading_z_rms, 4.0) << "the fit's heading variance alone is over-confident on these drives";
  EXPECT_LT(def.heading_z_rms, 0.6 * fit.heading_z_rms);
  EXPECT_GT(def.heading_z_rms, 0.5) << "not so wide it tells a planner nothing";
}

TEST(DriveMapper, BlackFrameAndOdometryJumpFallBackAndAreCounted) {
  const DriveRun r = run_rendered_drive(12, true, 10, 20);
  EXPECT_EQ(r.counters.frames, 30);
  EXPECT_EQ(r.counters.odometry_jumps, 2);                                // a spike jumps out and back
  EXPECT_GE(r.counters.vo_failed, 1);                                     // the black frame
  EXPECT_GE(r.counters.vo_failed - r.counters.vo_uncertain, 1);           // a loss, not a fit too loose to use
  EXPECT_LT(std::hypot(r.est.x - r.truth.x, r.est.y - r.truth.y), 0.05);  // the jump was ignored
}

TEST(DriveMapper, AGapInTheFramesIsNotAnOdometryJump) {
  Rig rig(13, 20);
  DriveMapperParams p;
  p.fuse_terrain = false;
  DriveMapper dm(rig.model, CameraMount{}, rig.sun.vector(), p, {1.5, 0});
  // 0.1 m per second; frames 4..9 are missing: a 0.7 m step over 7 s is a gap, not a jump.
  for (int k : {0, 1, 2, 3, 10, 11}) {
    const Pose2 truth{0.1 * k, 0.0, 0.0};
    dm.add_frame(rig.frame(truth), Pose2{0.1 * k * 1.01, 0.0, 0.0}, static_cast<double>(k));
  }
  EXPECT_EQ(dm.counters().odometry_jumps, 0);
  EXPECT_NEAR(dm.pose().x, 1.1, 0.03);
  // The same step without times is a jump (ignored, counted).
  DriveMapper dm2(rig.model, CameraMount{}, rig.sun.vector(), p, {1.5, 0});
  for (int k : {0, 10}) dm2.add_frame(rig.frame(Pose2{0.1 * k, 0, 0}), Pose2{0.1 * k, 0, 0});
  EXPECT_EQ(dm2.counters().odometry_jumps, 1);
}

TEST(DriveMapper, WheelStepsAreShortenedByTheExpectedSlip) {
  // The wheels report 1 m straight ahead in ten steps. The fusion expects them to overstate the
  // ground covered by `wheel.slip` (2 % here) and places the rover at 0.98 m; the wheel pose it
  // reports stays what the wheels said. With no slip expected it follows the wheels.
  Rig rig(13, 20);
  const cv::Mat f = rig.frame(Pose2{});
  auto drive = [&](double slip) {
    DriveMapperParams p;
    p.fuse_terrain = false;
    p.use_vision = false;
    p.wheel.slip = slip;
    DriveMapper dm(rig.model, CameraMount{}, rig.sun.vector(), p, {1.5, 0});
    double wheel_x = 0.0;
    for (int k = 0; k <= 10; ++k)
      wheel_x = dm.add_frame(f, Pose2{0.1 * k, 0.0, 0.0}, static_cast<double>(k)).wheel_pose.x;
    EXPECT_NEAR(wheel_x, 1.0, 1e-12);
    EXPECT_NEAR(dm.pose().y, 0.0, 1e-12);
    return dm.pose().x;
  };
  EXPECT_NEAR(drive(0.02), 0.98, 1e-9);
  EXPECT_NEAR(drive(0.0), 1.0, 1e-9);
  DriveMapperParams bad;
  bad.wheel.slip = 0.6;
  try {
    bad.validate();
    ADD_FAILURE() << "slip 0.6 accepted";
  } catch (const regolith::FieldError& e) {
    EXPECT_STREQ(e.what(), "mapping.wheel.slip: must be in [0, 0.5]");
  }
}

TEST(DriveMapper, AStandingRoverHasNoParallaxButStillSightsRocks) {
  // The same view five times: no baseline, so no parallax search runs (not a division by zero);
  // the per-frame rock sightings still do.
  Rig rig(14, 15);
  DriveMapper dm(rig.model, CameraMount{}, rig.sun.vector(), DriveMapperParams{}, {1.5, 0});
  const cv::Mat f = rig.frame(Pose2{});
  int most = 0;
  for (int k = 0; k < 5; ++k) {
    const FrameReport& r = dm.add_frame(f, Pose2{}, static_cast<double>(k));
    EXPECT_EQ(r.vo, k == 0 ? VoStatus::kNoKeyframe : VoStatus::kOk) << k;
    EXPECT_GT(r.rock_sightings, 0) << k;
    most = std::max(most, r.rock_sightings);
  }
  EXPECT_EQ(dm.counters().parallax_frames, 0);
  // The same rocks in every frame: each continues its track (one track per rock), and a rock is
  // missed in at most one frame (a rock at the edge of the height threshold may drop out when
  // the filtered tilt moves by rounding: on arm64 one of ten sightings did).
  EXPECT_EQ(dm.counters().rock_tracks, most);
  EXPECT_GE(dm.counters().rock_sightings, 4 * most);
  EXPECT_TRUE(dm.pose().finite());
  EXPECT_NEAR(dm.pose().x, 0.0, 0.01);
}

// The input.json of the rendered drives below (the rig's camera, 320 x 240).
constexpr const char* kRigDriveJson = R"({"camera": {"fx": 220, "fy": 220, "cx": 159.5, "cy": 119.5, "width": 320,
    "height": 240, "mount_height_m": 0.67, "pitch_deg": 34.377}, "sun": {"azimuth_deg": 100, "elevation_deg": 45}})";

// Frames k0..k1-1 of a rendered drive north (world +y, yaw pi/2; the rig renders along its own x)
// at 6 cm per frame, 1 s apart, into d/frames/<k>.png, with their frames.csv lines (odometry x
// from `odom_x`, 0 when not given) on `csv`.
void write_rig_frames(Rig& rig, const fs::path& d, std::ostream& csv, int k0, int k1,
                      const std::function<double(int)>& odom_x = nullptr) {
  fs::create_directories(d / "frames");
  for (int k = k0; k < k1; ++k) {
    const std::string f = "frames/" + std::to_string(k) + ".png";
    cv::imwrite((d / f).string(), rig.frame(Pose2{0.06 * k, 0, 0}));
    csv << k << "," << f << "," << k << "," << (odom_x ? odom_x(k) : 0.0) << "," << 0.06 * k << ",1.5707963\n";
  }
}

TEST(RecordedDrive, BadInputNamesTheFileFieldAndLine) {
  const regolith::testing::TempDir d_dir("mapping_bad");
  const fs::path d = d_dir.path();
  EXPECT_THROW(read_drive(d / "absent"), InputError);
  std::ofstream(d / "input.json") << R"({"camera": {"fx": 200, "fy": 200, "cx": 159.5, "cy": 119.5, "width": 320,
    "height": 240, "mount_height_m": 0.6, "pitch_deg": 30}, "sun": {"azimuth_deg": 100}})";
  try {
    read_drive(d);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("input.json: sun.elevation_deg: missing"), std::string::npos) << e.what();
  }
  std::ofstream(d / "input.json") << R"({"camera": {"fx": 200, "fy": 200, "cx": 159.5, "cy": 119.5, "width": 320,
    "height": 240, "mount_height_m": 0.6, "pitch_deg": 30}, "sun": {"azimuth_deg": 100, "elevation_deg": 40}})";
  std::ofstream(d / "frames.csv") << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n0,frames/0000.png,0,0,0,1.57\n"
                                     "1,frames/0001.png,1,0.05,abc,1.57\n";
  try {
    read_drive(d);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frames.csv:3: odom_y_m: not a number ('abc')"), std::string::npos)
        << e.what();
  }
  // A frame number is a whole number checked before the cast (1e308 as an int is undefined) and a
  // time is finite (NaN compared as "out of order" and the frame was dropped without a word).
  for (const auto& [row, want] : std::vector<std::pair<std::string, std::string>>{
           {"1e308,frames/0001.png,1,0,0,1.57",
            "frames.csv:3: frame: must be a whole number in 0..2147483647 (got '1e308')"},
           {"2.5,frames/0001.png,1,0,0,1.57",
            "frames.csv:3: frame: must be a whole number in 0..2147483647 (got '2.5')"},
           {"-1,frames/0001.png,1,0,0,1.57", "frames.csv:3: frame: must be a whole number in 0..2147483647 (got '-1')"},
           {"nan,frames/0001.png,1,0,0,1.57", "frames.csv:3: frame: must be a whole number"},
           {"1,frames/0001.png,nan,0,0,1.57", "frames.csv:3: t_s: must be a finite time (got 'nan')"},
           {"1,frames/0001.png,inf,0,0,1.57", "frames.csv:3: t_s: must be a finite time (got 'inf')"}}) {
    std::ofstream(d / "frames.csv") << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n0,frames/0000.png,0,0,0,1.57\n"
                                    << row << "\n";
    try {
      read_drive(d);
      ADD_FAILURE() << row;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  }
  // The header names every column read, and every row has them all.
  for (const auto& [text, want] : std::vector<std::pair<std::string, std::string>>{
           {"frame,file,t_s,odom_x_m,odom_y_m\n0,frames/0000.png,0,0,0\n",
            "frames.csv:1: no column 'odom_yaw_rad' in the header"},
           {"\n\nframe,file,t_s,odom_x_m,odom_yaw_rad\n", "frames.csv:3: no column 'odom_y_m' in the header"},
           {"frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n0,frames/0000.png,0,0,0\n",
            "frames.csv:2: 5 fields, expected 6"},
           {"", "frames.csv: empty (no header line)"},
           {"frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\r\n", "frames.csv: no frames"}}) {
    std::ofstream(d / "frames.csv") << text;
    try {
      read_drive(d);
      ADD_FAILURE() << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  }
  // Image sizes are whole pixels within 1..16384, checked before any cast.
  for (const char* w : {"1e30", "320.5", "0"}) {
    std::ofstream(d / "input.json")
        << R"({"camera": {"fx": 200, "fy": 200, "cx": 159.5, "cy": 119.5, "width": )" << w
        << R"(, "height": 240, "mount_height_m": 0.6, "pitch_deg": 30}, "sun": {"azimuth_deg": 100, "elevation_deg": 40}})";
    try {
      read_drive(d);
      ADD_FAILURE() << w;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("input.json: camera.width: must be a whole number of pixels, 1..16384"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(RecordedDrive, ACorruptedOdometryLineNeitherSizesTheWindowNorMovesThePose) {
  // One frames.csv line 1e6 m off: the mapper ignores the jump out and back (counted twice), and
  // the map window is sized by the path it dead-reckons, not by that line (it asked for 4e7
  // cells per side: an error naming map_resolution_m, which nobody had set).
  const regolith::testing::TempDir d_dir("mapping_spike");
  const fs::path d = d_dir.path();
  Rig rig(6);
  std::ofstream(d / "input.json") << kRigDriveJson;
  std::ofstream csv(d / "frames.csv");
  csv << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n";
  write_rig_frames(rig, d, csv, 0, 6, [](int k) { return k == 3 ? 1e6 : (k == 4 ? 1e300 : 0.0); });
  csv.close();
  const DriveMapSummary s = map_drive(read_drive(d), DriveMapperParams{}, d / "out");
  EXPECT_EQ(s.counters.frames, 6);
  EXPECT_EQ(s.counters.odometry_jumps, 3);
  // odometry.csv echoes the wheel odometry as read, one whole row per frame (1e300 as %f is 301
  // digits: it overran the row's buffer and ran into the next row); beyond 1e9 in exponent form.
  std::ifstream odo(d / "out" / "odometry.csv");
  std::vector<std::string> rows;
  for (std::string line; std::getline(odo, line);) rows.push_back(line);
  ASSERT_EQ(rows.size(), 7u);
  for (const std::string& r : rows) EXPECT_EQ(std::count(r.begin(), r.end(), ','), 11) << r;  // 12 columns
  EXPECT_NE(rows[4].find(",1000000.000000,"), std::string::npos) << rows[4];
  EXPECT_NE(rows[5].find(",1e+300,"), std::string::npos) << rows[5];
  const nlohmann::json mj = nlohmann::json::parse(std::ifstream(d / "out" / "map.json"));
  EXPECT_LT(mj["width"].get<int>() * mj["resolution_m"].get<double>(), 30.0) << mj.dump();
  // The corrected last pose stays on the 0.3 m path.
  EXPECT_NEAR(s.reports.back().pose.y, 0.30, 0.05);
  EXPECT_NEAR(s.reports.back().pose.x, 0.0, 0.05);
}

TEST(RecordedDrive, ADescriptionOfAnotherCameraIsRefusedBeforeAnythingIsSized) {
  // 320 x 240 frames described as a 16384 x 12288 camera: the mapper's tables would follow the
  // description (gigabytes); the first frame that reads shows the mismatch first.
  const regolith::testing::TempDir d_dir("mapping_other_camera");
  const fs::path d = d_dir.path();
  Rig rig(6);
  std::ofstream(d / "input.json")
      << R"({"camera": {"fx": 11264, "fy": 11264, "cx": 8191.5, "cy": 6143.5, "width": 16384,
    "height": 12288, "mount_height_m": 0.67, "pitch_deg": 34.377}, "sun": {"azimuth_deg": 100, "elevation_deg": 45}})";
  std::ofstream csv(d / "frames.csv");
  csv << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n0,frames/missing.png,0,0,0,1.5707963\n";
  write_rig_frames(rig, d, csv, 1, 3);
  csv.close();
  try {
    map_drive(read_drive(d), DriveMapperParams{}, d / "out");
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("input.json: camera is 16384x12288 px, but frame 1 ("), std::string::npos) << w;
    EXPECT_NE(w.find("1.png) is 320x240"), std::string::npos) << w;
  }
  EXPECT_FALSE(fs::exists(d / "out"));
}

TEST(RecordedDrive, ADescriptionWrittenIsReadBackFieldForField) {
  const regolith::testing::TempDir d_dir("mapping_describe");
  const fs::path d = d_dir.path();
  RecordedDrive a;
  a.camera.fx = 410.5;
  a.camera.fy = 411.25;
  a.camera.cx = 319.5;
  a.camera.cy = 241.0;
  a.camera.width = 640;
  a.camera.height = 480;
  a.camera.mount_height_m = 0.62;
  a.camera.pitch_rad = 0.41;
  a.camera.roll_rad = -0.02;
  a.mount = {0.25, -0.05, 0.1};
  a.sun_azimuth_deg = 231.5;
  a.sun_elevation_deg = 17.25;
  a.wheel_radius_m = 0.11;
  write_drive_description(a, d / "input.json");
  std::ofstream(d / "frames.csv") << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n0,frames/0.png,0,0,0,0\n";
  const RecordedDrive b = read_drive(d);
  EXPECT_DOUBLE_EQ(b.camera.fx, 410.5);
  EXPECT_DOUBLE_EQ(b.camera.fy, 411.25);
  EXPECT_DOUBLE_EQ(b.camera.cx, 319.5);
  EXPECT_DOUBLE_EQ(b.camera.cy, 241.0);
  EXPECT_EQ(b.camera.width, 640);
  EXPECT_EQ(b.camera.height, 480);
  EXPECT_DOUBLE_EQ(b.camera.mount_height_m, 0.62);
  EXPECT_NEAR(b.camera.pitch_rad, 0.41, 1e-12);
  EXPECT_NEAR(b.camera.roll_rad, -0.02, 1e-12);
  EXPECT_DOUBLE_EQ(b.mount.x_m, 0.25);
  EXPECT_DOUBLE_EQ(b.mount.y_m, -0.05);
  EXPECT_NEAR(b.mount.yaw_rad, 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(b.sun_azimuth_deg, 231.5);
  EXPECT_DOUBLE_EQ(b.sun_elevation_deg, 17.25);
  EXPECT_DOUBLE_EQ(b.wheel_radius_m, 0.11);
  EXPECT_THROW(write_drive_description(a, d / "absent" / "input.json"), InputError);
}

#ifdef REGOLITH_TOOL
TEST(RecordedDrive, ADriveOfWhichNoFrameReadsIsAnErrorOfTheCli) {
  // It wrote an empty map and exited 0 ("0 frames (2 skipped)"): a script took it for a map.
  const regolith::testing::TempDir d_dir("mapping_none");
  const fs::path d = d_dir.path();
  std::ofstream(d / "input.json") << kRigDriveJson;
  std::ofstream(d / "frames.csv")
      << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n"
      << "0,frames/missing0.png,0,0,0,1.5707963\n1,frames/missing1.png,1,0,0.05,1.5707963\n";
  const fs::path log = d / "log.txt";
  const std::string cmd = std::string(REGOLITH_TOOL) + " map " + d.string() + " --out " + (d / "out").string() + " > " +
                          log.string() + " 2>&1";
  const int st = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 2);
  std::ifstream f(log);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("missing0.png"), std::string::npos) << text;
  EXPECT_NE(text.find(": no frame could be mapped (2 skipped; the warnings above say why)"), std::string::npos) << text;
  EXPECT_TRUE(fs::exists(d / "out" / "map.json"));  // what was written stays
}
#endif

// One corrupted timestamp far in the future used to make every later frame "out of order": the rest of the
// drive was lost. The lone spike is the frame skipped; a row missing from frames.csv is said, not skipped.
TEST(RecordedDrive, ALoneBadTimestampCostsOneFrameNotTheRestOfTheDrive) {
  const regolith::testing::TempDir d_dir("mapping_spike");
  const fs::path d = d_dir.path();
  Rig rig(10);
  std::ofstream(d / "input.json") << kRigDriveJson;
  std::ostringstream rows;
  write_rig_frames(rig, d, rows, 0, 10);
  std::istringstream in(rows.str());
  std::ofstream csv(d / "frames.csv");
  csv << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n";
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("6,", 0) == 0) continue;                                     // frame 6's row lost
    if (line.rfind("3,", 0) == 0) line = "3,frames/3.png,58,0,0.18,1.5707963";  // frame 3's time corrupted
    csv << line << "\n";
  }
  csv.close();
  const DriveMapSummary s = map_drive(read_drive(d), DriveMapperParams{}, d / "out");
  EXPECT_EQ(s.counters.frames, 8);  // 0-2, 4, 5, 7-9
  EXPECT_EQ(s.skipped, 1);
  int spike_notes = 0, gap_notes = 0, order_notes = 0;
  for (const auto& n : s.notes) {
    spike_notes += n ==
                   "frame 3 (3.png): its time, 58 s, is later than the next frame's (4 s) while the frames "
                   "around it are in order: a bad timestamp: skipped";
    gap_notes += n == "frame 7 (7.png): frame 6 not in the drive (2 s since frame 5)";
    order_notes += n.find("out of order") != std::string::npos;
  }
  EXPECT_EQ(spike_notes, 1);
  EXPECT_EQ(gap_notes, 1);
  EXPECT_EQ(order_notes, 0);
}

TEST(RecordedDrive, UnreadableAndOutOfOrderFramesAreSkippedAndNamed) {
  const regolith::testing::TempDir d_dir("mapping_skip");
  const fs::path d = d_dir.path();
  Rig rig(6);
  std::ofstream(d / "input.json") << kRigDriveJson;
  std::ofstream csv(d / "frames.csv");
  csv << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n";
  write_rig_frames(rig, d, csv, 0, 6);
  csv << "3,frames/3.png,3,0,0.18,1.5707963\n";        // out of order
  csv << "7,frames/missing.png,7,0,0.42,1.5707963\n";  // unreadable
  csv.close();
  const DriveMapSummary s = map_drive(read_drive(d), DriveMapperParams{}, d / "out");
  EXPECT_EQ(s.counters.frames, 6);
  EXPECT_EQ(s.skipped, 2);
  bool named_order = false, named_missing = false;
  for (const auto& n : s.notes) {
    named_order |= n.find("frame 3") != std::string::npos && n.find("out of order") != std::string::npos;
    named_missing |= n.find("missing.png") != std::string::npos;
  }
  EXPECT_TRUE(named_order);
  EXPECT_TRUE(named_missing);
  for (const char* f : {"map.json", "elevation.tiff", "hazard.tiff", "rocks.csv", "odometry.csv", "overview.png"})
    EXPECT_TRUE(fs::exists(d / "out" / f)) << f;
  const cv::Mat e = cv::imread((d / "out" / "elevation.tiff").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(e.type(), CV_32FC1);
  // map.json says which cues made the map.
  const nlohmann::json mj = nlohmann::json::parse(std::ifstream(d / "out" / "map.json"));
  ASSERT_TRUE(mj.contains("cues")) << mj.dump();
  EXPECT_EQ(mj["cues"]["parallax"]["frames"].get<long>(), s.counters.parallax_frames);
  EXPECT_EQ(mj["cues"]["rock_sightings"]["sightings"].get<long>(), s.counters.rock_sightings);
  EXPECT_EQ(mj["cues"]["rock_sightings"]["tracks"].get<long>(), s.counters.rock_tracks);
  EXPECT_GT(s.counters.rock_tracks, 0);
  EXPECT_LT(s.counters.rock_tracks, s.counters.rock_sightings);
  EXPECT_TRUE(mj["cues"]["shadows"]["enabled"].get<bool>()) << "on by default since 2026-12-05";
  EXPECT_EQ(mj["cues"]["shadows"]["frames"].get<long>(), s.counters.shadow_frames);
}

// A drive and a map written by hand, so that what the scorer must find is known: two rocks >= 10 cm
// in view (one detected, one not), one detection far from any rock (a false alarm).
struct HandScoredDrive {
  fs::path drive, map;
  explicit HandScoredDrive(const fs::path& d) : drive(d / "drive"), map(d / "map") {
    fs::create_directories(drive);
    fs::create_directories(map);
    std::ofstream(drive / "input.json") << kRigDriveJson;
    std::ofstream(drive / "frames.csv") << "frame,file,t_s,odom_x_m,odom_y_m,odom_yaw_rad\n"
                                        << "0,frames/0.png,0,0,0,1.5707963\n1,frames/1.png,1,0,0.1,1.5707963\n";
    // Camera 0.67 m up, pitched 0.6 rad down, looking north (+y) from (0, 0) and (0, 0.1).
    std::ofstream(drive / "truth_poses.csv")
        << "frame,x_m,y_m,z_m,yaw_rad,pitch_rad,roll_rad,rover_x_m,rover_y_m,rover_z_m,rover_yaw_rad\n"
        << "0,0,0,0.67,1.5707963,0.6,0,0,0,0,1.5707963\n1,0,0.1,0.67,1.5707963,0.6,0,0,0.1,0,1.5707963\n";
    std::ofstream(drive / "grid.json") << R"({"origin_x_m": -2.0, "origin_y_m": -1.0, "resolution_m": 0.02})";
    cv::imwrite((drive / "height.tiff").string(), cv::Mat(200, 200, CV_32F, cv::Scalar(0)));
    // Rock 1 at (0, 1.5) and rock 2 at (0.5, 1.2), both 0.2 m tall and seen; rock 3 small.
    std::ofstream(drive / "truth.json") << R"({"rocks": [
      {"x_m": 0.0, "y_m": 1.5, "height_above_ground_m": 0.2, "width_m": 0.3, "length_m": 0.3, "major_axis_m": 0.3,
       "minor_axis_m": 0.3, "yaw_deg": 0, "observed": true},
      {"x_m": 0.5, "y_m": 1.2, "height_above_ground_m": 0.2, "width_m": 0.25, "length_m": 0.2, "major_axis_m": 0.25,
       "minor_axis_m": 0.2, "yaw_deg": 30, "observed": true},
      {"x_m": -0.4, "y_m": 1.0, "height_above_ground_m": 0.03, "width_m": 0.05, "length_m": 0.05, "major_axis_m": 0.05,
       "minor_axis_m": 0.05, "yaw_deg": 0, "observed": true}]})";
    std::ofstream(map / "map.json") << R"({"origin_x_m": -2.0, "origin_y_m": -1.0, "resolution_m": 0.04})";
    cv::imwrite((map / "elevation.tiff").string(), cv::Mat(100, 100, CV_32F, cv::Scalar(0)));
    cv::imwrite((map / "hazard.tiff").string(), cv::Mat(100, 100, CV_32F, cv::Scalar(0.1)));
    std::ofstream(map / "odometry.csv") << "frame,x_m,y_m,yaw_rad,wheel_x_m,wheel_y_m,wheel_yaw_rad\n"
                                        << "0,0,0,1.5707963,0,0,1.5707963\n1,0,0.1,1.5707963,0,0.11,1.5707963\n";
  }
  void detections(const std::string& rows, const std::string& header = "x_m,y_m,height_m,width_m,score") const {
    std::ofstream(map / "rocks.csv") << header << "\n" << rows;
  }
};

TEST(EvaluateMap, EachRocksClaimedCovarianceIsCheckedFromTheTruthsSide) {
  const regolith::testing::TempDir tmp("mapping_rock_covariance");
  const HandScoredDrive hd(tmp.path());
  const std::string cov = "x_m,y_m,height_m,width_m,score,cov_xx,cov_xy,cov_yy";
  // Rock 1 (0, 1.5) reported 0.2 m short along y with sd 0.1 m along y: d^2 = 4 (inside the 95 %
  // ellipse, 5.99); rock 2 (0.5, 1.2) reported 0.1 m off in x with sd 0.02 m: d^2 = 25 (outside).
  hd.detections("0,1.3,0.2,0.3,1,0.0004,0,0.01\n0.6,1.2,0.2,0.2,1,0.0004,0,0.0004\n", cov);
  nlohmann::json j = evaluate_map(hd.drive, hd.map);
  EXPECT_EQ(j["rocks"]["covariance_rocks"].get<int>(), 2);
  EXPECT_NEAR(j["rocks"]["position_mahalanobis2_mean"].get<double>(), (4.0 + 25.0) / 2, 1e-6);
  EXPECT_DOUBLE_EQ(j["rocks"]["position_within_95pct_ellipse"].get<double>(), 0.5);
  // One correlated report at (0.1, 1.6), cov [[0.01, 0.009], [0.009, 0.01]] (det 1.9e-5): rock 1's
  // error (0.1, 0.1) lies along its long axis, d^2 = 2e-5 / 1.9e-5; rock 2, missed, is 0.57 m
  // from it, across the axis (-0.4, 0.4): d^2 = 6.08e-3 / 1.9e-5 = 320. A missed rock counts
  // against the report nearest it: its ellipse does not cover where the rock is.
  hd.detections("0.1,1.6,0.2,0.3,1,0.01,0.009,0.01\n", cov);
  j = evaluate_map(hd.drive, hd.map);
  EXPECT_EQ(j["rocks"]["covariance_rocks"].get<int>(), 2);
  EXPECT_NEAR(j["rocks"]["position_mahalanobis2_mean"].get<double>(), (2e-5 + 6.08e-3) / 1.9e-5 / 2, 1e-6);
  EXPECT_DOUBLE_EQ(j["rocks"]["position_within_95pct_ellipse"].get<double>(), 0.5);
  // An older rocks.csv without the covariance: the checks are NaN, the rest scored.
  hd.detections("0,1.5,0.2,0.3,1\n");
  j = evaluate_map(hd.drive, hd.map);
  EXPECT_EQ(j["rocks"]["covariance_rocks"].get<int>(), 0);
  EXPECT_TRUE(std::isnan(j["rocks"]["position_mahalanobis2_mean"].get<double>()));
  EXPECT_EQ(j["rocks"]["hits"].get<int>(), 1);
}

// Pixels of exactly this BGR colour.
int count_colour(const cv::Mat& img, const cv::Vec3b& c) {
  int n = 0;
  for (int i = 0; i < img.rows; ++i)
    for (int j = 0; j < img.cols; ++j) n += img.at<cv::Vec3b>(i, j) == c;
  return n;
}

TEST(EvaluateMap, TheOverlayShowsHitsMissesAndFalseAlarms) {
  const regolith::testing::TempDir tmp("mapping_overlay");
  const HandScoredDrive hd(tmp.path());
  const cv::Vec3b matched(0, 230, 255), missed(0, 0, 255), false_alarm(255, 0, 255);
  // One hit (rock 1), rock 2 missed, one false alarm 1 m from every rock.
  hd.detections("0.02,1.52,0.18,0.3,1\n-1.0,2.2,0.1,0.1,1\n");
  const fs::path png = tmp.path() / "overlay.png";
  nlohmann::json j = evaluate_map(hd.drive, hd.map, png);
  EXPECT_EQ(j["rocks"]["truth_rocks_ge10cm_observed"].get<int>(), 2);
  EXPECT_EQ(j["rocks"]["hits"].get<int>(), 1);
  EXPECT_EQ(j["rocks"]["false_alarms"].get<int>(), 1);
  cv::Mat img = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  // Drawn from the legend alone: a few hundred pixels; each marker adds tens more.
  const int legend_missed = count_colour(img, missed), legend_false = count_colour(img, false_alarm);
  const int legend_matched = count_colour(img, matched);
  // Rock 2 found too, and no false alarm: no red ellipse, no magenta cross.
  hd.detections("0.02,1.52,0.18,0.3,1\n0.48,1.22,0.2,0.2,1\n");
  j = evaluate_map(hd.drive, hd.map, png);
  EXPECT_EQ(j["rocks"]["hits"].get<int>(), 2);
  EXPECT_EQ(j["rocks"]["false_alarms"].get<int>(), 0);
  const cv::Mat all_hit = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_EQ(all_hit.size(), img.size());
  EXPECT_GT(legend_missed - count_colour(all_hit, missed), 20) << "the missed rock's red ellipse";
  EXPECT_GT(legend_false - count_colour(all_hit, false_alarm), 20) << "the false alarm's magenta cross";
  EXPECT_GT(count_colour(all_hit, matched) - legend_matched, 20) << "the second hit's ellipse and cross";
  // The drive named with a trailing slash is the same drive: the same picture, title included
  // (the title once read the name of "DIR/" as empty).
  evaluate_map(hd.drive.string() + "/", hd.map, png);
  const cv::Mat slash = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_EQ(slash.size(), all_hit.size());
  EXPECT_EQ(cv::norm(slash, all_hit, cv::NORM_L1), 0.0);
  // Without an overlay nothing is drawn; a path that cannot be written is an error naming it.
  EXPECT_EQ(evaluate_map(hd.drive, hd.map)["rocks"]["hits"].get<int>(), 2);
  try {
    evaluate_map(hd.drive, hd.map, tmp.path() / "absent" / "overlay.png");
    ADD_FAILURE() << "expected an error naming the overlay";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("absent/overlay.png"), std::string::npos) << e.what();
  }
}

// Seen cells the map left unknown are what the coverage counts against it: the overlay tints them
// blue, so a person sees where the map is missing, not only how much.
TEST(EvaluateMap, TheOverlayTintsSeenCellsTheMapLeftUnknown) {
  const regolith::testing::TempDir tmp("mapping_overlay_unknown");
  const HandScoredDrive hd(tmp.path());
  hd.detections("0.02,1.52,0.18,0.3,1\n");
  const auto bluish = [](const cv::Mat& img) {
    int n = 0;
    for (int i = 0; i < img.rows; ++i)
      for (int j = 0; j < img.cols; ++j) {
        const cv::Vec3b p = img.at<cv::Vec3b>(i, j);
        n += p[0] > p[2] + 40 && p[0] > p[1] + 20;
      }
    return n;
  };
  const fs::path png = tmp.path() / "overlay.png";
  nlohmann::json j = evaluate_map(hd.drive, hd.map, png);
  EXPECT_DOUBLE_EQ(j["map"]["coverage"].get<double>(), 1.0);
  const int full = bluish(cv::imread(png.string(), cv::IMREAD_COLOR));
  // A hole of 0.4 x 0.4 m in the seen ground 1-1.4 m ahead of the start (cells 10 x 10).
  cv::Mat elev(100, 100, CV_32F, cv::Scalar(0));
  elev(cv::Rect(45, 50, 10, 10)).setTo(std::numeric_limits<float>::quiet_NaN());
  cv::imwrite((hd.map / "elevation.tiff").string(), elev);
  j = evaluate_map(hd.drive, hd.map, png);
  const int seen = j["map"]["seen_cells"].get<int>();
  EXPECT_NEAR(j["map"]["coverage"].get<double>(), 1.0 - 100.0 / seen, 1e-9);
  const cv::Mat holed = cv::imread(png.string(), cv::IMREAD_COLOR);
  // Each map cell is drawn as a square of several pixels: 100 cells tint well over 100 pixels.
  EXPECT_GT(bluish(holed) - full, 100) << "the unmapped cells' tint";
}

// Seen = in a true camera's image within 5 m and reached by its line of sight (the development
// set's `observed`: projection and depth test). Ground hidden behind a wall is in view but not
// seen: a map that leaves it unknown loses no coverage, and its hazard cells are not scored.
TEST(EvaluateMap, GroundHiddenFromEveryCameraIsNotCountedAsSeen) {
  const regolith::testing::TempDir tmp("mapping_eval_hidden");
  const HandScoredDrive hd(tmp.path());
  hd.detections("0.02,1.52,0.18,0.3,1\n");
  nlohmann::json j = evaluate_map(hd.drive, hd.map);
  const int flat_seen = j["map"]["seen_cells"].get<int>();
  EXPECT_EQ(j["map"]["in_view_cells"].get<int>(), flat_seen);  // flat ground: everything in view is seen
  // A wall 0.5 m tall across x -0.5..0.5 m at y 0.60-0.64 m (heightfield cells of 2 cm).
  cv::Mat height(200, 200, CV_32F, cv::Scalar(0));
  height(cv::Rect(75, 80, 51, 3)).setTo(0.5);
  cv::imwrite((hd.drive / "height.tiff").string(), height);
  // The map leaves the ground right behind the wall unknown (x -0.2..0.2, y 1.0-1.2: cells of 4 cm).
  cv::Mat elev(100, 100, CV_32F, cv::Scalar(0));
  elev(cv::Rect(45, 50, 10, 5)).setTo(std::numeric_limits<float>::quiet_NaN());
  cv::imwrite((hd.map / "elevation.tiff").string(), elev);
  j = evaluate_map(hd.drive, hd.map);
  const int seen = j["map"]["seen_cells"].get<int>(), in_view = j["map"]["in_view_cells"].get<int>();
  std::printf("flat: %d cells seen; wall: %d in view, %d seen\n", flat_seen, in_view, seen);
  EXPECT_LT(seen, in_view - 50);  // the wall's shadow
  EXPECT_DOUBLE_EQ(j["map"]["coverage"].get<double>(), 1.0);
  EXPECT_NEAR(j["map"]["coverage_in_view"].get<double>(), 1.0 - 50.0 / in_view, 1e-9);
}

// A scorer fed a broken file says which file and which field, not "map::at".
TEST(EvaluateMap, BrokenFilesAreErrorsNamingTheFileAndTheField) {
  const regolith::testing::TempDir tmp("mapping_eval_bad");
  const HandScoredDrive hd(tmp.path());
  hd.detections("0.02,1.52,0.18,0.3,1\n");
  ASSERT_EQ(evaluate_map(hd.drive, hd.map)["rocks"]["hits"].get<int>(), 1);
  const auto expect_error = [&](const std::string& needle) {
    try {
      evaluate_map(hd.drive, hd.map);
      ADD_FAILURE() << "expected an error containing '" << needle << "'";
    } catch (const regolith::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const auto write = [](const fs::path& p, const std::string& text) { std::ofstream(p) << text; };
  const std::string odometry =
      "frame,x_m,y_m,yaw_rad,wheel_x_m,wheel_y_m,wheel_yaw_rad\n"
      "0,0,0,1.5707963,0,0,1.5707963\n1,0,0.1,1.5707963,0,0.11,1.5707963\n";
  write(hd.map / "odometry.csv", "frame,x_m,y_m,yaw_rad,wheel_x_m,wheel_y_m\n0,0,0,1.57,0,0\n");
  expect_error("odometry.csv:1: no column 'wheel_yaw_rad' in the header");
  write(hd.map / "odometry.csv",
        "frame,x_m,y_m,yaw_rad,wheel_x_m,wheel_y_m,wheel_yaw_rad\n0,0,0,1.57,0,0,1.57\n1e12,0,0,0,0,0,0\n");
  expect_error("odometry.csv:3: frame: must be a whole number");
  write(hd.map / "odometry.csv", "");
  expect_error("odometry.csv: empty (no header line)");
  write(hd.map / "odometry.csv", odometry);
  hd.detections("");
  write(hd.map / "rocks.csv", "x_m,y_m,score\n0,1.5,1\n");
  expect_error("rocks.csv:1: no column 'height_m' in the header");
  hd.detections("0.02,1.52,0.18,0.3,1\n");
  cv::imwrite((hd.map / "hazard.tiff").string(), cv::Mat(50, 100, CV_32F, cv::Scalar(0.1)));
  expect_error("hazard.tiff: 100x50 cells, elevation.tiff has 100x100");
  cv::imwrite((hd.map / "hazard.tiff").string(), cv::Mat(100, 100, CV_32F, cv::Scalar(0.1)));
  write(hd.drive / "truth.json", R"({"rocks": [{"x_m": 0.0, "y_m": 1.5, "width_m": 0.3}]})");
  expect_error("truth.json: rocks[0]: observed: must be true or false");
  write(hd.drive / "truth.json", R"({"rocks": [{"x_m": 0.0, "y_m": 1.5, "width_m": 0.3, "observed": true}]})");
  expect_error("truth.json: rocks[0]: height_above_ground_m: missing");
  write(hd.drive / "truth.json", R"({"rocks": 3})");
  expect_error("truth.json: rocks: must be an array");
  // A short row reads its missing cells as unknown, not past the end.
  write(hd.drive / "truth.json", R"({"rocks": []})");
  write(hd.map / "odometry.csv", odometry + "2,0\n");
  EXPECT_EQ(evaluate_map(hd.drive, hd.map)["rocks"]["hits"].get<int>(), 0);
}

// The hazard AUC is scored over the seen cells with a value; the seen cells left unknown are
// counted and scored as 0 in a second AUC, so a map cannot look better by leaving a rock NaN.
TEST(EvaluateMap, TheCovarianceIsCheckedAgainstTheErrorItClaims) {
  // Frame 1 is 2 cm off across the track (x) and 0.01 rad off in heading. Claimed 1 cm and 0.01
  // rad: a squared Mahalanobis distance of 4 (inside the 95 % ellipse, 5.99) and a heading z of 1;
  // claimed 0.5 cm: 16, outside.
  const regolith::testing::TempDir tmp("mapping_covariance");
  const HandScoredDrive hd(tmp.path());
  const auto poses = [&](const std::string& cov) {
    std::ofstream(hd.map / "odometry.csv")
        << "frame,x_m,y_m,yaw_rad,cov_xx,cov_yy,cov_yawyaw,vo,wheel_x_m,wheel_y_m,wheel_yaw_rad,cov_xy\n"
        << "0,0,0,1.5707963,0,0,0,first,0,0,1.5707963,0\n"
        << "1,0.02,0.1,1.5807963," << cov << ",ok,0,0.11,1.5707963,0\n";
  };
  hd.detections("");
  poses("1e-4,1e-4,1e-4");
  nlohmann::json p = evaluate_map(hd.drive, hd.map)["poses"];
  EXPECT_EQ(p["covariance_frames"].get<int>(), 1) << "the first frame claims no covariance: not scored";
  EXPECT_NEAR(p["position_mahalanobis2_mean"].get<double>(), 4.0, 1e-3);
  EXPECT_DOUBLE_EQ(p["position_within_95pct_ellipse"].get<double>(), 1.0);
  EXPECT_NEAR(p["heading_z_rms"].get<double>(), 1.0, 1e-3);
  poses("2.5e-5,1e-4,1e-4");
  p = evaluate_map(hd.drive, hd.map)["poses"];
  EXPECT_NEAR(p["position_mahalanobis2_mean"].get<double>(), 16.0, 1e-2);
  EXPECT_DOUBLE_EQ(p["position_within_95pct_ellipse"].get<double>(), 0.0);
  // Without covariance columns (an older odometry.csv) the checks are NaN, the rest scored.
  std::ofstream(hd.map / "odometry.csv") << "frame,x_m,y_m,yaw_rad,wheel_x_m,wheel_y_m,wheel_yaw_rad\n"
                                         << "0,0,0,1.5707963,0,0,1.5707963\n1,0.02,0.1,1.5707963,0,0.11,1.5707963\n";
  p = evaluate_map(hd.drive, hd.map)["poses"];
  EXPECT_EQ(p["covariance_frames"].get<int>(), 0);
  EXPECT_TRUE(std::isnan(p["position_mahalanobis2_mean"].get<double>()));
  EXPECT_NEAR(p["final_position_error_m"].get<double>(), 0.02, 1e-9);
}

TEST(EvaluateMap, UnknownHazardCellsAreCountedAndScoredAsZeroInTheSecondAuc) {
  const regolith::testing::TempDir tmp("mapping_eval_unknown");
  const HandScoredDrive hd(tmp.path());
  hd.detections("0.02,1.52,0.18,0.3,1\n");
  // Map cell (i, j) is centred at (-2 + 0.04 j, -1 + 0.04 i). Rock 1 (0, 1.5) reads 0.9 within
  // 0.12 m of its centre; rock 2 (0.5, 1.2; semi-axes 0.125 x 0.1 m) is unknown within 0.09 m.
  cv::Mat hazard(100, 100, CV_32F, cv::Scalar(0.1));
  int unknown = 0, high = 0;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      const double x = -2 + 0.04 * j, y = -1 + 0.04 * i;
      if (std::hypot(x, y - 1.5) <= 0.12) hazard.at<float>(i, j) = 0.9f, ++high;
      if (std::hypot(x - 0.5, y - 1.2) <= 0.09) hazard.at<float>(i, j) = std::nanf(""), ++unknown;
    }
  ASSERT_GT(unknown, 10);
  cv::imwrite((hd.map / "hazard.tiff").string(), hazard);
  const nlohmann::json h = evaluate_map(hd.drive, hd.map)["hazard"];
  EXPECT_EQ(h["unknown_cells"].get<int>(), unknown) << h.dump();
  EXPECT_EQ(h["unknown_positive_cells"].get<int>(), unknown) << h.dump();
  const double pos = h["positive_cells"].get<double>();
  // Known positives: rock 1's cells at 0.9 above every negative, its rim and rock 2's rim tied with them at 0.1.
  EXPECT_NEAR(h["auc"].get<double>(), (high + 0.5 * (pos - high)) / pos, 1e-9) << h.dump();
  // Scored as 0, rock 2's unknown cells rank below every negative: each costs 1 / (pos + unknown).
  EXPECT_NEAR(h["auc_unknown_as_zero"].get<double>(), h["auc"].get<double>() * pos / (pos + unknown), 1e-9) << h.dump();
  // With every cell known the two readings agree.
  cv::imwrite((hd.map / "hazard.tiff").string(), cv::Mat(100, 100, CV_32F, cv::Scalar(0.1)));
  const nlohmann::json k = evaluate_map(hd.drive, hd.map)["hazard"];
  EXPECT_EQ(k["unknown_cells"].get<int>(), 0);
  EXPECT_DOUBLE_EQ(k["auc_unknown_as_zero"].get<double>(), k["auc"].get<double>());
}

// The independent development drives (../shared/data/synthetic_dev/traverse): the corrected pose
// must beat the drifting wheel odometry it starts from.
TEST(DevelopmentDrives, CorrectedPosesBeatWheelOdometry) {
  const fs::path root = fs::path(REGOLITH_SHARED_DIR) / "data" / "synthetic_dev" / "traverse";
  if (!fs::exists(root)) GTEST_SKIP() << root << " not present";
  double pos = 0, wpos = 0, head = 0, whead = 0, f1 = 0, auc = 0;
  int n = 0;
  for (const auto& entry : fs::directory_iterator(root)) {
    if (!fs::exists(entry.path() / "truth_poses.csv")) continue;
    const regolith::testing::TempDir out_dir("mapping_dev_" + entry.path().filename().string());
    const fs::path out = out_dir.path();
    map_drive(read_drive(entry.path()), DriveMapperParams{}, out);
    const nlohmann::json j = evaluate_map(entry.path(), out);
    pos += j["poses"]["final_position_error_pct"].get<double>();
    wpos += j["poses"]["wheel_final_position_error_pct"].get<double>();
    head += j["poses"]["final_heading_error_deg"].get<double>();
    whead += j["poses"]["wheel_final_heading_error_deg"].get<double>();
    EXPECT_GT(j["map"]["coverage"].get<double>(), 0.3) << entry.path();
    f1 += j["rocks"]["f1"].get<double>();
    auc += j["hazard"]["auc"].get<double>();
    ++n;
  }
  ASSERT_GT(n, 0);
  // Measured on the three dev drives: 1.09 % / 0.22 deg against the wheels' 1.79 % / 1.50 deg.
  EXPECT_LT(pos / n, 0.8 * wpos / n);
  EXPECT_LT(head / n, 0.4 * whead / n);
  // Rocks >= 10 cm and hazard (issue 14; goals F1 ~0.87, AUC 0.95): measured mean F1 0.39,
  // AUC 0.80 (parallax searches + sightings); the rectified-parallax map before them scored 0.08 / 0.74.
  EXPECT_GT(f1 / n, 0.30);
  EXPECT_GT(auc / n, 0.75);
}

// The same drive seen by a camera of twice the resolution (frames upsampled 2x, intrinsics scaled)
// must map as well: the pixel parameters are given for 320 px frames and grow with the camera
// (RockSightingParams::scaled_to_width), and the rocks are sighted in a working frame of at most
// 480 px (max_width_px). Measured (320 px -> 640 px): traverse_dev_0 hazard AUC 0.852 -> 0.840,
// rock F1 0.39 -> 0.39; traverse_dev_1 AUC 0.918 -> 0.894, F1 0.55 -> 0.44. Sighted at full size,
// dev_1's F1 was 0.24 at 640 px; with the 320 px scales at 640 px dev_0's AUC was 0.773.
TEST(DevelopmentDrives, TwiceTheResolutionMapsAsWell) {
  for (const char* name : {"traverse_dev_0", "traverse_dev_1"}) {
    SCOPED_TRACE(name);
    const fs::path dir = fs::path(REGOLITH_SHARED_DIR) / "data" / "synthetic_dev" / "traverse" / name;
    if (!fs::exists(dir / "truth_poses.csv")) GTEST_SKIP() << dir << " not present";
    const RecordedDrive drive = read_drive(dir);
    RecordedDrive twice = drive;
    twice.camera.fx *= 2;
    twice.camera.fy *= 2;
    twice.camera.cx = 2 * drive.camera.cx + 0.5;  // pixel centres at integer coordinates
    twice.camera.cy = 2 * drive.camera.cy + 0.5;
    twice.camera.width *= 2;
    twice.camera.height *= 2;
    const regolith::testing::TempDir frames("mapping_dev_twice_frames");
    for (DriveFrame& f : twice.frames) {
      cv::Mat big;
      cv::resize(cv::imread(f.file.string(), cv::IMREAD_GRAYSCALE), big, cv::Size(), 2.0, 2.0, cv::INTER_CUBIC);
      f.file = frames.path() / f.file.filename();
      ASSERT_TRUE(cv::imwrite(f.file.string(), big));
    }
    const regolith::testing::TempDir out1("mapping_dev_once"), out2("mapping_dev_twice");
    map_drive(drive, DriveMapperParams{}, out1.path());
    map_drive(twice, DriveMapperParams{}, out2.path());
    const nlohmann::json j1 = evaluate_map(dir, out1.path()), j2 = evaluate_map(dir, out2.path());
    const double auc1 = j1["hazard"]["auc"].get<double>(), auc2 = j2["hazard"]["auc"].get<double>();
    const double f1 = j1["rocks"]["f1"].get<double>(), f2 = j2["rocks"]["f1"].get<double>();
    std::printf("%s 320 px: hazard AUC %.3f, rock F1 %.2f; 640 px: AUC %.3f, F1 %.2f\n", name, auc1, f1, auc2, f2);
    EXPECT_GT(auc2, auc1 - 0.035);
    EXPECT_GT(f2, f1 - 0.15);
    EXPECT_GT(j2["map"]["coverage"].get<double>(), j1["map"]["coverage"].get<double>() - 0.05);
    EXPECT_LT(j2["poses"]["final_position_error_pct"].get<double>(),
              j1["poses"]["final_position_error_pct"].get<double>() + 0.5);
  }
}

}  // namespace
