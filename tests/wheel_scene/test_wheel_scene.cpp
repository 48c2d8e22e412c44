// Synthetic wheel-leg scene: ground truth geometry, rendering, sequences and the sequence CSV.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "error_of.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"
#include "temp_dir.hpp"

namespace ws = regolith::wheel_scene;
namespace fs = std::filesystem;
constexpr double kDeg = std::numbers::pi / 180.0;

namespace {

using regolith::testing::error_of;

bool is_blue(const cv::Vec3b& p) {
  return p[0] > p[2] + 60 && p[0] > p[1] + 30;
}

}  // namespace

TEST(WheelScene, TruthGeometry) {
  ws::SceneParams sp;  // hub (320, 110), leg 300 px, 0.5 mm/px, 5 legs
  ws::WheelSceneGenerator gen(sp);
  int leg = -1;
  EXPECT_NEAR(gen.lowest_tip_y(0.0, &leg), 410.0, 1e-9);
  EXPECT_EQ(leg, 0);
  // at 36 deg legs 0 and 4 are symmetric about the vertical
  EXPECT_NEAR(gen.lowest_tip_y(36.0 * kDeg), 110.0 + 300.0 * std::cos(36.0 * kDeg), 1e-9);
  EXPECT_NEAR(gen.leg_angle(1, 0.0), 72.0 * kDeg, 1e-12);
  EXPECT_NEAR(gen.leg_angle(3, 0.0), -144.0 * kDeg, 1e-12);  // wrapped to (-pi, pi]
  cv::Mat img;
  ws::FrameTruth t = gen.render_at_soil_level(0.0, 380.0, img);
  EXPECT_NEAR(t.sinkage_px, 30.0, 1e-9);
  EXPECT_NEAR(t.sinkage_mm, 15.0, 1e-9);
  t = gen.render_at_soil_level(0.0, 420.0, img);  // soil below the tips
  EXPECT_EQ(t.sinkage_mm, 0.0);
  t = gen.render_with_sinkage(0.2, 12.5, img);
  EXPECT_NEAR(t.sinkage_mm, 12.5, 1e-9);
  EXPECT_NEAR(t.soil_y_px, gen.lowest_tip_y(0.2) - 25.0, 1e-9);
  // misalignment moves the true legs, not the encoder reading
  gen.set_misalignment(4.0 * kDeg);
  EXPECT_NEAR(gen.leg_angle(0, 0.0), 4.0 * kDeg, 1e-12);
  // rotation direction flips the sign of the encoder angle
  sp.wheel.rotation_direction = -1;
  ws::WheelSceneGenerator rev(sp);
  EXPECT_NEAR(rev.leg_angle(0, 0.3), -0.3, 1e-12);
}

TEST(WheelScene, RenderedPixelsFollowTheGeometry) {
  ws::SceneParams sp;
  sp.light.noise_sigma = 0;
  ws::WheelSceneGenerator gen(sp);
  cv::Mat img;
  gen.render_at_soil_level(0.0, 350.0, img);  // leg 0 straight down, 60 px buried
  ASSERT_EQ(img.type(), CV_8UC3);
  ASSERT_EQ(img.size(), cv::Size(640, 480));
  EXPECT_TRUE(is_blue(img.at<cv::Vec3b>(250, 320)));  // leg above the soil
  EXPECT_TRUE(is_blue(img.at<cv::Vec3b>(345, 320)));
  EXPECT_FALSE(is_blue(img.at<cv::Vec3b>(355, 320)));  // buried part hidden by sand
  EXPECT_FALSE(is_blue(img.at<cv::Vec3b>(250, 340)));  // beside the leg (half width 14)
  EXPECT_FALSE(is_blue(img.at<cv::Vec3b>(110, 320)));  // hub
  // leg 1 at 72 deg, 200 px from the hub
  EXPECT_TRUE(is_blue(img.at<cv::Vec3b>(static_cast<int>(std::lround(110 + 200 * std::cos(72 * kDeg))),
                                        static_cast<int>(std::lround(320 + 200 * std::sin(72 * kDeg))))));
  // poor light is much darker and noisier
  ws::SceneParams dim = sp;
  dim.light = ws::Illumination::poor();
  ws::WheelSceneGenerator gdim(dim);
  cv::Mat d;
  gdim.render_at_soil_level(0.0, 350.0, d);
  EXPECT_LT(cv::mean(d)[0] * 4.0, cv::mean(img)[0]);
}

TEST(WheelScene, SequenceProfile) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  ws::SequenceSpec spec;
  spec.frames = 21;
  spec.max_sinkage_mm = 30;
  const auto seq = ws::make_sequence(gen, spec);
  ASSERT_EQ(seq.size(), 21U);
  EXPECT_EQ(seq[0].truth.sinkage_mm, 0.0);
  double mx = 0;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    EXPECT_NEAR(seq[i].truth.sinkage_mm, spec.profile_mm(static_cast<int>(i)), 1e-9);
    EXPECT_NEAR(seq[i].truth.encoder_angle_rad, spec.start_angle_rad + static_cast<double>(i) * spec.angle_step_rad,
                1e-12);
    mx = std::max(mx, seq[i].truth.sinkage_mm);
  }
  EXPECT_GT(mx, 29.0);
  EXPECT_LE(mx, 30.0 + 1e-9);
}

TEST(WheelScene, ValidationNamesTheField) {
  ws::SceneParams sp;
  sp.wheel.leg_width_px = -1;
  EXPECT_NE(error_of([&] { ws::WheelSceneGenerator g(sp); }).find("WheelModel.leg_width_px"), std::string::npos);
  sp = {};
  sp.light.noise_sigma = NAN;
  EXPECT_NE(error_of([&] { ws::WheelSceneGenerator g(sp); }).find("Illumination.noise_sigma"), std::string::npos);
  sp = {};
  sp.sand_on_leg_fraction = 0.9;
  EXPECT_NE(error_of([&] { ws::WheelSceneGenerator g(sp); }).find("SceneParams.sand_on_leg_fraction"),
            std::string::npos);
  sp = {};
  ws::WheelSceneGenerator g(sp);
  cv::Mat img;
  EXPECT_NE(error_of([&] { g.render_with_sinkage(0.0, -1.0, img); }).find("sinkage_mm"), std::string::npos);
  EXPECT_NE(error_of([&] { g.render_at_soil_level(NAN, 300.0, img); }).find("encoder_angle_rad"), std::string::npos);
}

TEST(WheelSceneCsv, RoundTripAndImages) {
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  ws::SequenceSpec spec;
  spec.frames = 4;
  const auto seq = ws::make_sequence(gen, spec);
  const regolith::testing::TempDir tmp("wheel_scene_roundtrip");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path csv = ws::write_sequence(dir, seq);
  const auto rows = ws::read_sequence_csv(csv);
  ASSERT_EQ(rows.size(), 4U);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_NEAR(rows[i].encoder_angle_rad, seq[i].truth.encoder_angle_rad, 1e-8);
    EXPECT_NEAR(rows[i].truth_mm, seq[i].truth.sinkage_mm, 1e-6);
    const cv::Mat back = cv::imread((dir / rows[i].frame).string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(back.empty()) << rows[i].frame;
    EXPECT_EQ(cv::norm(back, seq[i].bgr, cv::NORM_INF), 0.0);  // PNG is lossless
  }
}

TEST(WheelSceneCsv, MalformedFilesNameFileAndLine) {
  const regolith::testing::TempDir tmp("wheel_scene_malformed");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return dir / name;
  };
  const auto hdr = write("hdr.csv", "frame,angle,truth\na.png,0,0\n");
  EXPECT_NE(error_of([&] { ws::read_sequence_csv(hdr); }).find("hdr.csv:1: expected header"), std::string::npos);
  const auto cols = write("cols.csv", "frame,encoder_angle_rad,truth_mm\na.png,0.1,2\nb.png,0.2\n");
  EXPECT_NE(error_of([&] { ws::read_sequence_csv(cols); }).find("cols.csv:3: expected 3 columns (got 2)"),
            std::string::npos);
  const auto num = write("num.csv", "frame,encoder_angle_rad,truth_mm\na.png,zero,2\n");
  EXPECT_NE(error_of([&] {
              ws::read_sequence_csv(num);
            }).find("num.csv:2: column encoder_angle_rad: expected a finite number (got 'zero')"),
            std::string::npos);
  const auto nan = write("nan.csv", "frame,encoder_angle_rad,truth_mm\n# comment\na.png,0.1,nan\n");
  EXPECT_NE(error_of([&] { ws::read_sequence_csv(nan); }).find("nan.csv:3: column truth_mm"), std::string::npos);
  const auto trail = write("trail.csv", "frame,encoder_angle_rad,truth_mm\na.png,0.1,2x\n");
  EXPECT_NE(error_of([&] { ws::read_sequence_csv(trail); }).find("trail.csv:2: column truth_mm"), std::string::npos);
  const auto empty = write("empty.csv", "");
  EXPECT_NE(error_of([&] { ws::read_sequence_csv(empty); }).find("empty.csv: empty file"), std::string::npos);
  EXPECT_NE(error_of([&] { ws::read_sequence_csv(dir / "missing.csv"); }).find("missing.csv: cannot open"),
            std::string::npos);
  const auto ok = write("ok.csv", "frame,encoder_angle_rad,truth_mm\n\n a.png , -0.5 , 3.25 \n");
  const auto rows = ws::read_sequence_csv(ok);
  ASSERT_EQ(rows.size(), 1U);
  EXPECT_EQ(rows[0].frame, "a.png");
  EXPECT_DOUBLE_EQ(rows[0].encoder_angle_rad, -0.5);
  EXPECT_DOUBLE_EQ(rows[0].truth_mm, 3.25);
}
