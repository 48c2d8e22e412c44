#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "regolith/track_scene/track_scene.hpp"

using namespace regolith::track_scene;

TEST(TrackScene, RutDepthFollowsRigidWheelRelation) {
  TrackSceneParams p;
  p.tracks = {{0.4, 60.0}, {-0.4, 150.0}};
  const TrackScene s = generate_track_scene(p);
  ASSERT_EQ(s.truth.size(), 2u);
  for (const auto& t : s.truth) {
    const double z = std::pow(3.0 * t.load_n / (2.0 * 0.10 * 5e5 * std::sqrt(0.30)), 2.0 / 3.0);
    EXPECT_NEAR(t.mean_sinkage_m, z, 1e-12);
    EXPECT_NEAR(s.height_at(2.0, t.lateral_m), -z, 1e-4);         // rut floor
    EXPECT_NEAR(s.height_at(2.0, t.lateral_m + 0.2), 0.0, 1e-6);  // undisturbed ground
  }
  // heavier wheel, deeper rut: z ~ W^(2/(2n+1))
  EXPECT_NEAR(s.truth[1].mean_sinkage_m / s.truth[0].mean_sinkage_m, std::pow(2.5, 2.0 / 3.0), 1e-9);
}

TEST(TrackScene, RenderedImageIsLambertianAndDeterministic) {
  TrackSceneParams p;
  p.noise_dn = 0.0;
  p.albedo_texture = 0.0;
  const TrackScene a = generate_track_scene(p);
  const TrackScene b = generate_track_scene(p);
  ASSERT_EQ(a.image.type(), CV_8U);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  // flat ground far from the ruts: DN = gain * albedo * sin(elevation)
  double u = 0, v = 0;
  ASSERT_TRUE(project(p.camera, 2.0, 0.0, 0.0, u, v));
  const double expect = p.gain_dn * p.albedo * std::sin(p.sun.elevation_rad);
  EXPECT_NEAR(a.image.at<unsigned char>(static_cast<int>(std::lround(v)), static_cast<int>(std::lround(u))), expect,
              1.0);
  // the rut wall facing the sun (sun on the left, +y) is the one on the right side of the rut
  ASSERT_TRUE(project(p.camera, 2.0, 0.4 - 0.05 - 0.01, -0.01, u, v));
  EXPECT_GT(a.image.at<unsigned char>(static_cast<int>(std::lround(v)), static_cast<int>(std::lround(u))), expect + 20);
}

TEST(TrackScene, ProjectionMatchesPitchGeometry) {
  CameraModel c;
  double u = 0, v = 0;
  const double x = c.mount_height_m / std::tan(c.pitch_rad);  // optical axis hits the ground here
  ASSERT_TRUE(project(c, x, 0.0, 0.0, u, v));
  EXPECT_NEAR(u, c.cx, 1e-9);
  EXPECT_NEAR(v, c.cy, 1e-9);
  ASSERT_TRUE(project(c, x, 0.5, 0.0, u, v));
  EXPECT_LT(u, c.cx);  // +y is left
  EXPECT_FALSE(project(c, -1.0, 0.0, 0.0, u, v));
}

TEST(TrackScene, ValidateNamesField) {
  TrackSceneParams p;
  p.wheel_width_m = -1;
  try {
    generate_track_scene(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("wheel_width_m"), std::string::npos);
  }
  p = {};
  p.tracks = {{0.0, 0.0}};
  EXPECT_THROW(generate_track_scene(p), std::invalid_argument);
}
