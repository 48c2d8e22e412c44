// Calibration from an un-sunk frame recovers the scene's geometry; YAML rendering.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "scene_helpers.hpp"

namespace rs = regolith::sinkage;
namespace ws = regolith::wheel_scene;
using rs::testing::kDeg;

namespace {

double wrap_period(double a, double period) {
  return std::remainder(a, period);
}

}  // namespace

TEST(SinkageCalibration, RecoversKnownGeometry) {
  struct Setup {
    cv::Point2d hub;
    double length, width, offset_deg, angle;
    bool poor;
  };
  for (const Setup& s : {Setup{{320, 110}, 300, 28, 0.0, 0.3, false}, Setup{{300, 130}, 280, 24, 10.0, -0.5, false},
                         Setup{{330, 100}, 300, 30, -5.0, 0.9, true}}) {
    ws::SceneParams sp;
    sp.wheel.hub_center_px = s.hub;
    sp.wheel.leg_length_px = s.length;
    sp.wheel.leg_width_px = s.width;
    sp.wheel.angle_offset_rad = s.offset_deg * kDeg;
    sp.light = s.poor ? ws::Illumination::poor() : ws::Illumination::normal();
    ws::WheelSceneGenerator gen(sp);
    cv::Mat img;
    // un-sunk: soil line 15 px below the lowest tip
    gen.render_at_soil_level(s.angle, gen.lowest_tip_y(s.angle) + 15.0, img);
    const rs::CalibrationReport rep = rs::calibrate_from_unsunk_frame(img, s.angle);
    const rs::WheelGeometry& g = rep.geometry;
    EXPECT_GE(rep.legs_used, 3);
    EXPECT_LT(rep.hub_fit_rms_px, 1.5);
    EXPECT_NEAR(g.hub_center_px.x, s.hub.x, 1.5);
    EXPECT_NEAR(g.hub_center_px.y, s.hub.y, 1.5);
    EXPECT_NEAR(g.leg_length_px, s.length, 3.0);
    EXPECT_NEAR(g.leg_width_px, s.width, 2.0);
    EXPECT_NEAR(g.hub_radius_px, sp.wheel.hub_radius_px, 3.0);
    EXPECT_NEAR(g.foot_width_px, sp.wheel.foot_width_px, 4.0);
    EXPECT_NEAR(g.foot_thickness_px, sp.wheel.foot_thickness_px, 3.0);
    EXPECT_NEAR(wrap_period(g.angle_offset_rad - s.offset_deg * kDeg, g.leg_spacing_rad), 0.0, 1.0 * kDeg);

    // the calibrated geometry measures sinkage as well as the true one
    rs::SinkageEstimator est(g, ws::sinkage_params(sp.wheel), sp.size);
    for (double depth : {10.0, 35.0}) {
      cv::Mat f;
      const double a = s.angle + 0.2;
      const ws::FrameTruth t = gen.render_with_sinkage(a, depth, f);
      rs::SinkageResult r;
      est.process(f, a, r);
      ASSERT_TRUE(r.valid);
      EXPECT_NEAR(r.sinkage_mm, t.sinkage_mm, 2.0);
    }
  }
}

TEST(SinkageCalibration, BadInput) {
  EXPECT_THROW(rs::calibrate_from_unsunk_frame(cv::Mat(), 0.0), std::invalid_argument);
  EXPECT_THROW(rs::calibrate_from_unsunk_frame(cv::Mat(10, 10, CV_8UC1), 0.0), std::invalid_argument);
  cv::Mat sand(480, 640, CV_8UC3, cv::Scalar(110, 150, 185));
  EXPECT_THROW(rs::calibrate_from_unsunk_frame(sand, NAN), std::invalid_argument);
  try {
    rs::calibrate_from_unsunk_frame(sand, 0.0);
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("found 0 leg(s)"), std::string::npos) << e.what();
  }
}

TEST(SinkageCalibration, YamlBlock) {
  rs::WheelGeometry g;
  g.hub_center_px = {321.5, 109.25};
  g.leg_length_px = 299.5;
  const std::string y = rs::geometry_to_yaml(g, 2);
  EXPECT_NE(y.find("  geometry:\n"), std::string::npos);
  EXPECT_NE(y.find("    hub_center_px: [321.5, 109.25]\n"), std::string::npos);
  EXPECT_NE(y.find("    leg_length_px: 299.5\n"), std::string::npos);
  EXPECT_NE(y.find("    leg_count: 5\n"), std::string::npos);
  EXPECT_NE(y.find("    rotation_direction: 1\n"), std::string::npos);
  EXPECT_NE(y.find("    angle_offset_rad: 0\n"), std::string::npos);
}
