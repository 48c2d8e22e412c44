#include <cmath>

#include <gtest/gtest.h>

#include "regolith/terrain_scene/terrain_scene.hpp"

namespace {
using namespace regolith::terrain_scene;

SceneParams small() {
  SceneParams p;
  p.x_min_m = 0;
  p.x_max_m = 4;
  p.y_min_m = -2;
  p.y_max_m = 2;
  p.place_x_min_m = 0.5;
  p.place_x_max_m = 3.5;
  p.place_y_abs_max_m = 1.5;
  return p;
}

TEST(TerrainScene, DeterministicWithSeed) {
  const Terrain a(small()), b(small());
  EXPECT_EQ(cv::norm(a.height(), b.height(), cv::NORM_INF), 0.0);
  SceneParams p = small();
  p.seed = 2;
  const Terrain c(p);
  EXPECT_GT(cv::norm(a.height(), c.height(), cv::NORM_INF), 0.01);
  EXPECT_EQ(a.rocks().size(), 12u);
}

TEST(TerrainScene, RocksAreHalfEllipsoidsOfTheListedHeight) {
  SceneParams p = small();
  p.num_craters = 0;
  const Terrain t(p);
  for (const auto& rk : t.rocks()) {
    EXPECT_NEAR(t.height_at(rk.x_m, rk.y_m) - rk.base_z_m, rk.height_m, 0.01);
  }
  // Grid convention: row 0 / col 0 at +x/+y.
  EXPECT_DOUBLE_EQ(t.x_max(), 4.0);
  EXPECT_NEAR(t.x_min(), 0.0, 1e-9);
  EXPECT_FLOAT_EQ(static_cast<float>(t.height_at(4.0, 2.0)), t.height().at<float>(0, 0));
}

TEST(TerrainScene, OrthoFlatGroundBrightnessIsLambertian) {
  SceneParams p = small();
  p.fractal_rms_m = 0;
  p.num_rocks = 0;
  p.num_craters = 0;
  const Terrain t(p);
  RenderOptions ro;
  ro.albedo = 0.7;
  const Sun sun{0.3, 0.5};
  const auto o = render_ortho(t, sun, ro);
  EXPECT_NEAR(o.image.at<float>(50, 50), 0.7 * std::sin(0.5), 1e-5);
  EXPECT_NEAR(o.light_slant_rad, CV_PI / 2 - 0.5, 1e-9);
  // image +x = world -y, image +y = world -x: sun at azimuth 0.3 (ahead, slightly left).
  EXPECT_NEAR(o.light_tilt_rad, std::atan2(-std::cos(0.3), -std::sin(0.3)), 1e-9);
}

TEST(TerrainScene, CameraRangeOnFlatGroundAndRockBoxes) {
  SceneParams p = small();
  p.fractal_rms_m = 0;
  p.num_craters = 0;
  p.x_max_m = 8;
  p.place_x_min_m = 1.5;
  const Terrain t(p);
  CameraPose cam;
  cam.width = 160;
  cam.height = 120;
  cam.fx = cam.fy = 150;
  cam.cx = 79.5;
  cam.cy = 59.5;
  const auto img = render_camera(t, cam, {CV_PI, 0.7});
  // Bottom row centre sees flat ground at h / tan(pitch + beta).
  const double beta = std::atan((119 - cam.cy) / cam.fy);
  EXPECT_NEAR(img.range_m.at<float>(119, 80), cam.height_m / std::tan(cam.pitch_rad + beta), 1e-3);
  EXPECT_FALSE(img.rock_boxes.empty());
  for (const auto& b : img.rock_boxes) {
    const int id = b.rock_index;
    EXPECT_EQ(img.rock_id.at<int>(b.box.y + b.box.height / 2, b.box.x + b.box.width / 2) >= -1, true);
    int hits = 0;
    for (int r = b.box.y; r < b.box.y + b.box.height; ++r)
      for (int c = b.box.x; c < b.box.x + b.box.width; ++c) hits += img.rock_id.at<int>(r, c) == id;
    EXPECT_GT(hits, 0);
  }
  // Moving the camera forward shifts the view (a sequence of frames).
  CameraPose cam2 = cam;
  cam2.x_m += 0.5;
  const auto img2 = render_camera(t, cam2, {CV_PI, 0.7});
  EXPECT_GT(cv::norm(img.image, img2.image, cv::NORM_L1), 1.0);
}

TEST(TerrainScene, NoiseAndVignettingAreDeterministic) {
  const Terrain t(small());
  RenderOptions ro;
  ro.noise_sigma = 0.02;
  ro.vignetting = true;
  ro.a2 = -0.3;
  const auto a = render_ortho(t, {1.0, 0.6}, ro), b = render_ortho(t, {1.0, 0.6}, ro);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  const auto clean = render_ortho(t, {1.0, 0.6});
  EXPECT_LT(cv::mean(a.image(cv::Rect(0, 0, 20, 20)))[0], cv::mean(clean.image(cv::Rect(0, 0, 20, 20)))[0]);
}

TEST(TerrainScene, BadParameters) {
  SceneParams p = small();
  p.resolution_m = -1;
  try {
    Terrain t(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("resolution_m"), std::string::npos);
  }
  // Within 20000 cells per side but 1.9e8 cells (~4 GB): refused before anything is allocated.
  p = small();
  p.x_min_m = 0, p.x_max_m = 52, p.y_min_m = -46, p.y_max_m = 46, p.resolution_m = 0.005;
  try {
    p.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("resolution_m: grid of 191360000 cells, more than a scene may hold (2^26)"),
              std::string::npos)
        << e.what();
  }
  const Terrain t(small());
  CameraPose cam;
  cam.height_m = std::nan("");
  EXPECT_THROW(render_camera(t, cam, {0, 0.5}), std::invalid_argument);
  EXPECT_THROW(render_ortho(t, {0, -0.1}), std::invalid_argument);
}

}  // namespace
