// The allocation-free replacements of image_ops.hpp against the OpenCV calls they replace, on
// random inputs of odd and even sizes (borders included), and the per-frame allocation count of
// IttiSaliency::compute + BoxDetector::detect once warmed up (counting global operator new on
// this thread while armed).
// The replaced global operator new/delete pair malloc/free; GCC cannot see that they match.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <new>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new
#include "regolith/saliency/bit_mask.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/image_ops.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/model_file.hpp"
#include "regolith/saliency/trained.hpp"

namespace rs = regolith::saliency;

namespace {

cv::Mat random_float(cv::Size s, int seed) {
  cv::Mat m(s, CV_32F);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(m, cv::RNG::UNIFORM, 0.0, 1.0);
  return m;
}

// Largest |a - b| relative to the largest |b| (1 when b is all zero).
double rel_diff(const cv::Mat& a, const cv::Mat& b) {
  EXPECT_EQ(a.size(), b.size());
  EXPECT_EQ(a.type(), b.type());
  double mx = 0.0;
  cv::minMaxLoc(cv::abs(b), nullptr, &mx);
  return cv::norm(a, b, cv::NORM_INF) / std::max(mx, 1.0);
}

// Random binary image: blobs of random rectangles and ellipses plus salt noise.
cv::Mat random_binary(cv::Size s, int seed) {
  std::mt19937 rng(static_cast<unsigned>(seed));
  cv::Mat m(s, CV_8U, cv::Scalar(0));
  std::uniform_int_distribution<int> ux(-5, s.width + 5), uy(-5, s.height + 5), ur(1, 12);
  for (int k = 0; k < 25; ++k) {
    if (k % 2 == 0)
      cv::ellipse(m, {ux(rng), uy(rng)}, {ur(rng), ur(rng)}, 17.0 * k, 0, 360, 255, -1);
    else
      cv::rectangle(m, cv::Rect(ux(rng), uy(rng), ur(rng), ur(rng)), 255, -1);
  }
  std::bernoulli_distribution salt(0.04);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      if (salt(rng)) m.at<uchar>(y, x) = 255;
  return m;
}

const cv::Size kSizes[] = {{1, 1}, {2, 3}, {7, 5}, {9, 9}, {40, 30}, {41, 33}, {80, 61}, {161, 120}};

}  // namespace

TEST(ImageOps, GaborEnergyEqualsFilter2DReplicate) {
  for (const int ks : {3, 9}) {
    cv::Mat even = cv::getGaborKernel({ks, ks}, 7.0 / 3.0, 0.7, 7.0, 1.0, 0.0, CV_32F);
    cv::Mat odd = cv::getGaborKernel({ks, ks}, 7.0 / 3.0, 0.7, 7.0, 1.0, CV_PI / 2, CV_32F);
    odd.at<float>(0, 0) += 0.25f;  // make it asymmetric: a flipped kernel would be caught
    int seed = 1;
    for (const cv::Size s : kSizes) {
      const cv::Mat src = random_float(s, seed++);
      cv::Mat e, o, ref, dst, pad, rows, one;
      cv::filter2D(src, e, CV_32F, even, {-1, -1}, 0.0, cv::BORDER_REPLICATE);
      cv::filter2D(src, o, CV_32F, odd, {-1, -1}, 0.0, cv::BORDER_REPLICATE);
      ref = cv::abs(e) + cv::abs(o);
      rs::gabor_energy(src, even, odd, dst, pad, rows);
      EXPECT_LT(rel_diff(dst, ref), 1e-5) << s << " k" << ks;
      rs::correlate_replicate(src, odd, one, pad);
      EXPECT_LT(rel_diff(one, o), 1e-5) << s << " k" << ks;
    }
  }
}

// The separable form of an isotropic Gabor pair gives the energy of the pair's 2-D kernels (every
// orientation IttiSaliency uses and two odd ones, both kernel sizes, every test size: replicated
// borders included).
TEST(ImageOps, SeparableGaborEnergyEqualsTheDirectOne) {
  int seed = 40;
  for (const int ks : {3, 9})
    for (const double theta : {0.0, CV_PI / 4, CV_PI / 2, 3 * CV_PI / 4, 0.3, 2.0}) {
      cv::Mat even, odd;
      rs::gabor_kernels(ks, 7.0 / 3.0, 7.0, 1.0, theta, even, odd);
      const rs::SeparableGabor sep = rs::SeparableGabor::make(ks, 7.0 / 3.0, 7.0, theta);
      for (const cv::Size s : kSizes) {
        const cv::Mat src = random_float(s, seed++);
        cv::Mat ref, dst, pad, rows;
        rs::gabor_energy(src, even, odd, ref, pad, rows);
        rs::GaborLevel level;
        rs::gabor_energy(src, sep, dst, level, rows);
        EXPECT_LT(rel_diff(dst, ref), 2e-5) << s << " k" << ks << " theta " << theta;
        // A level prepared once serves every orientation: the same bits as preparing it anew.
        rs::GaborLevel shared;
        shared.prepare(src, rs::SeparableGabor::make(ks, 7.0 / 3.0, 7.0, 0.0));
        cv::Mat again;
        rs::gabor_energy(shared, sep, again, rows);
        EXPECT_EQ(cv::norm(again, dst, cv::NORM_INF), 0.0) << s << " k" << ks << " theta " << theta;
      }
    }
  rs::GaborLevel level;  // prepared for 3 taps, asked for 9
  level.prepare(random_float({20, 20}, 1), rs::SeparableGabor::make(3, 7.0 / 3.0, 7.0, 0.0));
  cv::Mat out, rows;
  EXPECT_THROW(rs::gabor_energy(level, rs::SeparableGabor::make(9, 7.0 / 3.0, 7.0, 0.0), out, rows),
               std::invalid_argument);
  EXPECT_THROW(rs::SeparableGabor::make(4, 1.0, 7.0, 0.0), std::invalid_argument);
  EXPECT_THROW(rs::SeparableGabor::make(9, 0.0, 7.0, 0.0), std::invalid_argument);
}

TEST(ImageOps, SobelThroughCorrelationEqualsCvSobel) {
  const cv::Mat kx = (cv::Mat_<float>(3, 3) << -1, 0, 1, -2, 0, 2, -1, 0, 1) / 8.0;
  const cv::Mat src = random_float({37, 29}, 5);
  cv::Mat ref, dst, pad;
  cv::Sobel(src, ref, CV_32F, 1, 0, 3, 1.0 / 8.0, 0.0, cv::BORDER_REPLICATE);
  rs::correlate_replicate(src, kx, dst, pad);
  EXPECT_LT(rel_diff(dst, ref), 1e-6);
}

TEST(ImageOps, BinaryMorphologyEqualsOpenCvDefaultBorder) {
  // The detector's masks as bits (BitMask) against cv::erode / cv::dilate / cv::morphologyEx with
  // the default border: every shape and size of element, the open-then-close of BoxDetector.
  int seed = 10;
  rs::BitMask bits, a, b;
  cv::Mat got;
  for (const int shape : {cv::MORPH_ELLIPSE, cv::MORPH_RECT, cv::MORPH_CROSS}) {
    for (const cv::Size ks : {cv::Size(5, 5), cv::Size(3, 7), cv::Size(1, 1), cv::Size(9, 9)}) {
      const cv::Mat k = cv::getStructuringElement(shape, ks);
      rs::BinaryMorphology morph(k);
      for (const cv::Size s : kSizes) {
        const cv::Mat src = random_binary(s, seed++);
        cv::Mat re, rd, ro, rc;
        cv::erode(src, re, k);
        cv::dilate(src, rd, k);
        cv::morphologyEx(src, ro, cv::MORPH_OPEN, k);
        cv::morphologyEx(ro, rc, cv::MORPH_CLOSE, k);
        bits.threshold(src, 0);
        morph.erode(bits, a);
        a.unpack(got);
        EXPECT_EQ(cv::norm(got, re, cv::NORM_INF), 0.0) << shape << " " << ks << " " << s;
        morph.dilate(bits, b);
        b.unpack(got);
        EXPECT_EQ(cv::norm(got, rd, cv::NORM_INF), 0.0) << shape << " " << ks << " " << s;
        morph.dilate(a, b);  // open
        b.unpack(got);
        EXPECT_EQ(cv::norm(got, ro, cv::NORM_INF), 0.0) << s;
        morph.dilate(b, a);  // then close, in place as BoxDetector's buffers allow
        morph.erode(a, a);
        a.unpack(got);
        EXPECT_EQ(cv::norm(got, rc, cv::NORM_INF), 0.0) << s;
      }
    }
  }
  // Elements whose rows are runs but not nested (a slanted bar) or asymmetric; one with a gap in a
  // row is refused (the detector's ellipses never have one).
  const cv::Mat slanted = (cv::Mat_<uchar>(3, 5) << 1, 1, 0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 0, 1, 1);
  const cv::Mat lopsided = (cv::Mat_<uchar>(5, 3) << 0, 1, 0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 0, 0, 1);
  for (const cv::Mat& kk : {slanted, lopsided}) {
    const cv::Mat src = random_binary({37, 29}, seed++);
    cv::Mat re, rd;
    cv::erode(src, re, kk);
    cv::dilate(src, rd, kk);
    rs::BinaryMorphology morph(kk);
    bits.threshold(src, 0);
    morph.erode(bits, a);
    a.unpack(got);
    EXPECT_EQ(cv::norm(got, re, cv::NORM_INF), 0.0) << kk;
    morph.dilate(bits, a);
    a.unpack(got);
    EXPECT_EQ(cv::norm(got, rd, cv::NORM_INF), 0.0) << kk;
  }
  const cv::Mat gappy = (cv::Mat_<uchar>(3, 5) << 1, 0, 1, 0, 1, 0, 0, 0, 0, 0, 0, 1, 1, 0, 1);
  EXPECT_THROW(rs::BinaryMorphology{gappy}, std::invalid_argument);
}

TEST(ImageOps, ResizeTableEqualsCvResize) {
  // Sizes of the dyadic pyramid (ceil halving) to a map level and back, plus odd ratios.
  const std::tuple<cv::Size, cv::Size, int> cases[] = {
      {{160, 120}, {40, 30}, cv::INTER_AREA},
      {{140, 125}, {35, 32}, cv::INTER_AREA},
      {{70, 63}, {35, 32}, cv::INTER_AREA},
      {{35, 32}, {35, 32}, cv::INTER_AREA},
      {{101, 77}, {13, 9}, cv::INTER_AREA},
      {{5, 4}, {40, 30}, cv::INTER_LINEAR},
      {{3, 2}, {35, 32}, cv::INTER_LINEAR},
      {{80, 60}, {320, 240}, cv::INTER_LINEAR},
      {{35, 32}, {560, 500}, cv::INTER_LINEAR},
      {{1, 1}, {7, 5}, cv::INTER_LINEAR},
      {{50, 40}, {17, 23}, cv::INTER_LINEAR},
      {{20, 15}, {20, 15}, cv::INTER_LINEAR},
      // the mock deployment (320x240, map level 2, levels 3..7 -> 80x60, map -> input)
      {{40, 30}, {80, 60}, cv::INTER_LINEAR},
      {{20, 15}, {80, 60}, cv::INTER_LINEAR},
      {{10, 8}, {80, 60}, cv::INTER_LINEAR},
      {{5, 4}, {80, 60}, cv::INTER_LINEAR},
      {{3, 2}, {80, 60}, cv::INTER_LINEAR},
      {{80, 60}, {320, 240}, cv::INTER_LINEAR}};
  int seed = 100;
  for (const auto& [from, to, interp] : cases) {
    const cv::Mat src = random_float(from, seed++);
    cv::Mat ref, dst;
    cv::resize(src, ref, to, 0, 0, interp);
    rs::ResizeTable t;
    t.build(from, to, interp == cv::INTER_AREA ? rs::ResizeTable::Mode::kArea : rs::ResizeTable::Mode::kLinear);
    t.apply(src, dst);
    EXPECT_LT(rel_diff(dst, ref), 2e-6) << from << " -> " << to << " interp " << interp;
  }
  // Clamped as written (Itti's map -> input): each output of cv::resize put into [0, 1], NaN -> 0.
  cv::Mat src = random_float({40, 30}, 7) * 3.0 - 1.0;  // values in [-1, 2]
  src.at<float>(5, 7) = std::numeric_limits<float>::quiet_NaN();
  src.at<float>(9, 20) = -0.f;
  cv::Mat ref, dst;
  cv::resize(src, ref, {640, 480}, 0, 0, cv::INTER_LINEAR);
  rs::ResizeTable clamped;
  clamped.build({40, 30}, {640, 480}, rs::ResizeTable::Mode::kLinear);
  clamped.apply(src, dst, /*clamp_unit=*/true);
  int nan_outputs = 0;
  for (int y = 0; y < ref.rows; ++y)
    for (int x = 0; x < ref.cols; ++x) {
      const float r = ref.at<float>(y, x), d = dst.at<float>(y, x);
      if (std::isnan(r)) {
        ++nan_outputs;
        ASSERT_EQ(d, 0.f) << y << "," << x;
      } else {
        ASSERT_NEAR(d, std::clamp(r, 0.f, 1.f), 2e-6f) << y << "," << x;
      }
    }
  EXPECT_GT(nan_outputs, 0);
  rs::ResizeTable t;
  EXPECT_THROW(t.build({10, 10}, {20, 20}, rs::ResizeTable::Mode::kArea), std::invalid_argument);
  t.build({10, 10}, {5, 5}, rs::ResizeTable::Mode::kLinear);
  cv::Mat wrong(11, 10, CV_32F, cv::Scalar(0)), out;
  EXPECT_THROW(t.apply(wrong, out), std::invalid_argument);
}

TEST(ImageOps, RunComponentsEqualOpenCvStatsAndNumbering) {
  // 8-connected components of a BitMask: cv::connectedComponentsWithStats' count and statistics,
  // component k here being its label k + 1 (the same numbering).
  int seed = 200;
  rs::BitMask bits;
  rs::RunComponents cc;
  auto same_as_opencv = [&](const cv::Mat& bin, const std::string& what) {
    cv::Mat labels, stats, centroids;
    const int n_ref = cv::connectedComponentsWithStats(bin, labels, stats, centroids, 8, CV_32S);
    bits.threshold(bin, 0);
    const int n = cc.run(bits);
    ASSERT_EQ(n, n_ref - 1) << what;
    for (int i = 0; i < n; ++i)
      for (int f = 0; f < 5; ++f)
        EXPECT_EQ(cc.stats(i)[static_cast<std::size_t>(f)], stats.at<int>(i + 1, f))
            << what << " component " << i << " stat " << f;
  };
  for (const cv::Size s : kSizes)
    for (int trial = 0; trial < 4; ++trial) same_as_opencv(random_binary(s, seed++), "random");
  // A U shape that needs merges across rows, and a diagonal pair (one component, 8-connected).
  cv::Mat u(20, 30, CV_8U, cv::Scalar(0));
  cv::rectangle(u, cv::Rect(2, 2, 3, 15), 255, -1);
  cv::rectangle(u, cv::Rect(20, 2, 3, 15), 255, -1);
  cv::rectangle(u, cv::Rect(2, 15, 21, 2), 255, -1);
  u.at<uchar>(0, 10) = 255;
  u.at<uchar>(1, 11) = 255;
  same_as_opencv(u, "U");
  EXPECT_EQ(cc.run(bits), 2);
}

TEST(ImageOps, BitMasksAroundTheWordSizeEqualOpenCv) {
  // Widths around the 64-pixel word (63, 64, 65, 128, 130), grey images thresholded at several
  // levels, the detector's 5 x 5 ellipse and others, a row run longer than a word (141 wide):
  // against cv::erode / cv::dilate and cv::connectedComponentsWithStats, bit for bit.
  const cv::Size sizes[] = {{1, 1}, {2, 3}, {7, 5}, {63, 9}, {64, 20}, {65, 33}, {128, 7}, {130, 61}, {161, 120}};
  const cv::Mat kernels[] = {
      cv::getStructuringElement(cv::MORPH_ELLIPSE, {5, 5}), cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}),
      cv::getStructuringElement(cv::MORPH_ELLIPSE, {9, 9}), cv::getStructuringElement(cv::MORPH_RECT, {3, 7}),
      cv::getStructuringElement(cv::MORPH_CROSS, {7, 5}),   cv::getStructuringElement(cv::MORPH_ELLIPSE, {141, 5})};
  int seed = 300;
  rs::BitMask bits, out;
  rs::RunComponents runs;
  cv::Mat ref, got, labels, stats, centroids;
  for (const cv::Size s : sizes) {
    for (int trial = 0; trial < 3; ++trial) {
      cv::Mat grey = random_binary(s, seed++);
      cv::Mat noise(s, CV_8U);
      cv::randu(noise, 0, 200);
      grey = grey / 2 + noise / 4;  // grey levels: the threshold picks the mask
      const int thr = 60 + 10 * trial;
      const cv::Mat bin = grey > thr;
      bits.threshold(grey, thr);
      bits.unpack(got);
      ASSERT_EQ(cv::norm(got, bin, cv::NORM_INF), 0.0) << s << " threshold " << thr;
      for (const cv::Mat& k : kernels) {
        rs::BinaryMorphology morph(k);
        cv::erode(bin, ref, k);
        morph.erode(bits, out);
        out.unpack(got);
        EXPECT_EQ(cv::norm(got, ref, cv::NORM_INF), 0.0) << s << " erode " << k.size();
        cv::dilate(bin, ref, k);
        morph.dilate(bits, out);
        out.unpack(got);
        EXPECT_EQ(cv::norm(got, ref, cv::NORM_INF), 0.0) << s << " dilate " << k.size();
      }
      const int n_ref = cv::connectedComponentsWithStats(bin, labels, stats, centroids, 8, CV_32S);
      ASSERT_EQ(runs.run(bits), n_ref - 1) << s;
      for (int i = 1; i < n_ref; ++i)
        for (int f = 0; f < 5; ++f)
          EXPECT_EQ(runs.stats(i - 1)[static_cast<std::size_t>(f)], stats.at<int>(i, f))
              << s << " component " << i << " stat " << f;
    }
  }
  // A pixel whose only neighbour is diagonal, across a word boundary; a full run of 64.
  cv::Mat u(4, 128, CV_8U, cv::Scalar(0));
  u.at<uchar>(0, 63) = 255;
  u.at<uchar>(1, 64) = 255;
  u.row(3).colRange(0, 64).setTo(255);
  bits.threshold(u, 0);
  EXPECT_EQ(runs.run(bits), 2);
  EXPECT_EQ(runs.stats(0), (std::array<int, 5>{63, 0, 2, 2, 2}));
  EXPECT_EQ(runs.stats(1), (std::array<int, 5>{0, 3, 64, 1, 64}));
  EXPECT_THROW(bits.threshold(cv::Mat(3, 3, CV_32F), 1), std::invalid_argument);
}

TEST(ImageOps, IttiAndBoxesAllocateNothingPerFrameOnceWarm) {
  // The settings of the `sams` component in the mock deployment (320x240, delta_max 3, map
  // level 2, local-max N) and the library defaults at 640x480 (map level 4: INTER_AREA tables),
  // each with the height and the slope structure feature.
  struct Case {
    cv::Size size;
    int delta_max, map_level;
    rs::StructureFeature feature;
  };
  for (const Case& c :
       {Case{{320, 240}, 3, 2, rs::StructureFeature::kHeight}, Case{{320, 240}, 3, 2, rs::StructureFeature::kSlope},
        Case{{640, 480}, 4, 4, rs::StructureFeature::kHeight}}) {
    cv::Mat gray(c.size, CV_8U), height(c.size, CV_32F);
    cv::randu(gray, 0, 256);
    cv::GaussianBlur(gray, gray, {0, 0}, 2.0);
    cv::randu(height, 0.f, 1.f);
    cv::GaussianBlur(height, height, {0, 0}, 4.0);
    rs::IttiParams ip;
    ip.delta_max = c.delta_max;
    ip.map_level = c.map_level;
    ip.normalisation = rs::Normalisation::kLocalMax;
    ip.structure_feature = c.feature;
    ip.weights = {0.2, 0.5, 0.0, 0.3};
    rs::PostProcessParams pp;
    pp.threshold_scale = 1.2;
    rs::IttiSaliency itti(ip);
    rs::BoxDetector det(pp);
    cv::Mat sal;
    std::vector<rs::Detection> out;
    out.reserve(4096);
    itti.compute(gray, height, sal);
    det.detect(sal, out);
    const std::uint64_t a0 = regolith::testing::thread_allocations();
    for (int k = 0; k < 3; ++k) {
      itti.compute(gray, height, sal);
      det.detect(sal, out);
    }
    EXPECT_EQ(regolith::testing::thread_allocations() - a0, 0u) << c.size << " map level " << c.map_level;
    EXPECT_FALSE(out.empty());
  }
}

TEST(ImageOps, GaussianBlur32fEqualsCvGaussianBlur) {
  rs::GaussianBlur32f blur;
  int seed = 40;
  for (const cv::Size& s : kSizes)
    for (double sigma : {0.8, 2.0, 4.0, 9.5}) {
      const cv::Mat src = random_float(s, ++seed);
      cv::Mat ours, ref;
      blur.apply(src, ours, sigma);
      cv::GaussianBlur(src, ref, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT_101);
      EXPECT_LT(rel_diff(ours, ref), 1e-5) << s << " sigma " << sigma;
      cv::Mat alias = src.clone();
      blur.apply(alias, alias, sigma);  // in place
      EXPECT_LT(rel_diff(alias, ref), 1e-5) << s << " sigma " << sigma << " in place";
    }
  cv::Mat dst;
  EXPECT_THROW(blur.apply(cv::Mat(4, 4, CV_32F), dst, 0.0), std::invalid_argument);
  EXPECT_THROW(blur.apply(cv::Mat(4, 4, CV_8U), dst, 1.0), std::invalid_argument);
}

// The guided filter written out per pixel: each clipped window's least-squares a, b, then their
// means over the windows holding the pixel.
cv::Mat guided_reference(const cv::Mat& guide, const cv::Mat& src, int r, double eps) {
  const int W = src.cols, H = src.rows;
  cv::Mat a(H, W, CV_64F), b(H, W, CV_64F), out(H, W, CV_32F);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double si = 0, sp = 0, sip = 0, sii = 0, n = 0;
      for (int v = std::max(y - r, 0); v <= std::min(y + r, H - 1); ++v)
        for (int u = std::max(x - r, 0); u <= std::min(x + r, W - 1); ++u) {
          const double i = guide.at<float>(v, u), p = src.at<float>(v, u);
          si += i, sp += p, sip += i * p, sii += i * i, n += 1;
        }
      const double mi = si / n, mp = sp / n;
      a.at<double>(y, x) = (sip / n - mi * mp) / (sii / n - mi * mi + eps);
      b.at<double>(y, x) = mp - a.at<double>(y, x) * mi;
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double sa = 0, sb = 0, n = 0;
      for (int v = std::max(y - r, 0); v <= std::min(y + r, H - 1); ++v)
        for (int u = std::max(x - r, 0); u <= std::min(x + r, W - 1); ++u)
          sa += a.at<double>(v, u), sb += b.at<double>(v, u), n += 1;
      out.at<float>(y, x) = static_cast<float>(sa / n * guide.at<float>(y, x) + sb / n);
    }
  return out;
}

TEST(ImageOps, GuidedFilterEqualsItsDefinitionAndKeepsTheGuidesEdges) {
  int seed = 70;
  for (const cv::Size& s : {cv::Size(1, 1), cv::Size(7, 3), cv::Size(31, 17), cv::Size(64, 48)})
    for (int r : {1, 4, 12}) {
      const cv::Mat guide = random_float(s, ++seed), src = random_float(s, ++seed);
      rs::GuidedFilter gf(r, 1e-3);
      cv::Mat ours;
      gf.apply(guide, src, ours);
      const cv::Mat ref = guided_reference(guide, src, r, 1e-3);
      double worst = 0;
      for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
          worst = std::max(worst, std::abs(double(ours.at<float>(y, x)) - ref.at<float>(y, x)));
      EXPECT_LT(worst, 2e-4) << s << " r " << r;
      cv::Mat alias = src.clone();
      gf.apply(guide, alias, alias);  // in place
      EXPECT_EQ(cv::norm(alias, ours, cv::NORM_INF), 0.0) << s << " r " << r << " in place";
      cv::Mat g8, from8;
      guide.convertTo(g8, CV_8U, 255.0);
      cv::Mat g8f;
      g8.convertTo(g8f, CV_32F, 1.0 / 255.0);
      gf.apply(g8, src, from8);  // an 8-bit guide reads as value / 255
      gf.apply(g8f, src, ours);
      EXPECT_LT(cv::norm(from8, ours, cv::NORM_INF), 1e-6) << s << " r " << r << " 8-bit guide";
    }
  // A rock (a bright square in the guide) whose painted map has a hole of low values inside it
  // (its mid-grey middle): within the rock's flat guide the filter smooths the hole up towards its
  // surroundings, and across the rock's edge it keeps the map's step where a plain mean of the
  // same windows bleeds it onto the ground.
  cv::Mat guide(60, 60, CV_32F, cv::Scalar(0.2f)), map(60, 60, CV_32F, cv::Scalar(0.f));
  const cv::Rect square(15, 15, 30, 30);
  guide(square).setTo(0.8f);
  map(square).setTo(1.f);
  map(cv::Rect(25, 25, 8, 8)).setTo(0.2f);
  rs::GuidedFilter gf(6, 1e-3);
  cv::Mat out, box;
  gf.apply(guide, map, out, 0.f, 1.f);
  cv::blur(map, box, cv::Size(13, 13));  // the plain mean of the same windows
  EXPECT_GT(out.at<float>(29, 29), 0.6f) << "the hole is filled in";
  EXPECT_LT(out.at<float>(30, 12), 0.1f * box.at<float>(30, 12)) << "3 px outside the rock";
  EXPECT_LT(out.at<float>(30, 5), 0.01f);
  double lo, hi;
  cv::minMaxLoc(out, &lo, &hi);
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  EXPECT_THROW(rs::GuidedFilter(0, 1e-3), std::invalid_argument);
  EXPECT_THROW(rs::GuidedFilter(4, 0.0), std::invalid_argument);
  EXPECT_THROW(gf.apply(cv::Mat(5, 5, CV_32F), cv::Mat(4, 4, CV_32F), out), std::invalid_argument);
  EXPECT_THROW(gf.apply(cv::Mat(4, 4, CV_16U), cv::Mat(4, 4, CV_32F), out), std::invalid_argument);
}

TEST(ImageOps, Sobel3EqualsCvSobel) {
  int seed = 90;
  for (const cv::Size& s : kSizes) {
    const cv::Mat src = random_float(s, ++seed);
    cv::Mat gx, gy, rx, ry;
    rs::sobel3_32f(src, gx, gy, 0.125f);
    cv::Sobel(src, rx, CV_32F, 1, 0, 3, 0.125);
    cv::Sobel(src, ry, CV_32F, 0, 1, 3, 0.125);
    EXPECT_LT(rel_diff(gx, rx), 1e-6) << s;
    EXPECT_LT(rel_diff(gy, ry), 1e-6) << s;
  }
}

TEST(ImageOps, TrainedRockStagesAllocateNothingPerFrameOnceWarm) {
  // What the `sams` component runs per frame with method trained: candidates and features, the
  // forest's scores, NMS, the pixel score map, the box refinement, the map's guided filter and the
  // pixel stage; the second image of a size (other content) allocates nothing.
  const rs::TrainedModel model = rs::load_trained_model(rs::default_trained_model_path());
  ASSERT_TRUE(model.has_pixel_stage());
  for (const cv::Size s : {cv::Size(320, 240), cv::Size(640, 480)}) {
    rs::CandidateExtractor ex(model.candidates);
    rs::CandidateSet set;
    std::vector<float> scores;
    std::vector<rs::Detection> dets;
    std::vector<int> spans;
    rs::TrainedModel::BoxScratch box_scratch;
    rs::TrainedMapScratch map_scratch;
    cv::Mat map;
    const std::size_t most = ex.max_candidates(s);
    scores.reserve(most);
    dets.reserve(most);
    box_scratch.reserve(s, most);
    auto frame = [&](int seed) {
      cv::Mat gray(s, CV_8U, cv::Scalar(100));
      std::mt19937 rng(static_cast<unsigned>(seed));
      std::uniform_int_distribution<int> ux(0, s.width - 1), uy(0, s.height - 1), ur(4, s.width / 12), ug(20, 235);
      for (int k = 0; k < 30; ++k)
        cv::ellipse(gray, {ux(rng), uy(rng)}, {ur(rng), ur(rng)}, 13.0 * k, 0, 360, ug(rng), -1);
      cv::Mat noise(s, CV_8U);
      cv::randu(noise, 0, 12);
      gray += noise;
      return gray;
    };
    auto run = [&](const cv::Mat& gray) {
      ex.extract(gray, set);
      model.score(set, scores);
      rs::TrainedModel::score_map(set, scores, map, spans);
      rs::TrainedModel::boxes(set, scores, map, model.box, dets, box_scratch);
      model.finish_map(gray, map, map_scratch);
    };
    const cv::Mat frames[] = {frame(1), frame(2), frame(3), frame(4)};
    run(frames[0]);
    const std::uint64_t a0 = regolith::testing::thread_allocations();
    std::size_t candidates = 0, kept = 0;
    for (int k = 1; k < 4; ++k) {
      run(frames[k]);
      candidates += set.candidates.size();
      kept += dets.size();
    }
    EXPECT_EQ(regolith::testing::thread_allocations() - a0, 0u) << s;
    EXPECT_GT(candidates, 10u) << s;
    EXPECT_GT(kept, 0u) << s;
    EXPECT_EQ(scores.size(), set.candidates.size());
  }
}
