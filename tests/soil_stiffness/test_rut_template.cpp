// The rut template fit (rut_template.hpp): its rendered cross-section behaves as the geometry of
// sun and rut says, and the fit recovers depth and centre from an image of that model, through
// the camera's perspective, with noise. Accuracy on an independent renderer: test_soil_scene.cpp.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/soil_stiffness/rut_template.hpp"

namespace soil = regolith::soil;
namespace dd = regolith::direct_depth;

namespace {

dd::CameraModel rear_camera() {
  dd::CameraModel c;
  c.fx = c.fy = 600.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  c.mount_height_m = 0.8;
  c.pitch_rad = 0.75;
  return c;
}

soil::RutLight low_sun_from_left() {
  soil::RutLight l;
  l.sun.azimuth_rad = 1.4;     // nearly across the track, from the left (+y)
  l.sun.elevation_rad = 0.35;  // 20 deg: below the 40-deg walls
  l.flat_dn = 120.0;
  l.ambient = 0.05;
  return l;
}

constexpr double kWheel = 0.12;

// The rear camera's image of one rut (depth z, centre `centre` m left) of the template's own model,
// with 4 DN of noise.
cv::Mat render_rut(const dd::CameraModel& cam, const soil::RutLight& l, double z, double centre) {
  const dd::DirectDepth geometry(cam);
  soil::RutTemplateFit render(cam, kWheel, {}, {}, 10);
  cv::Mat img(cam.height, cam.width, CV_8UC1);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 4.0);
  for (int r = 0; r < cam.height; ++r)
    for (int c = 0; c < cam.width; ++c) {
      const auto g = geometry.ground(c, r);
      const double v = g.valid ? render.predict(l, centre, z, g.lateral_m - centre) : 0.0;
      img.at<unsigned char>(r, c) = cv::saturate_cast<unsigned char>(v + noise(rng));
    }
  return img;
}

}  // namespace

TEST(RutTemplate, FlatGroundIsFlatBrightnessEverywhere) {
  soil::RutTemplateFit fit(rear_camera(), kWheel, {}, {}, 10);
  const soil::RutLight l = low_sun_from_left();
  for (double off = -0.15; off <= 0.15; off += 0.01) EXPECT_NEAR(fit.predict(l, 0.2, 0.0, off), 120.0, 1e-6) << off;
}

TEST(RutTemplate, LowSunShadowsTheFloorUnderTheSunwardWallAndLightsTheOther) {
  soil::RutTemplateFit fit(rear_camera(), kWheel, {}, {}, 10);
  const soil::RutLight l = low_sun_from_left();
  const double z = 0.03;
  const double shadow = l.flat_dn * l.ambient / (std::sin(l.sun.elevation_rad) + l.ambient);
  // the floor next to the sunward (left, +y) wall lies in that wall's cast shadow
  EXPECT_NEAR(fit.predict(l, 0.2, z, 0.5 * kWheel * 0.8), shadow, 1.0);
  // the far (right, -y) wall faces the sun: brighter than flat ground
  const double wall = -(0.5 * kWheel + 0.5 * z / std::tan(0.70));
  EXPECT_GT(fit.predict(l, 0.2, z, wall), 1.5 * l.flat_dn);
  // the sunward wall faces away from the sun: self-shadowed
  EXPECT_NEAR(fit.predict(l, 0.2, z, -wall), shadow, 1.0);
  // a shallower rut throws a shorter shadow: the floor's middle is lit at 5 mm
  EXPECT_NEAR(fit.predict(l, 0.2, 0.005, 0.0), l.flat_dn, 1.0);
}

// Any sun: from either side, along the track ahead (no cross-track shading, no cast shadow across
// the rut: the walls' shading and widths remain), behind the camera.
class RutTemplateSun : public ::testing::TestWithParam<double> {};

TEST_P(RutTemplateSun, FitRecoversDepthAndCentreThroughPerspectiveAndNoise) {
  const dd::CameraModel cam = rear_camera();
  soil::RutLight l = low_sun_from_left();
  l.sun.azimuth_rad = GetParam();
  const double z_true = 0.023, centre_true = 0.205;
  const cv::Mat img = render_rut(cam, l, z_true, centre_true);
  std::vector<double> ranges;
  for (double x = 0.8; x < 1.9; x += 0.01) ranges.push_back(x);  // the image sees 0.38-2.1 m
  std::vector<double> depth(ranges.size());
  soil::RutTemplateFit fit(cam, kWheel, {}, {}, static_cast<int>(ranges.size()));
  const double centre = fit.fit(img, l, 0.2, ranges.data(), static_cast<int>(ranges.size()), 10, depth.data());
  EXPECT_NEAR(centre, centre_true, 0.003);
  int n = 0;
  for (double z : depth) {
    ASSERT_TRUE(std::isfinite(z));
    EXPECT_NEAR(z, z_true, 0.001);
    ++n;
  }
  EXPECT_EQ(n, static_cast<int>(ranges.size()));
}

INSTANTIATE_TEST_SUITE_P(Azimuths, RutTemplateSun, ::testing::Values(1.4, -1.4, 0.0, 3.14159, 2.5, -0.6));

// The fit reads each hypothesis' footprint means once per window on the lattice of sample offsets
// when the centre step is a whole number of sample steps (the defaults: 2 mm each), instead of once
// per (sample, centre offset): the same costs, so the same depths and centre as the direct
// evaluation (a centre step one part in a million longer takes that path).
TEST(RutTemplate, TheLatticeOfFootprintMeansFitsAsTheDirectEvaluation) {
  const dd::CameraModel cam = rear_camera();
  const soil::RutLight l = low_sun_from_left();
  const cv::Mat img = render_rut(cam, l, 0.017, 0.21);
  std::vector<double> ranges;
  for (double x = 0.8; x < 1.9; x += 0.01) ranges.push_back(x);
  const int n = static_cast<int>(ranges.size());
  soil::RutTemplateParams direct;
  direct.centre_step_m *= 1.000001;
  std::vector<double> d_lattice(ranges.size()), d_direct(ranges.size());
  soil::RutTemplateFit lattice_fit(cam, kWheel, {}, {}, n), direct_fit(cam, kWheel, {}, direct, n);
  const double c_lattice = lattice_fit.fit(img, l, 0.2, ranges.data(), n, 10, d_lattice.data());
  const double c_direct = direct_fit.fit(img, l, 0.2, ranges.data(), n, 10, d_direct.data());
  EXPECT_NEAR(c_lattice, c_direct, 1e-6);
  EXPECT_NEAR(c_lattice, 0.21, 0.003);
  for (int i = 0; i < n; ++i) {
    ASSERT_TRUE(std::isfinite(d_lattice[static_cast<std::size_t>(i)])) << i;
    EXPECT_NEAR(d_lattice[static_cast<std::size_t>(i)], d_direct[static_cast<std::size_t>(i)], 1e-6) << i;
    EXPECT_NEAR(d_lattice[static_cast<std::size_t>(i)], 0.017, 0.001) << i;
  }
}

// A rut inside a larger shadow (the rover's own, a rock's): the cross-section is uniformly dark,
// at the ambient level, and no depth explains it better than another. Not measurable (NaN),
// counted, never a made-up number.
TEST(RutTemplate, RutInFullShadowIsNotMeasurable) {
  const dd::CameraModel cam = rear_camera();
  const soil::RutLight l = low_sun_from_left();
  const double shadow = l.flat_dn * l.ambient / (std::sin(l.sun.elevation_rad) + l.ambient);
  cv::Mat img(cam.height, cam.width, CV_8UC1);
  cv::randn(img, shadow, 2.0);
  std::vector<double> ranges;
  for (double x = 0.8; x < 1.9; x += 0.01) ranges.push_back(x);
  std::vector<double> depth(ranges.size());
  soil::RutTemplateFit fit(cam, kWheel, {}, {}, static_cast<int>(ranges.size()));
  fit.fit(img, l, 0.2, ranges.data(), static_cast<int>(ranges.size()), 10, depth.data());
  for (double z : depth) EXPECT_TRUE(std::isnan(z)) << z;
  EXPECT_EQ(fit.unmeasurable_windows(), static_cast<int>((ranges.size() + 9) / 10));
}

TEST(RutTemplate, BadParametersAreNamed) {
  soil::RutTemplateParams p;
  p.max_sinkage_m = -1;
  try {
    p.validate();
    FAIL() << "accepted a negative max_sinkage_m";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_sinkage_m"), std::string::npos) << e.what();
  }
  soil::RutShape s;
  s.wall_slope_rad = 2.0;
  EXPECT_THROW(s.validate(), std::invalid_argument);
}
