// Dynamic mask geometry, parameter validation and bad input.
#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "error_of.hpp"
#include "scene_helpers.hpp"

namespace rs = regolith::sinkage;
namespace ws = regolith::wheel_scene;
using rs::testing::kDeg;

namespace {

using regolith::testing::error_of;

std::uint8_t mask_at(const rs::SinkageEstimator& e, double x, double y) {
  return e.mask().at<std::uint8_t>(static_cast<int>(std::lround(y)), static_cast<int>(std::lround(x)));
}

}  // namespace

// Mask with no sweep and no margin equals the hand-computed leg polygon (shaft + foot).
TEST(SinkageMask, MatchesHandComputedLegPolygon) {
  ws::SceneParams sp;
  rs::WheelGeometry g = ws::sinkage_geometry(sp.wheel);  // hub (320,110), L 300, w 28, foot 48x10
  rs::SinkageParams p = ws::sinkage_params(sp.wheel);
  p.angle_tolerance_rad = 0.0;
  p.mask_margin_px = 0.0;
  rs::SinkageEstimator est(g, p, sp.size);
  cv::Mat img(sp.size, CV_8UC3, cv::Scalar(110, 150, 185));
  rs::SinkageResult r;
  est.process(img, 0.0, r);  // leg 0 straight down; legs 1 and 4 at +-72 deg are outside +-40 deg
  ASSERT_EQ(r.leg_count, 1U);
  // shaft: |x - 320| <= 14 for 40 <= along < 290; foot |x - 320| <= 24 for 290 <= along <= 300
  EXPECT_NE(mask_at(est, 320, 110 + 200), 0);
  EXPECT_NE(mask_at(est, 320 + 13, 110 + 200), 0);
  EXPECT_NE(mask_at(est, 320 - 13, 110 + 200), 0);
  EXPECT_EQ(mask_at(est, 320 + 15, 110 + 200), 0);
  EXPECT_EQ(mask_at(est, 320 - 15, 110 + 200), 0);
  EXPECT_NE(mask_at(est, 320 + 23, 110 + 295), 0);
  EXPECT_EQ(mask_at(est, 320 + 23, 110 + 285), 0);
  EXPECT_EQ(mask_at(est, 320 + 25, 110 + 295), 0);
  EXPECT_EQ(mask_at(est, 320, 110 + 302), 0);
  EXPECT_EQ(mask_at(est, 320, 110 + 38), 0);  // inside the hub radius
  EXPECT_NE(mask_at(est, 320, 110 + 42), 0);
  // area equals the polygon area within the rasterisation of its boundary
  const double area = (290.0 - 40.0) * 28.0 + 10.0 * 48.0;
  const double boundary = 2.0 * (250.0 + 28.0) + 2.0 * (10.0 + 48.0);
  EXPECT_NEAR(cv::countNonZero(est.mask()), area, boundary);
}

// With the misalignment sweep, the mask covers the leg rotated by +-tolerance and nothing beyond.
TEST(SinkageMask, SweepCoversToleranceOnly) {
  ws::SceneParams sp;
  rs::WheelGeometry g = ws::sinkage_geometry(sp.wheel);
  rs::SinkageParams p = ws::sinkage_params(sp.wheel);
  p.angle_tolerance_rad = 6.0 * kDeg;
  p.mask_margin_px = 4.0;
  rs::SinkageEstimator est(g, p, sp.size);
  cv::Mat img(sp.size, CV_8UC3, cv::Scalar(110, 150, 185));
  rs::SinkageResult r;
  est.process(img, 0.0, r);
  auto at = [&](double r_px, double deg) {
    return mask_at(est, 320 + r_px * std::sin(deg * kDeg), 110 + r_px * std::cos(deg * kDeg));
  };
  // at radius 200: half width 14 + 4 = 18 px beyond the 6 deg ray -> ~11.2 deg
  EXPECT_NE(at(200, 5.9), 0);
  EXPECT_NE(at(200, -10.0), 0);
  EXPECT_EQ(at(200, 12.0), 0);
  EXPECT_EQ(at(200, -12.0), 0);
}

// The mask only covers legs that can touch the soil (within the contact window).
TEST(SinkageMask, OnlyContactWindowLegs) {
  ws::SceneParams sp;
  rs::WheelGeometry g = ws::sinkage_geometry(sp.wheel);
  rs::SinkageParams p = ws::sinkage_params(sp.wheel);
  rs::SinkageEstimator est(g, p, sp.size);
  cv::Mat img(sp.size, CV_8UC3, cv::Scalar(110, 150, 185));
  for (double enc_deg : {0.0, 17.0, 36.0, -30.0}) {
    rs::SinkageResult r;
    est.process(img, enc_deg * kDeg, r);
    int in_window = 0;
    for (int k = 0; k < g.leg_count; ++k) {
      if (std::abs(g.leg_angle(k, enc_deg * kDeg)) <= p.contact_half_angle_rad) ++in_window;
    }
    EXPECT_EQ(static_cast<int>(r.leg_count), in_window) << enc_deg;
    // every mask pixel lies within the window widened by the sweep and the leg's angular width
    const cv::Mat& m = est.mask();
    int bad = 0, total = 0;
    for (int y = 0; y < m.rows; ++y) {
      for (int x = 0; x < m.cols; ++x) {
        if (m.at<std::uint8_t>(y, x) == 0) continue;
        ++total;
        const double dx = x - g.hub_center_px.x, dy = y - g.hub_center_px.y;
        const double rho = std::hypot(dx, dy);
        const double psi = std::atan2(dx, dy);
        const double limit = p.contact_half_angle_rad + p.angle_tolerance_rad +
                             std::atan((0.5 * g.foot_width_px + p.mask_margin_px + 1.0) / std::max(rho, 1.0));
        if (std::abs(psi) > limit || rho > g.leg_length_px + 30.0) ++bad;
      }
    }
    EXPECT_GT(total, 5000) << enc_deg;
    EXPECT_EQ(bad, 0) << enc_deg;
    // and every contact leg's template centre line is covered
    for (std::size_t i = 0; i < r.leg_count; ++i) {
      const double phi = r.legs[i].encoder_angle_rad;
      for (double s = 60; s < 290; s += 20) {
        EXPECT_NE(mask_at(est, g.hub_center_px.x + s * std::sin(phi), g.hub_center_px.y + s * std::cos(phi)), 0);
      }
    }
    // the previous frame's mask was cleared: a leg outside the window has no mask pixels
    for (int k = 0; k < g.leg_count; ++k) {
      const double phi = g.leg_angle(k, enc_deg * kDeg);
      if (std::abs(phi) <= p.contact_half_angle_rad + 0.25) continue;
      const double x = g.hub_center_px.x + 200 * std::sin(phi), y = g.hub_center_px.y + 200 * std::cos(phi);
      if (x >= 0 && y >= 0 && x < m.cols && y < m.rows) {
        EXPECT_EQ(mask_at(est, x, y), 0) << k;
      }
    }
  }
}

TEST(SinkageValidation, GeometryErrorsNameTheField) {
  auto bad_geom = [](auto mutate) {
    rs::WheelGeometry g;
    mutate(g);
    return error_of([&] { g.validate(); });
  };
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.leg_width_px = -1; }).find("WheelGeometry.leg_width_px"),
            std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) {
              g.hub_center_px.x = std::numeric_limits<double>::quiet_NaN();
            }).find("WheelGeometry.hub_center_px.x"),
            std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.leg_count = 0; }).find("WheelGeometry.leg_count"), std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.leg_spacing_rad = 2.0; }).find("WheelGeometry.leg_spacing_rad"),
            std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.leg_length_px = 30; }).find("WheelGeometry.leg_length_px"),
            std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.foot_width_px = -3; }).find("WheelGeometry.foot_width_px"),
            std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.foot_thickness_px = 1000; }).find("WheelGeometry.foot_thickness_px"),
            std::string::npos);
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) { g.rotation_direction = 0; }).find("WheelGeometry.rotation_direction"),
            std::string::npos);
  EXPECT_NE(
      bad_geom([](rs::WheelGeometry& g) { g.angle_offset_rad = INFINITY; }).find("WheelGeometry.angle_offset_rad"),
      std::string::npos);
  EXPECT_EQ(bad_geom([](rs::WheelGeometry&) {}), "<no exception>");
  // A leg of 1e9 px passed and the estimator's tables threw std::bad_alloc at configure (found by
  // probing every deployment parameter at its bounds).
  EXPECT_NE(bad_geom([](rs::WheelGeometry& g) {
              g.leg_length_px = 1e9;
            }).find("WheelGeometry.leg_length_px: must be <= 32768 px"),
            std::string::npos);
  EXPECT_EQ(bad_geom([](rs::WheelGeometry& g) { g.leg_length_px = rs::kMaxLegLengthPx; }), "<no exception>");
}

TEST(SinkageValidation, ParamErrorsNameTheField) {
  auto bad_params = [](auto mutate) {
    rs::SinkageParams p;
    mutate(p);
    return error_of([&] { p.validate(); });
  };
  EXPECT_NE(bad_params([](rs::SinkageParams& p) { p.ema_alpha = 0; }).find("SinkageParams.ema_alpha"),
            std::string::npos);
  EXPECT_NE(bad_params([](rs::SinkageParams& p) { p.open_kernel_px = 4; }).find("SinkageParams.open_kernel_px"),
            std::string::npos);
  EXPECT_NE(bad_params([](rs::SinkageParams& p) {
              p.mm_per_px = std::numeric_limits<double>::quiet_NaN();
            }).find("SinkageParams.mm_per_px"),
            std::string::npos);
  EXPECT_NE(bad_params([](rs::SinkageParams& p) { p.sat_min = 1.5; }).find("SinkageParams.sat_min"), std::string::npos);
  EXPECT_NE(bad_params([](rs::SinkageParams& p) { p.median_window = 0; }).find("SinkageParams.median_window"),
            std::string::npos);
  EXPECT_NE(
      bad_params([](rs::SinkageParams& p) { p.angle_tolerance_rad = -0.1; }).find("SinkageParams.angle_tolerance_rad"),
      std::string::npos);
  EXPECT_EQ(bad_params([](rs::SinkageParams&) {}), "<no exception>");
  // the constructor validates too
  rs::WheelGeometry g;
  g.leg_width_px = 0;
  EXPECT_THROW(rs::SinkageEstimator(g, rs::SinkageParams{}, {640, 480}), std::invalid_argument);
  EXPECT_THROW(rs::SinkageEstimator(rs::WheelGeometry{}, rs::SinkageParams{}, {0, 480}), std::invalid_argument);
  // leg_length_mm overrides mm_per_px (thesis L / plz)
  rs::SinkageParams p;
  p.leg_length_mm = 150.0;
  EXPECT_DOUBLE_EQ(p.scale_mm_per_px(rs::WheelGeometry{}), 0.5);
}

TEST(SinkageBadInput, ImageErrorsAreClear) {
  rs::SinkageEstimator est(rs::WheelGeometry{}, rs::SinkageParams{}, {640, 480});
  rs::SinkageResult r;
  EXPECT_NE(error_of([&] { est.process(cv::Mat(), 0.0, r); }).find("bgr: empty image"), std::string::npos);
  EXPECT_NE(error_of([&] { est.process(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), 0.0, r); }).find("expected CV_8UC3"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              est.process(cv::Mat(240, 320, CV_8UC3, cv::Scalar(0)), 0.0, r);
            }).find("expected 640x480 (got 320x240)"),
            std::string::npos);
  EXPECT_NE(error_of([&] { est.process(cv::Mat(480, 640, CV_32FC3, cv::Scalar(0)), 0.0, r); }).find("expected CV_8UC3"),
            std::string::npos);
}

// Stale or missing encoder data (NaN angle) -> invalid, confidence 0, counted.
TEST(SinkageBadInput, NanAngleGivesInvalidResult) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  rs::SinkageEstimator est(ws::sinkage_geometry(sp.wheel), ws::sinkage_params(sp.wheel), sp.size);
  cv::Mat img;
  gen.render_with_sinkage(0.2, 20.0, img);
  rs::SinkageResult r;
  est.process(img, 0.2, r);
  ASSERT_TRUE(r.valid);
  est.process(img, std::numeric_limits<double>::quiet_NaN(), r);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.confidence, 0.0);
  EXPECT_EQ(r.sinkage_mm, 0.0);
  EXPECT_EQ(r.reason, rs::InvalidReason::kBadAngle);
  est.process(img, INFINITY, r);
  EXPECT_EQ(r.reason, rs::InvalidReason::kBadAngle);
  EXPECT_EQ(est.diagnostics().frames, 3U);
  EXPECT_EQ(est.diagnostics().valid_frames, 1U);
  EXPECT_EQ(est.diagnostics().frame_reasons[static_cast<std::size_t>(rs::InvalidReason::kBadAngle)], 2U);
}

// A frame without any visible leg (soil everywhere) and a leg colour that never matches.
TEST(SinkageBadInput, NoVisibleLegAndWrongColour) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  for (bool poor : {false, true}) {
    gen.set_illumination(poor ? ws::Illumination::poor() : ws::Illumination::normal());
    rs::SinkageEstimator est(ws::sinkage_geometry(sp.wheel), ws::sinkage_params(sp.wheel), sp.size);
    cv::Mat img;
    gen.render_at_soil_level(0.1, -10.0, img);  // soil covers the whole image
    rs::SinkageResult r;
    est.process(img, 0.1, r);
    EXPECT_FALSE(r.valid) << poor;
    EXPECT_EQ(r.confidence, 0.0);
    EXPECT_EQ(r.reason, rs::InvalidReason::kNoLegPixels) << rs::to_string(r.reason);
    EXPECT_EQ(est.diagnostics().frame_reasons[static_cast<std::size_t>(rs::InvalidReason::kNoLegPixels)], 1U);
  }
  rs::SinkageParams green = ws::sinkage_params(sp.wheel);
  green.mode = rs::SegmentationMode::kHsv;
  green.hue_min_deg = 90;
  green.hue_max_deg = 150;
  gen.set_illumination(ws::Illumination::normal());
  rs::SinkageEstimator est(ws::sinkage_geometry(sp.wheel), green, sp.size);
  cv::Mat img;
  gen.render_with_sinkage(0.1, 20.0, img);
  rs::SinkageResult r;
  est.process(img, 0.1, r);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.reason, rs::InvalidReason::kNoLegPixels);
  EXPECT_GE(est.diagnostics().leg_reasons[static_cast<std::size_t>(rs::InvalidReason::kNoLegPixels)], 1U);
}

// Calibration geometry outside the image and an encoder far from the legs.
TEST(SinkageBadInput, GeometryOutsideImageAndWrongEncoder) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  cv::Mat img;
  gen.render_with_sinkage(0.0, 20.0, img);
  rs::WheelGeometry far = ws::sinkage_geometry(sp.wheel);
  far.hub_center_px = {-3000.0, -3000.0};
  rs::SinkageEstimator est(far, ws::sinkage_params(sp.wheel), sp.size);
  rs::SinkageResult r;
  est.process(img, 0.0, r);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.confidence, 0.0);
  EXPECT_EQ(r.reason, rs::InvalidReason::kOutsideImage);
  EXPECT_EQ(est.diagnostics().frame_reasons[static_cast<std::size_t>(rs::InvalidReason::kOutsideImage)], 1U);

  // encoder 36 deg away from the true legs: the masks fall between legs
  rs::SinkageEstimator est2(ws::sinkage_geometry(sp.wheel), ws::sinkage_params(sp.wheel), sp.size);
  est2.process(img, 36.0 * kDeg, r);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.confidence, 0.0);
  EXPECT_NE(r.reason, rs::InvalidReason::kNone);
}

TEST(SinkageOverlay, DrawsDistinctColours) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  rs::SinkageEstimator est(ws::sinkage_geometry(sp.wheel), ws::sinkage_params(sp.wheel), sp.size);
  cv::Mat img, out;
  gen.render_with_sinkage(0.0, 30.0, img);
  rs::SinkageResult r;
  est.process(img, 0.0, r);
  ASSERT_TRUE(r.valid);
  rs::draw_overlay(est, img, r, out);
  ASSERT_EQ(out.size(), img.size());
  int red = 0, green = 0, blue = 0;
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      const cv::Vec3b p = out.at<cv::Vec3b>(y, x);
      if (p[2] > 200 && p[1] < 60 && p[0] < 60) ++red;
      if (p[1] > 200 && p[2] < 60 && p[0] < 60) ++green;
      if (p[0] > 200 && p[1] < 100 && p[2] < 60) ++blue;
    }
  }
  EXPECT_GT(red, 100);
  EXPECT_GT(green, 10);
  EXPECT_GT(blue, 10);
  EXPECT_THROW(rs::draw_overlay(cv::Mat(), est.geometry(), r, out), std::invalid_argument);
}
