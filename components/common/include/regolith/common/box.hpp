#pragma once
// Box sums over a (2 radius + 1)^2 window with clamped (replicated) borders, CV_32F, separable:
// a vertical pass into a caller-owned scratch image, then a horizontal one. For small radii
// (<= kDirectBoxRadius) both sum the window directly in float (sequential memory, no drift, and
// the compiler vectorises them: the matching searches run one per hypothesis); for larger ones
// the vertical pass keeps running column sums in `acc` (CV_64F, one row: O(1) per pixel) when
// given, and the horizontal pass a running sum in double.
// No allocation once `dst`, `tmp` (src's size, CV_32F) and `acc` (1 x cols, CV_64F) exist (the
// real-time path preallocates them).
#include <algorithm>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>

namespace regolith::common {

inline constexpr int kDirectBoxRadius = 3;

/// Columns [begin, end) of one image row: where a matching search has cells worth computing.
struct ColumnSpan {
  int begin = 0;
  int end = 0;
};

/// Row i of the direct window sums, written to dst only over the columns of `out`: the vertical
/// pass into `tmp` over those columns and the radius either side, then the horizontal pass. Each
/// sum adds the same samples in the same order whatever `out` is, so a value equals box_sum's bit
/// for bit for radius <= kDirectBoxRadius (box_sum's running sums of larger radii round
/// differently; here any radius adds its 2 radius + 1 terms per pass).
inline void box_sum_row(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp, int w, int i, ColumnSpan out) {
  const int R = src.rows, C = src.cols;
  if (out.begin >= out.end) return;
  const int vb = std::max(0, out.begin - w), ve = std::min(C, out.end + w);
  float* t = tmp.ptr<float>(i);
  // The window's rows top to bottom, each column's sum kept in a register, four columns at a
  // time (the scalar tail adds in the same order); the rows in batches of kRowBatch, a later batch
  // adding to the stored sum (the same adds in the same order: a float stored and loaded is
  // unchanged).
  constexpr int L = cv::v_float32x4::nlanes, kRowBatch = 9;
  const float* rows[kRowBatch];
  for (int k0 = 0; k0 < 2 * w + 1; k0 += kRowBatch) {
    const int n = std::min(kRowBatch, 2 * w + 1 - k0);
    for (int k = 0; k < n; ++k) rows[k] = src.ptr<float>(std::clamp(i - w + k0 + k, 0, R - 1));
    const float* first = k0 == 0 ? rows[0] : t;  // the batch's first term
    const int kb = k0 == 0 ? 1 : 0;              // its first row still to add
    int j = vb;
    for (; j + L <= ve; j += L) {
      cv::v_float32x4 a = cv::v_load(first + j);
      for (int k = kb; k < n; ++k) a = a + cv::v_load(rows[k] + j);
      cv::v_store(t + j, a);
    }
    for (; j < ve; ++j) {
      float a = first[j];
      for (int k = kb; k < n; ++k) a += rows[k][j];
      t[j] = a;
    }
  }
  const int j0 = std::min(w, C), j1 = std::max(j0, C - w);  // [j0, j1): the window inside the row
  const int ib = std::max(j0, out.begin), ie = std::max(ib, std::min(j1, out.end));
  float* d = dst.ptr<float>(i);
  int c = ib;  // the same way along the row
  for (; c + L <= ie; c += L) {
    cv::v_float32x4 a = cv::v_load(t + c - w);
    for (int k = -w + 1; k <= w; ++k) a = a + cv::v_load(t + c + k);
    cv::v_store(d + c, a);
  }
  for (; c < ie; ++c) {
    float a = t[c - w];
    for (int k = -w + 1; k <= w; ++k) a += t[c + k];
    d[c] = a;
  }
  const auto clamped = [&](int j) {
    float sum = t[std::clamp(j - w, 0, C - 1)];
    for (int k = -w + 1; k <= w; ++k) sum += t[std::clamp(j + k, 0, C - 1)];
    d[j] = sum;
  };
  for (int j = out.begin; j < std::min(out.end, j0); ++j) clamped(j);
  for (int j = std::max(out.begin, j1); j < out.end; ++j) clamped(j);
}

inline void box_sum(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp, int radius, cv::Mat* acc = nullptr) {
  const int w = radius, R = src.rows, C = src.cols;
  dst.create(R, C, CV_32F);
  tmp.create(R, C, CV_32F);
  if (acc != nullptr && w > kDirectBoxRadius) {
    acc->create(1, C, CV_64F);
    double* a = acc->ptr<double>(0);
    std::fill(a, a + C, 0.0);
    for (int k = -w; k <= w; ++k) {
      const float* s = src.ptr<float>(std::clamp(k, 0, R - 1));
      for (int j = 0; j < C; ++j) a[j] += s[j];
    }
    for (int i = 0; i < R; ++i) {
      float* t = tmp.ptr<float>(i);
      for (int j = 0; j < C; ++j) t[j] = static_cast<float>(a[j]);
      const float* in = src.ptr<float>(std::min(i + w + 1, R - 1));
      const float* out = src.ptr<float>(std::max(i - w, 0));
      for (int j = 0; j < C; ++j) a[j] += static_cast<double>(in[j]) - out[j];
    }
  } else if (w <= kDirectBoxRadius) {
    for (int i = 0; i < R; ++i) box_sum_row(src, dst, tmp, w, i, {0, C});
    return;
  } else {
    for (int i = 0; i < R; ++i) {
      float* t = tmp.ptr<float>(i);
      const float* s0 = src.ptr<float>(std::clamp(i - w, 0, R - 1));
      std::copy(s0, s0 + C, t);
      for (int k = -w + 1; k <= w; ++k) {
        const float* s = src.ptr<float>(std::clamp(i + k, 0, R - 1));
        for (int j = 0; j < C; ++j) t[j] += s[j];
      }
    }
  }
  // The running sums of N rows at once: each row's sum is one chain of dependent adds, so N
  // independent chains keep the adder busy (each row's result is the single-row one exactly).
  const auto running_rows = [&]<int N>(int i0) {
    const float* t[N];
    float* d[N];
    double run[N];
    for (int q = 0; q < N; ++q) {
      t[q] = tmp.ptr<float>(i0 + q);
      d[q] = dst.ptr<float>(i0 + q);
      run[q] = 0;
      for (int j = -w; j <= w; ++j) run[q] += t[q][std::clamp(j, 0, C - 1)];
    }
    for (int j = 0; j < C; ++j) {
      const int in = std::min(j + w + 1, C - 1), out = std::max(j - w, 0);
      for (int q = 0; q < N; ++q) {
        d[q][j] = static_cast<float>(run[q]);
        run[q] += t[q][in] - t[q][out];
      }
    }
  };
  int i = 0;
  for (; i + 4 <= R; i += 4) running_rows.template operator()<4>(i);
  for (; i < R; ++i) running_rows.template operator()<1>(i);
}

/// box_sum over each row's span only (`spans`: one per row of src), bit for bit box_sum's values
/// there; dst outside the spans is left as it was. A radius above kDirectBoxRadius sums the whole
/// image (its running sums start at the row's first column).
inline void box_sum_spans(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp, int radius, const ColumnSpan* spans) {
  if (radius > kDirectBoxRadius) {
    box_sum(src, dst, tmp, radius);
    return;
  }
  dst.create(src.rows, src.cols, CV_32F);
  tmp.create(src.rows, src.cols, CV_32F);
  for (int i = 0; i < src.rows; ++i) box_sum_row(src, dst, tmp, radius, i, spans[i]);
}

}  // namespace regolith::common
