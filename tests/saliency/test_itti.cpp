// Itti-Koch building blocks and SAMS on constructed scenes with known salient
// objects.
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "regolith/core/parallel.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/evaluate.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/peers.hpp"

namespace rs = regolith::saliency;

namespace {

cv::Mat noise_texture(cv::Size size, double mean, double sd, unsigned seed) {
  cv::Mat img(size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::NORMAL, mean, sd);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
  return img;
}

cv::Point argmax(const cv::Mat& m) {
  cv::Point p;
  cv::minMaxLoc(m, nullptr, nullptr, nullptr, &p);
  return p;
}

}  // namespace

TEST(Pyramid, StbDownsampleSizesConstantAndRamp) {
  cv::Mat c(37, 50, CV_32F, cv::Scalar(0.25));
  cv::Mat d, tmp;
  rs::downsample_stb(c, d, tmp);
  EXPECT_EQ(d.size(), cv::Size(25, 19));
  double mn, mx;
  cv::minMaxLoc(d, &mn, &mx);
  EXPECT_NEAR(mn, 0.25, 1e-6);
  EXPECT_NEAR(mx, 0.25, 1e-6);
  // A ramp f(x) = x: the symmetric 6-tap kernel puts coarse pixel i at x = 2i +
  // 0.5.
  cv::Mat r(8, 40, CV_32F);
  for (int x = 0; x < 40; ++x) r.col(x).setTo(static_cast<float>(x));
  rs::downsample_stb(r, d, tmp);
  for (int i = 2; i < 18; ++i) EXPECT_NEAR(d.at<float>(3, i), 2 * i + 0.5, 1e-4) << i;
}

TEST(Normalisation, LocalMaxPromotesASinglePeakAndSuppressesTwins) {
  cv::Mat one = cv::Mat::zeros(20, 20, CV_32F);
  one.at<float>(10, 10) = 3.f;
  rs::normalise_local_max(one);
  EXPECT_NEAR(one.at<float>(10, 10), 10.f * 100.f,
              1e-3);  // scaled to 10, times (10 - 0)^2
  cv::Mat two = cv::Mat::zeros(20, 20, CV_32F);
  two.at<float>(5, 5) = 3.f;
  two.at<float>(15, 15) = 3.f;
  rs::normalise_local_max(two);
  EXPECT_NEAR(cv::norm(two, cv::NORM_INF), 0.0, 1e-6);  // (10 - 10)^2 = 0
  // One strong and one 40 % peak: factor (10 - 4)^2 = 36.
  cv::Mat mixed = cv::Mat::zeros(20, 20, CV_32F);
  mixed.at<float>(5, 5) = 5.f;
  mixed.at<float>(15, 15) = 2.f;
  rs::normalise_local_max(mixed);
  EXPECT_NEAR(mixed.at<float>(5, 5), 10.f * 36.f, 1e-3);
}

TEST(Normalisation, IterativeKeepsAnIsolatedPeakAndKillsClutter) {
  rs::IttiParams p;
  cv::Mat peak = cv::Mat::zeros(32, 40, CV_32F);
  cv::circle(peak, {20, 16}, 2, cv::Scalar(1.0), cv::FILLED);
  cv::Mat clutter = noise_texture({40, 32}, 0.5, 0.3, 11);
  cv::threshold(clutter, clutter, 0.0, 0.0, cv::THRESH_TOZERO);
  rs::normalise_iterative(peak, p);
  rs::normalise_iterative(clutter, p);
  const double pk = cv::norm(peak, cv::NORM_INF);
  const double cl = cv::norm(clutter, cv::NORM_INF);
  EXPECT_GT(pk, 5.0);
  EXPECT_EQ(argmax(peak), cv::Point(20, 16));
  EXPECT_GT(pk, 4.0 * cl) << "peak " << pk << " clutter " << cl;
  // Uniform maps vanish.
  cv::Mat flat(32, 40, CV_32F, cv::Scalar(0.3));
  rs::normalise_iterative(flat, p);
  EXPECT_EQ(cv::countNonZero(flat), 0);
}

TEST(Itti, FindsABrightRockOnTexturedGround) {
  cv::Mat img = noise_texture({512, 384}, 0.4, 0.05, 5);
  const cv::Point c(340, 150);
  cv::circle(img, c, 22, cv::Scalar(0.85), cv::FILLED);
  cv::Mat img8;
  img.convertTo(img8, CV_8U, 255.0);
  rs::IttiSaliency itti;
  cv::Mat sal;
  itti.compute(img8, sal);
  ASSERT_EQ(sal.size(), img.size());
  ASSERT_EQ(sal.type(), CV_32F);
  EXPECT_LT(cv::norm(argmax(sal) - c),
            22.0 + 16.0);  // within the rock, +- one map pixel
  rs::BoxDetector det;
  std::vector<rs::Detection> boxes;
  det.detect(sal, boxes);
  ASSERT_FALSE(boxes.empty());
  EXPECT_GT(rs::iou(boxes[0].box, cv::Rect(c.x - 22, c.y - 22, 45, 45)), 0.3);
}

TEST(Sams, StructureChannelFindsARelieflessRockInTheHeightMap) {
  // The image carries no object; only the height map has a bump (a rock the
  // camera cannot distinguish by brightness). Itti cannot find it, SAMS with
  // the structure channel does.
  const cv::Size size(512, 384);
  cv::Mat img = noise_texture(size, 0.45, 0.06, 9);
  cv::Mat height = cv::Mat::zeros(size, CV_32F);
  const cv::Point c(140, 260);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const double r2 = (x - c.x) * (x - c.x) + (y - c.y) * (y - c.y);
      height.at<float>(y, x) = static_cast<float>(12.0 * std::exp(-r2 / (2.0 * 15.0 * 15.0)));
    }
  }
  rs::IttiParams p;
  p.weights = {0.2, 0.2, 0.0, 0.6};
  rs::IttiSaliency sams(p);
  cv::Mat sal;
  sams.compute(img, height, sal);
  EXPECT_LT(cv::norm(argmax(sal) - c), 30.0);
  const rs::Conspicuity& k = sams.conspicuity(img, height);
  ASSERT_FALSE(k.structure.empty());
  EXPECT_GT(cv::norm(k.structure, cv::NORM_INF), 0.0);
  // Slope feature: a ring around the same centre, still within the rock's
  // footprint.
  p.structure_feature = rs::StructureFeature::kSlope;
  rs::IttiSaliency slope(p);
  slope.compute(img, height, sal);
  EXPECT_LT(cv::norm(argmax(sal) - c), 40.0);
  // Without the structure channel the maximum is elsewhere (texture only).
  rs::IttiSaliency itti;
  itti.compute(img, sal);
  EXPECT_GT(cv::norm(argmax(sal) - c), 30.0);
}

TEST(Sams, HeightsEnterThePyramidAtTheLevelOfTheirSize) {
  // The sfs component's quarter-resolution solve goes in at pyramid level 2: the structure
  // channel then matches the one built from the full-size heights (the levels it uses are
  // smoothed copies of the same relief), and still finds the relief-only rock. Other sizes are
  // refused, naming both.
  const cv::Size size(512, 384);
  cv::Mat img = noise_texture(size, 0.45, 0.06, 9);
  cv::Mat height(size, CV_32F);
  const cv::Point c(140, 260);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      height.at<float>(y, x) =
          static_cast<float>(12.0 * std::exp(-((x - c.x) * (x - c.x) + (y - c.y) * (y - c.y)) / 450.0));
  cv::Mat h4;
  cv::resize(height, h4, rs::IttiSaliency::level_size(size, 2), 0, 0, cv::INTER_AREA);
  rs::IttiParams p;
  p.weights = {0.2, 0.2, 0.0, 0.6};
  rs::IttiSaliency sams(p);
  const cv::Mat full = sams.conspicuity(img, height).structure.clone();
  const cv::Mat quarter = sams.conspicuity(img, h4).structure.clone();
  ASSERT_EQ(full.size(), quarter.size());
  cv::Mat prod;
  cv::Scalar mf, sf, mq, sq;
  cv::meanStdDev(full, mf, sf);
  cv::meanStdDev(quarter, mq, sq);
  cv::multiply(full - mf[0], quarter - mq[0], prod);
  EXPECT_GT(cv::mean(prod)[0] / (sf[0] * sq[0]), 0.95);
  cv::Mat sal;
  sams.compute(img, h4, sal);
  EXPECT_EQ(sal.size(), size);
  EXPECT_LT(cv::norm(argmax(sal) - c), 30.0);
  EXPECT_EQ(rs::IttiSaliency::level_size({641, 481}, 2), cv::Size(161, 121));
  try {
    sams.compute(img, cv::Mat(100, 100, CV_32F, cv::Scalar(0)), sal);
    ADD_FAILURE() << "a 100x100 height for a 512x384 image was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("100x100"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("128x96"), std::string::npos) << e.what();
  }
}

TEST(Itti, AcceptsGreyAndColourOfAnyDepth) {
  cv::Mat g = noise_texture({300, 260}, 0.5, 0.1, 1);
  cv::circle(g, {150, 130}, 15, cv::Scalar(0.95), cv::FILLED);
  cv::Mat g16, bgr32, bgra8, bgr8;
  g.convertTo(g16, CV_16U, 65535.0);
  cv::Mat planes[] = {g, g * 0.8, g * 0.6};
  cv::merge(planes, 3, bgr32);
  bgr32.convertTo(bgr8, CV_8U, 255.0);
  cv::cvtColor(bgr8, bgra8, cv::COLOR_BGR2BGRA);
  rs::IttiParams p;
  p.use_colour = true;
  rs::IttiSaliency itti(p);
  for (const cv::Mat& m : {g16, bgr32, bgra8, bgr8}) {
    cv::Mat sal;
    itti.compute(m, sal);
    EXPECT_EQ(sal.size(), m.size());
    EXPECT_LT(cv::norm(argmax(sal) - cv::Point(150, 130)), 30.0) << "type " << m.type();
  }
  EXPECT_FALSE(itti.conspicuity(bgr8).colour.empty());
  EXPECT_TRUE(itti.conspicuity(g16).colour.empty());
  for (rs::Method m : {rs::Method::kSpectralResidual, rs::Method::kFineGrained}) {
    rs::OpenCvSaliency peer(m);
    for (const cv::Mat& img : {g16, bgr32, bgra8}) {
      cv::Mat sal;
      peer.compute(img, sal);
      EXPECT_EQ(sal.size(), img.size());
      EXPECT_EQ(sal.type(), CV_32F);
    }
  }
}

TEST(Itti, BadInputAndParametersGiveClearMessages) {
  rs::IttiSaliency itti;
  cv::Mat sal;
  auto message = [&](const cv::Mat& img, const cv::Mat& h) {
    try {
      itti.compute(img, h, sal);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(message(cv::Mat(), cv::Mat()).find("empty"), std::string::npos);
  EXPECT_NE(message(cv::Mat::zeros(200, 300, CV_8U), cv::Mat()).find("smaller than the pyramid"), std::string::npos);
  EXPECT_NE(message(cv::Mat::zeros(300, 300, CV_8UC2), cv::Mat()).find("channels"), std::string::npos);
  EXPECT_NE(message(cv::Mat::zeros(300, 300, CV_8U), cv::Mat::zeros(100, 100, CV_32F)).find("height: size"),
            std::string::npos);
  rs::IttiParams p;
  p.weights.structure = std::nan("");
  try {
    rs::IttiSaliency bad(p);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ChannelWeights.structure"), std::string::npos);
  }
  p = {};
  p.map_level = 20;
  EXPECT_THROW(rs::IttiSaliency{p}, std::invalid_argument);
  EXPECT_THROW(rs::method_from_string("gbvs"), std::invalid_argument);
  EXPECT_EQ(rs::method_from_string("fine_grained"), rs::Method::kFineGrained);
}

// The size a small image is processed at (`regolith rocks` and the sams component): the shorter
// side brought to the pyramid's, the aspect kept (rounded up); a sliver that would exceed the image
// limits is an error naming both sizes.
TEST(Itti, ASmallImageIsProcessedEnlargedToThePyramidsSide) {
  const rs::IttiParams p;  // 2^(4 + 4) = 256 px
  EXPECT_EQ(p.input_size({640, 480}), cv::Size(640, 480));
  EXPECT_EQ(p.input_size({256, 256}), cv::Size(256, 256));
  EXPECT_EQ(p.input_size({320, 240}), cv::Size(342, 256));
  EXPECT_EQ(p.input_size({100, 300}), cv::Size(256, 768));
  EXPECT_EQ(p.input_size({16, 16}), cv::Size(256, 256));
  try {
    static_cast<void>(p.input_size({16000, 100}));
    FAIL() << "a 16000x100 sliver enlarged to 40960x256";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "16000x100 px is too small for the 256 px a side of the pyramid: enlarged to that it would be "
                 "40960x256 px");
  }
  EXPECT_THROW(static_cast<void>(p.input_size({0, 100})), std::invalid_argument);
}

namespace {
// Every job on a thread of its own, started last job first: the channels must not share any
// buffer or depend on each other's order.
class ThreadPerJob final : public regolith::ParallelFor {
 public:
  void run(int n, void (*fn)(void*, int), void* ctx) override {
    std::vector<std::thread> t;
    for (int i = n - 1; i >= 0; --i) t.emplace_back([=] { fn(ctx, i); });
    for (auto& x : t) x.join();
  }
  int threads() const override { return 8; }
};
}  // namespace

TEST(Sams, ChannelsRunInParallelGiveTheSameMapsBitForBit) {
  const cv::Size size(320, 256);  // the default 9-level pyramid needs >= 256 px
  cv::Mat img = noise_texture(size, 0.45, 0.06, 3);
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{img, img * 0.9, img * 1.1}, bgr);
  cv::Mat height = noise_texture(size, 0.0, 1.0, 4);
  for (const bool colour : {false, true}) {
    for (const auto norm : {rs::Normalisation::kLocalMax, rs::Normalisation::kIterative}) {
      rs::IttiParams p;
      p.use_colour = colour;
      p.normalisation = norm;
      p.weights = {0.2, 0.4, colour ? 0.2 : 0.0, 0.2};
      rs::IttiSaliency serial(p), parallel(p);
      ThreadPerJob par;
      parallel.set_parallel(&par);
      cv::Mat a, b;
      for (int frame = 0; frame < 2; ++frame) {  // the second frame reuses every buffer
        serial.compute(colour ? bgr : img, height, a);
        parallel.compute(colour ? bgr : img, height, b);
        EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << "colour " << colour << " frame " << frame;
      }
      const rs::Conspicuity& cs = serial.conspicuity(colour ? bgr : img, height);
      const rs::Conspicuity& cp = parallel.conspicuity(colour ? bgr : img, height);
      EXPECT_EQ(cv::norm(cs.orientation, cp.orientation, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(cs.structure, cp.structure, cv::NORM_INF), 0.0);
      EXPECT_EQ(cv::norm(cs.intensity, cp.intensity, cv::NORM_INF), 0.0);
      if (colour) {
        EXPECT_EQ(cv::norm(cs.colour, cp.colour, cv::NORM_INF), 0.0);
      }
    }
  }
}
