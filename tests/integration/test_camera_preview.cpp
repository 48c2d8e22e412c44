// The mocked rover's camera previews (components/preview): under simulated time every terrain frame
// and the wheel camera at the preview rate give a JPEG of the camera's frame with the results drawn
// where the results put them.
#include <atomic>
#include <cstdio>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "cli_support.hpp"
#include "diagnostics.hpp"
#include "regolith/preview/component.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/saliency/component.hpp"
#include "regolith/sinkage/component.hpp"

using namespace regolith;

namespace {

using regolith::testing::diagnostics_of;

}  // namespace

TEST(CameraPreview, TheMockRoverPreviewsItsFrontAndWheelCameras) {
  cli::register_everything();
  auto cfg = Params::load_string(cli::embedded_mock_rover(), "<embedded>/config/mock_rover.yaml");
  auto app = runtime::Application::load(cfg, {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(6 * kNsPerSec, stop);
  app->stop();  // the preview workers finish what they were handed

  // front camera: 2 Hz frames, one preview each (frames 0..12)
  const auto front = diagnostics_of(*app, "front_preview");
  ASSERT_FALSE(front.empty());
  EXPECT_EQ(front.at("topic"), "preview/rocks/compressed");
  EXPECT_GE(std::stoi(front.at("previews")), 11) << "previews of 13 terrain frames";
  EXPECT_EQ(front.at("encode_failures"), "0");
  EXPECT_EQ(front.at("hazard_overlays"), front.at("previews"))
      << "every preview has the traversability grid of its frame (leased in step(), whatever the worker's pace)";
  auto& ctx = app->context();
  const auto rocks = ctx.channel<saliency::RockFrame>(saliency::kRocksChannel).acquire();
  const auto pr = ctx.channel<preview::PreviewImage>("preview/rocks").acquire();
  ASSERT_TRUE(rocks);
  ASSERT_TRUE(pr);
  EXPECT_EQ(pr->sequence, rocks->sequence) << "the last preview shows the last frame's rocks";
  EXPECT_EQ(pr->stamp, rocks->stamp);
  const cv::Mat img = cv::imdecode(pr->jpeg, cv::IMREAD_COLOR);
  ASSERT_EQ(img.size(), cv::Size(320, 240));
  EXPECT_EQ(pr->width, 320);
  ASSERT_GT(rocks->count, 0u) << "the mocked drive shows rocks";
  // every box's top edge (below the caption band) is drawn in its colour
  int boxes_checked = 0;
  for (std::uint32_t i = 0; i < rocks->count; ++i) {
    const auto& r = rocks->rocks[i];
    const cv::Rect b = r.detection.box;
    if (b.y < 20 || b.width < 8) continue;
    int coloured = 0;
    for (int x = b.x + 2; x < b.x + b.width - 2; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(b.y, x);
      coloured += (p[2] > 150 && p[0] < 110) ? 1 : 0;  // red or yellow after JPEG
    }
    EXPECT_GT(coloured, (b.width - 4) / 2) << "box " << i << " at " << b;  // 2-3 px lines survive JPEG
    ++boxes_checked;
  }
  EXPECT_GT(boxes_checked, 0);

  // wheel camera: 10 Hz frames, previews at max_rate_hz 2
  const auto wheel = diagnostics_of(*app, "wheel_preview");
  ASSERT_FALSE(wheel.empty());
  EXPECT_EQ(wheel.at("topic"), "preview/sinkage/compressed");
  const int wheel_previews = std::stoi(wheel.at("previews"));
  EXPECT_GE(wheel_previews, 11);
  EXPECT_LE(wheel_previews, 13);  // rate-limited: 2 per simulated second, not 10
  const auto ps = ctx.channel<preview::PreviewImage>("preview/sinkage").acquire();
  ASSERT_TRUE(ps);
  const cv::Mat wimg = cv::imdecode(ps->jpeg, cv::IMREAD_COLOR);
  ASSERT_EQ(wimg.size(), cv::Size(320, 240));  // 640x480 scaled to width 320
  int red = 0;                                 // the leg template outline
  for (int y = 0; y < wimg.rows; ++y)
    for (int x = 0; x < wimg.cols; ++x) {
      const cv::Vec3b p = wimg.at<cv::Vec3b>(y, x);
      red += (p[2] > 180 && p[1] < 90 && p[0] < 90) ? 1 : 0;
    }
  EXPECT_GT(red, 50) << "the leg template is drawn";

  // kept for a human look
  const std::string dir = std::string(REGOLITH_BINARY_DIR) + "/tests/integration/";
  cv::imwrite(dir + "preview_rocks.jpg", img);
  cv::imwrite(dir + "preview_sinkage.jpg", wimg);
  std::printf("previews: %spreview_rocks.jpg, %spreview_sinkage.jpg\n", dir.c_str(), dir.c_str());
}
