// Hungarian assignment, box IoU, one-to-one matching, N-MODA / N-MODP, centroid
// hits and the pixel-level F-measure / MAE on hand-built cases with known
// answers.
#include <algorithm>
#include <numeric>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "regolith/saliency/evaluate.hpp"
#include "regolith/saliency/hungarian.hpp"

namespace rs = regolith::saliency;

namespace {

double total_cost(const std::vector<double>& c, int cols, const std::vector<int>& a) {
  double s = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] >= 0) s += c[i * static_cast<size_t>(cols) + static_cast<size_t>(a[i])];
  }
  return s;
}

// Brute force over all injective maps of the smaller side.
double brute_force(const std::vector<double>& c, int rows, int cols) {
  const bool tall = rows > cols;
  const int n = tall ? cols : rows, m = tall ? rows : cols;
  std::vector<int> perm(static_cast<size_t>(m));
  std::iota(perm.begin(), perm.end(), 0);
  double best = 1e300;
  do {
    double s = 0.0;
    for (int i = 0; i < n; ++i) {
      const int r = tall ? perm[static_cast<size_t>(i)] : i;
      const int col = tall ? i : perm[static_cast<size_t>(i)];
      s += c[static_cast<size_t>(r) * static_cast<size_t>(cols) + static_cast<size_t>(col)];
    }
    best = std::min(best, s);
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

rs::FrameTruth truth_with_boxes(cv::Size size, const std::vector<cv::Rect>& boxes) {
  cv::Mat mask = cv::Mat::zeros(size, CV_8U);
  for (const auto& b : boxes) mask(b).setTo(255);
  return rs::truth_from_mask(mask, 50);
}

}  // namespace

TEST(Hungarian, KnownThreeByThree) {
  // The unique optimum is rows -> cols (1, 0, 2) with cost 1 + 2 + 2 = 5.
  const std::vector<double> c = {4, 1, 3,  //
                                 2, 0, 5,  //
                                 3, 2, 2};
  const auto a = rs::solve_assignment(c, 3, 3);
  ASSERT_EQ(a.size(), 3u);
  EXPECT_EQ(a[0], 1);
  EXPECT_EQ(a[1], 0);
  EXPECT_EQ(a[2], 2);
  EXPECT_DOUBLE_EQ(total_cost(c, 3, a), 5.0);
}

TEST(Hungarian, RectangularWideAndTall) {
  // Wide: 2 rows, 3 columns. Best: row0->col2 (1), row1->col0 (2) = 3.
  const std::vector<double> wide = {5, 4, 1,  //
                                    2, 3, 6};
  const auto a = rs::solve_assignment(wide, 2, 3);
  EXPECT_EQ(a, (std::vector<int>{2, 0}));
  // Tall: the transpose; one row stays unassigned.
  const std::vector<double> tall = {5, 2,  //
                                    4, 3,  //
                                    1, 6};
  const auto b = rs::solve_assignment(tall, 3, 2);
  EXPECT_EQ(b, (std::vector<int>{1, -1, 0}));
  EXPECT_TRUE(rs::solve_assignment({}, 0, 4).empty());
  EXPECT_EQ(rs::solve_assignment({}, 2, 0), (std::vector<int>{-1, -1}));
}

TEST(Hungarian, MatchesBruteForceOnRandomMatrices) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int rows = 1 + trial % 6, cols = 1 + (trial / 6) % 6;
    std::vector<double> c(static_cast<size_t>(rows * cols));
    for (auto& v : c) v = (trial % 3 == 0) ? std::round(u(rng) * 3) : u(rng);  // ties too
    const auto a = rs::solve_assignment(c, rows, cols);
    // One-to-one and min(rows, cols) pairs.
    std::vector<int> used;
    for (int x : a) {
      if (x >= 0) used.push_back(x);
    }
    std::sort(used.begin(), used.end());
    EXPECT_EQ(std::adjacent_find(used.begin(), used.end()), used.end());
    EXPECT_EQ(static_cast<int>(used.size()), std::min(rows, cols));
    EXPECT_NEAR(total_cost(c, cols, a), brute_force(c, rows, cols), 1e-9) << "rows=" << rows << " cols=" << cols;
  }
}

TEST(Hungarian, BadInputNamesTheProblem) {
  EXPECT_THROW(rs::solve_assignment({1, 2, 3}, 2, 2), std::invalid_argument);
  try {
    rs::solve_assignment({1, std::nan(""), 3, 4}, 2, 2);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cost[1]"), std::string::npos);
  }
}

TEST(Metrics, Iou) {
  EXPECT_DOUBLE_EQ(rs::iou({0, 0, 10, 10}, {0, 0, 10, 10}), 1.0);
  EXPECT_DOUBLE_EQ(rs::iou({0, 0, 10, 10}, {5, 0, 10, 10}), 50.0 / 150.0);
  EXPECT_DOUBLE_EQ(rs::iou({0, 0, 10, 10}, {20, 20, 5, 5}), 0.0);
  EXPECT_DOUBLE_EQ(rs::iou({0, 0, 0, 0}, {0, 0, 0, 0}), 0.0);
}

TEST(Metrics, TruthFromMaskComponentsAndIgnoredSmallOnes) {
  cv::Mat mask = cv::Mat::zeros(100, 100, CV_8U);
  mask(cv::Rect(10, 10, 20, 10)).setTo(255);  // 200 px
  mask(cv::Rect(60, 60, 5, 5)).setTo(255);    // 25 px -> ignored at 50
  mask.at<uchar>(20, 30) = 255;               // diagonal neighbour of (19,29): same component
  const auto t = rs::truth_from_mask(mask, 50);
  ASSERT_EQ(t.objects.size(), 2u);
  EXPECT_EQ(t.objects[0].box, cv::Rect(10, 10, 21, 11));
  EXPECT_EQ(t.objects[0].area, 201);
  EXPECT_FALSE(t.objects[0].ignored);
  EXPECT_TRUE(t.objects[1].ignored);
  EXPECT_EQ(t.valid_count(), 1);
}

TEST(Metrics, PerfectAllMissesAllFalsePositives) {
  const std::vector<cv::Rect> gt = {{0, 0, 20, 20}, {50, 50, 20, 20}, {100, 10, 30, 15}};
  const auto t = truth_with_boxes({200, 100}, gt);
  // Perfect.
  auto m = rs::match_frame(gt, t, 0.5);
  EXPECT_EQ(m.matched, 3);
  EXPECT_DOUBLE_EQ(rs::n_moda({m}), 1.0);
  EXPECT_DOUBLE_EQ(rs::n_modp({m}), 1.0);
  // All misses: N-MODA 0.
  m = rs::match_frame({}, t, 0.5);
  EXPECT_EQ(m.misses(), 3);
  EXPECT_DOUBLE_EQ(rs::n_moda({m}), 0.0);
  EXPECT_DOUBLE_EQ(rs::n_modp({m}), 0.0);
  // All false positives (2 boxes elsewhere) and all misses: 1 - (3 + 2) / 3.
  m = rs::match_frame({{150, 60, 10, 10}, {170, 80, 10, 10}}, t, 0.2);
  EXPECT_EQ(m.false_positives(), 2);
  EXPECT_NEAR(rs::n_moda({m}), 1.0 - 5.0 / 3.0, 1e-12);
}

TEST(Metrics, PartialOverlapsAtBothThresholds) {
  const auto t = truth_with_boxes({200, 100}, {{0, 0, 10, 10}, {50, 50, 20, 20}});
  // Det A overlaps GT0 with IoU 1/3; det B overlaps GT1 with IoU 300/400 = 0.75
  // (20x15 inside).
  const std::vector<cv::Rect> dets = {{5, 0, 10, 10}, {50, 50, 20, 15}, {150, 0, 10, 10}};
  const auto m2 = rs::match_frame(dets, t, 0.2);
  EXPECT_EQ(m2.matched, 2);
  EXPECT_EQ(m2.misses(), 0);
  EXPECT_EQ(m2.false_positives(), 1);
  EXPECT_NEAR(rs::n_moda({m2}), 1.0 - 1.0 / 2.0, 1e-12);
  EXPECT_NEAR(rs::n_modp({m2}), (1.0 / 3.0 + 0.75) / 2.0, 1e-12);
  const auto m5 = rs::match_frame(dets, t, 0.5);
  EXPECT_EQ(m5.matched, 1);
  EXPECT_NEAR(rs::n_moda({m5}), 1.0 - (1.0 + 2.0) / 2.0, 1e-12);
  EXPECT_NEAR(rs::n_modp({m5}), 0.75, 1e-12);
  // Pooled over two frames: sums, not means of per-frame MODA.
  const auto t2 = truth_with_boxes({200, 100}, {{0, 0, 20, 20}, {30, 30, 20, 20}, {60, 60, 20, 20}, {100, 10, 20, 20}});
  const auto m_other = rs::match_frame({{0, 0, 20, 20}}, t2, 0.5);  // 1 match, 3 misses
  EXPECT_NEAR(rs::n_moda({m5, m_other}), 1.0 - (3.0 + 3.0) / 6.0, 1e-12);
}

TEST(Metrics, OneToOneMatchingPrefersTheGlobalOptimum) {
  // Two GT side by side, one wide detection over both (IoU 0.476 with each) and
  // one exact detection on GT1: the optimum pairs the wide box with GT0 and the
  // exact one with GT1.
  const auto t = truth_with_boxes({100, 40}, {{0, 0, 20, 20}, {22, 0, 20, 20}});
  const std::vector<cv::Rect> dets = {{0, 0, 42, 20}, {22, 0, 20, 20}};
  const auto m = rs::match_frame(dets, t, 0.4);
  EXPECT_EQ(m.matched, 2);  // wide det: IoU with GT0 = 400/840 = 0.476
  EXPECT_NEAR(m.iou_sum, 400.0 / 840.0 + 1.0, 1e-12);
}

TEST(Metrics, DetectionOnIgnoredComponentIsNotAFalsePositive) {
  cv::Mat mask = cv::Mat::zeros(100, 100, CV_8U);
  mask(cv::Rect(10, 10, 30, 30)).setTo(255);
  mask(cv::Rect(70, 70, 6, 6)).setTo(255);  // 36 px < 50 -> ignored
  const auto t = rs::truth_from_mask(mask, 50);
  const auto m = rs::match_frame({{10, 10, 30, 30}, {70, 70, 6, 6}, {0, 80, 10, 10}}, t, 0.5);
  EXPECT_EQ(m.n_gt, 1);
  EXPECT_EQ(m.matched, 1);
  EXPECT_EQ(m.n_det, 2);  // the one on the ignored component does not count
  EXPECT_EQ(m.false_positives(), 1);
}

TEST(Metrics, CentroidHitsCountEachComponentOnce) {
  const auto t = truth_with_boxes({100, 100}, {{0, 0, 30, 30}, {50, 50, 30, 30}});
  // Two boxes centred in GT0, one centred on background.
  EXPECT_EQ(rs::centroid_hits({{5, 5, 10, 10}, {10, 10, 10, 10}, {35, 35, 10, 10}}, t), 1);
  EXPECT_EQ(rs::centroid_hits({{5, 5, 10, 10}, {55, 55, 10, 10}}, t), 2);
}

TEST(Metrics, PixelFMeasureAndMae) {
  cv::Mat mask = cv::Mat::zeros(10, 10, CV_8U);
  mask(cv::Rect(0, 0, 5, 10)).setTo(255);
  // A perfect map: max F = 1, MAE = 0.
  auto p = rs::pixel_stats(mask, mask);
  EXPECT_DOUBLE_EQ(*std::max_element(p.f_curve.begin(), p.f_curve.end()), 1.0);
  EXPECT_DOUBLE_EQ(p.mae, 0.0);
  // Constant 51 (0.2): MAE = 0.5 * 0.8 + 0.5 * 0.2 = 0.5; at t <= 51 all pixels
  // positive: P = 0.5, R = 1 -> F = 1.3 * 0.5 / (0.3 * 0.5 + 1) = 0.565217...
  cv::Mat c(10, 10, CV_8U, cv::Scalar(51));
  p = rs::pixel_stats(c, mask);
  EXPECT_NEAR(p.mae, 0.5, 1e-12);
  EXPECT_NEAR(p.f_curve[51], 1.3 * 0.5 / 1.15, 1e-12);
  EXPECT_DOUBLE_EQ(p.f_curve[52], 0.0);
  EXPECT_THROW(rs::pixel_stats(c, cv::Mat::zeros(5, 5, CV_8U)), std::invalid_argument);
}

TEST(Metrics, SummaryPoolsFramesAndTableHasOneRowPerMethod) {
  const auto t = truth_with_boxes({200, 100}, {{0, 0, 10, 10}, {50, 50, 20, 20}});
  std::vector<rs::Detection> dets(2);
  dets[0].box = {0, 0, 10, 10};
  dets[1].box = {150, 0, 10, 10};
  const auto r = rs::evaluate_frame("a.png", dets, t);
  const auto s = rs::summarise({r, r});
  EXPECT_EQ(s.images, 2);
  EXPECT_EQ(s.gt, 4);
  EXPECT_NEAR(s.n_moda05, 1.0 - 4.0 / 4.0, 1e-12);
  EXPECT_NEAR(s.precision05, 0.5, 1e-12);
  EXPECT_NEAR(s.recall05, 0.5, 1e-12);
  EXPECT_NEAR(s.centroid_rate, 0.5, 1e-12);
  EXPECT_LT(s.max_f, 0.0);  // no pixel stats given
  const std::string md = rs::markdown_table({{"itti", s}, {"sams", s}});
  EXPECT_EQ(std::count(md.begin(), md.end(), '\n'), 4);
  EXPECT_NE(md.find("| sams | 2 | 4 | 4 | 0.000 | 1.000 | 0.500 | 0.500 |"), std::string::npos) << md;
}
