#pragma once
// The 1-D matching search both parallax cues run (GroundParallax along the baseline in the
// rectified frame, PlaneSweep over height hypotheses in the image): window costs per hypothesis
// t arrive as rolling slices c0 = t-2, c1 = t-1, c2 = t; a minimum at t-1 bracketed by its
// neighbours replaces the best so far. Then a parabola through the three gives the sub-step
// offset and the match confidence. Header-only, no allocation.
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>

#include "regolith/common/box.hpp"

namespace regolith::mapping {

/// `ok4` (CV_8U, `ok`'s size, made by the caller) = 1 where the bilinear footprint of (i, j) — the
/// sample, its right, lower and lower-right neighbours — is usable in `ok` (CV_8U, non-zero =
/// usable); 0 on the last row and column. Both searches sample the current frame bilinearly, so
/// one lookup per hypothesis replaces four.
inline void bilinear_footprint_usable(const cv::Mat& ok, cv::Mat& ok4) {
  const int R = ok.rows, C = ok.cols;
  for (int i = 0; i < R; ++i) {
    uchar* o = ok4.ptr<uchar>(i);
    const uchar* u = ok.ptr<uchar>(i);
    const uchar* v = i + 1 < R ? ok.ptr<uchar>(i + 1) : nullptr;
    for (int j = 0; j < C; ++j) o[j] = v && j + 1 < C && u[j] && u[j + 1] && v[j] && v[j + 1] ? 1 : 0;
  }
}

/// The cost of a sample that cannot be compared (4 x the largest squared grey-level difference):
/// both searches' sample costs, and the level at or above which a window sum holds one.
inline constexpr float kUnusableSampleCost = 4.0f * 255.0f * 255.0f;

/// One row of a search's sample costs for one hypothesis, over the columns of `span`: e[j] =
/// (cur(at_row[j], at_col[j]) - gain key[j] - bias)^2 with `cur` (CV_32F) sampled bilinearly, or
/// kUnusableSampleCost where the keyframe sample is unusable (key_ok[j] == 0), the position lies outside
/// cur's bilinear footprint (or is NaN) or that footprint is unusable (`cur_ok4` of
/// bilinear_footprint_usable). Both searches run it: GroundParallax on the rectified grid,
/// PlaneSweep in the image.
inline void bilinear_costs(const float* at_row, const float* at_col, const float* key, const uchar* key_ok,
                           const cv::Mat& cur, const cv::Mat& cur_ok4, float gain, float bias, common::ColumnSpan span,
                           float* e) {
  const float row_max = static_cast<float>(cur.rows - 1), col_max = static_cast<float>(cur.cols - 1);
  for (int j = span.begin; j < span.end; ++j) {
    const float ci = at_row[j], cj = at_col[j];
    // Inside the footprint (a NaN fails too) before the conversion; there truncation is the floor.
    if (!key_ok[j] || !(ci >= 0.0f && cj >= 0.0f && ci < row_max && cj < col_max)) {
      e[j] = kUnusableSampleCost;
      continue;
    }
    const int i0 = static_cast<int>(ci), j0 = static_cast<int>(cj);
    if (!cur_ok4.ptr<uchar>(i0)[j0]) {
      e[j] = kUnusableSampleCost;
      continue;
    }
    const float fi = ci - static_cast<float>(i0), fj = cj - static_cast<float>(j0);
    const float* ra = cur.ptr<float>(i0);
    const float* rb = cur.ptr<float>(i0 + 1);
    const float top = ra[j0] + fj * (ra[j0 + 1] - ra[j0]), bot = rb[j0] + fj * (rb[j0 + 1] - rb[j0]);
    const float r = top + fi * (bot - top) - gain * key[j] - bias;
    e[j] = r * r;
  }
}

/// Rows [r0, r1] of CV_32F images: where c1 is a bracketed minimum below best, records it (best,
/// index t - 1 in `at`, its neighbours in left / right). `second` (optional, filled with the same
/// "none" value as best) keeps the lowest of the other bracketed minima: another valley of the
/// cost, as deep as the best one on a repetitive texture. `spans` (optional, one per row of the
/// images) limits each row to its columns; the others are left as they were.
inline void keep_bracketed_minimum(const cv::Mat& c0, const cv::Mat& c1, const cv::Mat& c2, cv::Mat& best, cv::Mat& at,
                                   cv::Mat& left, cv::Mat& right, int t, int r0, int r1, cv::Mat* second = nullptr,
                                   const common::ColumnSpan* spans = nullptr) {
  for (int i = r0; i <= r1; ++i) {
    const float* l = c0.ptr<float>(i);
    const float* c = c1.ptr<float>(i);
    const float* r = c2.ptr<float>(i);
    float* b = best.ptr<float>(i);
    float* bs = at.ptr<float>(i);
    float* lf = left.ptr<float>(i);
    float* rt = right.ptr<float>(i);
    float* sc = second != nullptr ? second->ptr<float>(i) : nullptr;
    const auto update = [&](int j0, int j1) {
      for (int j = j0; j < j1; ++j) {
        if (!(c[j] <= l[j] && c[j] <= r[j])) continue;
        if (c[j] < b[j]) {
          if (sc != nullptr) sc[j] = b[j];
          b[j] = c[j];
          bs[j] = static_cast<float>(t - 1);
          lf[j] = l[j];
          rt[j] = r[j];
        } else if (sc != nullptr && c[j] < sc[j]) {
          sc[j] = c[j];
        }
      }
    };
    // Four cells at a time first: most cells are no minimum below the best (or the second) at a
    // given t, and one vector compare rejects four of them (the second is never below the best,
    // so "below the second" covers both updates). The cells of a block that may update go through
    // the scalar rule, so the result is the scalar loop's exactly.
    const float* bar = sc != nullptr ? sc : b;
    const int n = spans != nullptr ? spans[i].end : best.cols;
    int j = spans != nullptr ? spans[i].begin : 0;
    for (; j + cv::v_float32x4::nlanes <= n; j += cv::v_float32x4::nlanes) {
      const cv::v_float32x4 vc = cv::v_load(c + j);
      const cv::v_float32x4 hit = (vc <= cv::v_load(l + j)) & (vc <= cv::v_load(r + j)) & (vc < cv::v_load(bar + j));
      if (cv::v_check_any(hit)) update(j, j + cv::v_float32x4::nlanes);
    }
    update(j, n);
  }
}

/// Lowe's ratio test on the cost valleys: false when the second-deepest valley (keep_bracketed_minimum's
/// `second`) is below `ratio` x the best plus one noise variance per window sample, i.e. another
/// height fits about as well (repetitive or smooth texture along the search line). ratio 0 = off.
inline bool unique_minimum(double best, double second, double ratio, double cells, double noise2) {
  return ratio <= 0 || second >= ratio * best + cells * noise2;
}

/// The one check of a uniqueness_ratio parameter: 0 (off) or in [1, 10].
inline bool valid_uniqueness_ratio(double ratio) {
  return ratio == 0 || (ratio >= 1 && ratio <= 10);
}

/// Sub-step offset (-0.5..0.5, in steps) of the parabola through (l, best, r) and the match's
/// confidence (0..1): the curvature per window sample in units of the noise (how sharply the
/// match is fixed), lowered when the best residual is well above the noise. False when the three
/// do not curve upwards. cells = samples per window, noise2 = noise variance (grey levels^2).
inline bool parabola_minimum(double l, double best, double r, double cells, double noise2, double& offset,
                             double& confidence) {
  const double curv = l + r - 2.0 * best;
  if (!(curv > 0)) return false;
  offset = std::clamp(0.5 * (l - r) / curv, -0.5, 0.5);
  const double sharp = curv / (cells * noise2);
  const double fit = std::exp(-std::max(0.0, best / cells - 2.0 * noise2) / (8.0 * noise2));
  confidence = sharp / (1.0 + sharp) * fit;
  return true;
}

}  // namespace regolith::mapping
