#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mock_test_util.hpp"

namespace regolith::mocks::test {
namespace {

// Image i of a test sequence is uniform with value 10 * (i + 1).
void write_images(const TempDir& d, const std::string& sub, int n, int w = 32, int h = 24) {
  std::filesystem::create_directories(d.file(sub));
  for (int i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/img_%03d.png", i);
    cv::imwrite(d.file(sub) + name, cv::Mat(h, w, CV_8UC1, cv::Scalar(10 * (i + 1))));
  }
}

int pixel(const hal::FrameLease& f) {
  return f->image.at<std::uint8_t>(0, 0);
}

TEST(ImageFiles, FrameIndexFollowsSimulatedTime) {
  Fixture fx;
  write_images(fx.dir, "frames", 5);
  auto cam = fx.camera("backend: image_files\npath: frames\nrate_hz: 10\n", 3);
  EXPECT_EQ(cam->format().width, 32);
  EXPECT_EQ(cam->format().height, 24);
  hal::FrameLease f;
  const TimeNs t0 = fx.clock.now();
  EXPECT_FALSE(cam->latest(t0, f)) << "not started";
  cam->start();
  EXPECT_FALSE(cam->latest(t0 - 1, f)) << "before start";
  ASSERT_TRUE(cam->latest(t0, f));
  EXPECT_EQ(f->sequence, 0u);
  EXPECT_EQ(f->capture_time, t0);
  EXPECT_EQ(f->camera_index, 3);
  EXPECT_EQ(pixel(f), 10);
  // Jump 250 ms: the frame due is index floor(0.25 * 10) = 2, captured at 200 ms.
  ASSERT_TRUE(cam->latest(t0 + 250 * kNsPerMs, f));
  EXPECT_EQ(f->sequence, 2u);
  EXPECT_EQ(f->capture_time, t0 + 200 * kNsPerMs);
  EXPECT_EQ(pixel(f), 30);
  // Exactly on a frame boundary.
  ASSERT_TRUE(cam->latest(t0 + 400 * kNsPerMs, f));
  EXPECT_EQ(f->sequence, 4u);
  // Looping: frame 7 shows image 7 % 5 = 2.
  ASSERT_TRUE(cam->latest(t0 + 799 * kNsPerMs, f));
  EXPECT_EQ(f->sequence, 7u);
  EXPECT_EQ(f->capture_time, t0 + 700 * kNsPerMs);
  EXPECT_EQ(pixel(f), 30);
  const auto st = cam->stats();
  EXPECT_EQ(st.frames, 8u);
  EXPECT_EQ(st.state, hal::DeviceState::kStreaming);
  EXPECT_EQ(st.last_frame_time, t0 + 700 * kNsPerMs);
  f.reset();
  cam->stop();
  EXPECT_FALSE(cam->latest(t0 + kNsPerSec, f));
}

TEST(ImageFiles, NoLoopKeepsTheLastFrame) {
  Fixture fx;
  write_images(fx.dir, "frames", 5);
  auto cam = fx.camera("backend: image_files\npath: frames\nrate_hz: 10\nloop: false\n");
  cam->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease f;
  ASSERT_TRUE(cam->latest(t0 + 3 * kNsPerSec, f));
  EXPECT_EQ(f->sequence, 4u);
  EXPECT_EQ(f->capture_time, t0 + 400 * kNsPerMs);
  EXPECT_EQ(pixel(f), 50);
}

TEST(ImageFiles, MismatchedSizeNamesTheFile) {
  Fixture fx;
  write_images(fx.dir, "frames", 3);
  cv::imwrite(fx.dir.file("frames/img_001.png"), cv::Mat(30, 40, CV_8UC1, cv::Scalar(1)));
  const std::string msg = config_error([&] { fx.camera("backend: image_files\npath: frames\n"); });
  EXPECT_NE(msg.find("img_001.png"), std::string::npos) << msg;
  EXPECT_NE(msg.find("40x30"), std::string::npos) << msg;
  EXPECT_NE(msg.find("test.yaml:2:"), std::string::npos) << msg;
}

TEST(ImageFiles, ResizesWhenWidthAndHeightAreGiven) {
  Fixture fx;
  write_images(fx.dir, "frames", 2);
  cv::imwrite(fx.dir.file("frames/img_002.png"), cv::Mat(30, 40, CV_8UC1, cv::Scalar(77)));
  auto cam = fx.camera("backend: image_files\npath: frames\nwidth: 16\nheight: 12\nformat: bgr8\n");
  EXPECT_EQ(cam->format().width, 16);
  EXPECT_EQ(cam->format().height, 12);
  cam->start();
  hal::FrameLease f;
  ASSERT_TRUE(cam->latest(fx.clock.now() + 200 * kNsPerMs, f));  // 10 Hz default: frame 2
  EXPECT_EQ(f->image.type(), CV_8UC3);
  EXPECT_EQ(f->image.cols, 16);
  EXPECT_EQ(f->image.at<cv::Vec3b>(5, 5), cv::Vec3b(77, 77, 77));
  const std::string msg = config_error([&] { fx.camera("backend: image_files\npath: frames\nwidth: 16\n"); });
  EXPECT_NE(msg.find("give both width and height"), std::string::npos) << msg;
}

TEST(ImageFiles, GlobPatternAndSortOrder) {
  Fixture fx;
  write_images(fx.dir, "frames", 4);
  cv::imwrite(fx.dir.file("frames/zz.jpg"), cv::Mat(24, 32, CV_8UC1, cv::Scalar(200)));
  auto all = fx.camera("backend: image_files\npath: frames\nrate_hz: 1\n");
  auto png = fx.camera("backend: image_files\npath: frames/img_*.png\nrate_hz: 1\nmax_frames: 3\n");
  all->start();
  png->start();
  const TimeNs t0 = fx.clock.now();
  hal::FrameLease f;
  ASSERT_TRUE(all->latest(t0 + 4 * kNsPerSec, f));  // the .jpg sorts last: index 4
  EXPECT_NEAR(pixel(f), 200, 2);
  ASSERT_TRUE(png->latest(t0 + 3 * kNsPerSec, f));  // only 3 preloaded: frame 3 shows image 0
  EXPECT_EQ(pixel(f), 10);
  ASSERT_TRUE(png->latest(t0 + 5 * kNsPerSec, f));
  EXPECT_EQ(pixel(f), 30);
}

TEST(ImageFiles, BadInputErrors) {
  Fixture fx;
  write_images(fx.dir, "frames", 2);
  fx.dir.write("frames/img_001.png", "this is not a PNG");
  std::string msg = config_error([&] { fx.camera("backend: image_files\npath: frames\n"); });
  EXPECT_NE(msg.find("cannot read image"), std::string::npos) << msg;
  EXPECT_NE(msg.find("img_001.png"), std::string::npos) << msg;
  // A JPEG cut short (`head -c 2000`): libjpeg would decode it with grey rows; refused, named.
  {
    std::vector<unsigned char> jpg;
    cv::Mat noise(64, 64, CV_8UC1);
    cv::randu(noise, 0, 255);
    ASSERT_TRUE(cv::imencode(".jpg", noise, jpg));
    fx.dir.write("cut/img_000.jpg",
                 std::string(jpg.begin(), jpg.begin() + static_cast<std::ptrdiff_t>(jpg.size() / 2)));
    msg = config_error([&] { fx.camera("backend: image_files\npath: cut\n"); });
    EXPECT_NE(msg.find("img_000.jpg': truncated JPEG"), std::string::npos) << msg;
  }
  std::filesystem::create_directories(fx.dir.file("empty"));
  msg = config_error([&] { fx.camera("backend: image_files\npath: empty\n"); });
  EXPECT_NE(msg.find("contains no image"), std::string::npos) << msg;
  msg = config_error([&] { fx.camera("backend: image_files\npath: nothing/*.png\n"); });
  EXPECT_NE(msg.find("matches no image"), std::string::npos) << msg;
  write_images(fx.dir, "frames", 2);  // repaired
  msg = config_error([&] { fx.camera("backend: image_files\npath: frames\nrate_hz: 0\n"); });
  EXPECT_NE(msg.find("rate_hz"), std::string::npos) << msg;
  msg = config_error([&] { fx.camera("backend: image_files\npath: frames\nloops: true\n"); });
  EXPECT_NE(msg.find("did you mean 'loop'"), std::string::npos) << msg;
}

// Two consumers poll concurrently: at most one writes; every leased frame's pixels match its
// sequence number (no torn or mislabelled frame). A reader never waits: while the other thread
// writes the very first frame there is nothing to lease yet (under emulation or load that window
// can last thousands of polls), but once a reader has seen a frame it always gets one.
TEST(ImageFiles, ConcurrentConsumersSeeConsistentFrames) {
  Fixture fx;
  write_images(fx.dir, "frames", 7, 64, 48);
  auto cam = fx.camera("backend: image_files\npath: frames\nrate_hz: 1000\n");
  cam->start();
  const TimeNs t0 = fx.clock.now();
  std::atomic<int> bad{0}, seen{0};
  auto worker = [&](int phase) {
    hal::FrameLease f;
    std::uint64_t last = 0;
    bool had_frame = false;
    for (int i = 0; i < 20000; ++i) {
      const TimeNs now = t0 + (i / 2 + phase) * kNsPerMs / 3;
      if (!cam->latest(now, f)) {
        if (had_frame) ++bad;  // a frame was published: it must stay leasable
        continue;
      }
      had_frame = true;
      ++seen;
      const int expect = 10 * static_cast<int>(f->sequence % 7 + 1);
      if (pixel(f) != expect || f->image.at<std::uint8_t>(47, 63) != expect) ++bad;
      if (f->capture_time != t0 + static_cast<TimeNs>(f->sequence) * kNsPerMs) ++bad;
      if (f->sequence < last) ++bad;
      last = f->sequence;
    }
  };
  std::thread a(worker, 0), b(worker, 1);
  a.join();
  b.join();
  EXPECT_EQ(bad.load(), 0);
  EXPECT_GE(seen.load(), 20000);  // the first writer leases on every poll, the other once it has a frame
}

}  // namespace
}  // namespace regolith::mocks::test
