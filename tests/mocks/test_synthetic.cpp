#include <gtest/gtest.h>

#include "mock_test_util.hpp"

#ifdef REGOLITH_HAVE_WHEEL_SCENE
#include "regolith/wheel_scene/wheel_scene.hpp"
#endif

namespace regolith::mocks::test {
namespace {

#ifdef REGOLITH_HAVE_TERRAIN_SCENE
TEST(SyntheticTerrain, RendersMovingDeterministicFrames) {
  Fixture fx;
  const std::string yaml =
      "backend: synthetic_terrain\nwidth: 96\nheight: 72\nframes: 3\nrate_hz: 2\n"
      "speed_m_s: 0.4\nresolution_m: 0.05\n";
  auto a = fx.camera(yaml + "seed: 4\n");
  auto b = fx.camera(yaml + "seed: 4\n");
  auto c = fx.camera(yaml + "seed: 5\n");
  EXPECT_EQ(a->format().width, 96);
  a->start();
  b->start();
  c->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease fa, fb, fc;
  std::vector<cv::Mat> seen;
  for (int k = 0; k < 3; ++k) {
    const TimeNs t = t0 + k * 500 * kNsPerMs;
    ASSERT_TRUE(a->latest(t, fa));
    ASSERT_TRUE(b->latest(t, fb));
    ASSERT_TRUE(c->latest(t, fc));
    EXPECT_EQ(fa->sequence, static_cast<std::uint64_t>(k));
    EXPECT_EQ(cv::norm(fa->image, fb->image, cv::NORM_INF), 0.0) << "same seed, same frames";
    EXPECT_GT(cv::norm(fa->image, fc->image, cv::NORM_L1), 0.0) << "other seed, other terrain";
    const double mean = cv::mean(fa->image)[0];
    EXPECT_GT(mean, 20.0);
    EXPECT_LT(mean, 250.0);
    seen.push_back(fa->image.clone());
  }
  EXPECT_GT(cv::norm(seen[0], seen[2], cv::NORM_L1) / static_cast<double>(seen[0].total()), 1.0) << "the rover moved";
}

TEST(SyntheticTerrain, LeavingTheTerrainIsAConfigError) {
  Fixture fx;
  const std::string msg = config_error(
      [&] { fx.camera("backend: synthetic_terrain\nwidth: 32\nheight: 24\nframes: 30\nrate_hz: 1\nspeed_m_s: 1\n"); });
  EXPECT_NE(msg.find("leaves the terrain at frame 12"), std::string::npos) << msg;
}

TEST(SyntheticTerrain, TooManyFramesToHoldAreAConfigErrorNotAnEndlessRender) {
  Fixture fx;
  const std::string msg = config_error(
      [&] { fx.camera("backend: synthetic_terrain\nwidth: 4096\nheight: 4096\nformat: bgr8\nframes: 10000\n"); });
  EXPECT_NE(
      msg.find("frames: 10000 frames of 4096x4096 x 3 B are 468.8 GiB, more than the 1 GiB a mock camera may hold"),
      std::string::npos)
      << msg;
}
#endif

#ifdef REGOLITH_HAVE_WHEEL_SCENE
TEST(SyntheticWheel, FramesAndEncoderAnglesMatch) {
  Fixture fx;
  const std::string body =
      "frames: 4\nrate_hz: 10\nsample_rate_hz: 100\nspeed_rad_s: 0.5\n"
      "initial_angle_rad: 0.1\nsinkage_mm: 15\nseed: 3\n";
  auto cam = fx.camera("backend: synthetic_wheel\n" + body);
  auto enc = fx.encoders("backend: synthetic_wheel\n" + body);
  ASSERT_EQ(enc->wheel_names().at(0), "wheel");
  const std::string too_many = config_error([&] { fx.camera("backend: synthetic_wheel\nframes: 10000\n"); });
  EXPECT_NE(too_many.find("frames: 10000 frames of 640x480 x 3 B are 8.6 GiB"), std::string::npos) << too_many;
  cam->start();
  enc->start();
  const TimeNs t0 = fx.clock.now();
  wheel_scene::SceneParams sp;
  sp.seed = 3;
  wheel_scene::WheelSceneGenerator gen(sp);
  // The generator's sensor noise is a random stream: render the reference frames in order.
  std::vector<cv::Mat> ref(4);
  for (int i = 0; i < 4; ++i) {
    const auto truth = gen.render_with_sinkage(0.1 + 0.05 * i, 15.0, ref[static_cast<std::size_t>(i)]);
    EXPECT_NEAR(truth.sinkage_mm, 15.0, 1e-6);
  }
  hal::FrameLease f;
  hal::AngleSample s;
  for (int k : {0, 1, 3, 5}) {  // frame 5 loops back to frame 1
    const TimeNs t = t0 + k * 100 * kNsPerMs;
    ASSERT_TRUE(cam->latest(t, f));
    ASSERT_TRUE(enc->latest(0, t, s));
    EXPECT_EQ(s.stamp, f->capture_time);
    const double expect_angle = 0.1 + 0.5 * 0.1 * (k % 4);
    EXPECT_NEAR(s.angle, expect_angle, 1e-12) << k;
    EXPECT_EQ(cv::norm(f->image, ref[static_cast<std::size_t>(k % 4)], cv::NORM_INF), 0.0)
        << "frame " << k << " is the scene at the encoder angle";
  }
}

TEST(SyntheticWheel, ConfigCheckValidatesWithoutRendering) {
  // `regolith config check` (devices not opened) rendered every frame of the wheel scene: seconds
  // per deployment under ASan (tests/fuzz deployment_check: a timeout). Now one black frame of
  // the configured format, and bad parameters are still refused.
  Fixture fx;
  auto cam = fx.camera("backend: synthetic_wheel\nframes: 50\nwidth: 320\nheight: 240\nformat: mono8\n", 0, false);
  EXPECT_EQ(cam->format().width, 320);
  EXPECT_EQ(cam->format().height, 240);
  cam->start();
  hal::FrameLease f;
  ASSERT_TRUE(cam->latest(fx.clock.now(), f));
  EXPECT_EQ(cv::countNonZero(f->image), 0);
  const std::string bad = config_error([&] { fx.camera("backend: synthetic_wheel\nsinkage_mm: -1\n", 0, false); });
  EXPECT_NE(bad.find("sinkage_mm"), std::string::npos) << bad;
}

TEST(SyntheticWheel, ALoopOfWholeLegSpacingsKeepsTheEncodersCounting) {
  // 4 frames at 10 Hz and pi rad/s: a loop turns the wheel 0.4 pi, one leg spacing (2 pi / 5), so the
  // looped frames are seamless and the encoders report the angle a real wheel would: pi t.
  Fixture fx;
  const double pi = 3.14159265358979323846;
  const std::string body = "frames: 4\nrate_hz: 10\nsample_rate_hz: 100\nspeed_rad_s: 3.141592653589793\n";
  auto cam = fx.camera("backend: synthetic_wheel\n" + body);
  auto enc = fx.encoders("backend: synthetic_wheel\n" + body);
  cam->start();
  enc->start();
  const TimeNs t0 = fx.clock.now();
  hal::AngleSample s;
  hal::FrameLease f, first;
  ASSERT_TRUE(cam->latest(t0, first));
  const cv::Mat frame0 = first->image.clone();
  first.reset();
  for (int k = 0; k <= 13; ++k) {  // 3 loops and a bit
    const TimeNs t = t0 + k * 100 * kNsPerMs;
    ASSERT_TRUE(enc->latest(0, t, s));
    ASSERT_TRUE(cam->latest(t, f));
    EXPECT_NEAR(s.angle, pi * 0.1 * k, 1e-9) << "frame " << k << ": no jump back at a loop";
    if (k % 4 == 0) {
      EXPECT_EQ(cv::norm(f->image, frame0, cv::NORM_INF), 0.0) << "frame " << k << " shows frame 0 again";
    }
  }
  // Any other loop repeats the angle with the frames (the first test's 0.5 rad/s loops back).
}
#endif

}  // namespace
}  // namespace regolith::mocks::test
