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

namespace regolith::common {

inline constexpr int kDirectBoxRadius = 3;

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
  if (w <= kDirectBoxRadius) {
    const int j0 = std::min(w, C), j1 = std::max(j0, C - w);  // [j0, j1): the window inside the row
    for (int i = 0; i < R; ++i) {
      const float* t = tmp.ptr<float>(i);
      float* d = dst.ptr<float>(i);
      for (int j = j0; j < j1; ++j) d[j] = t[j - w];
      for (int k = -w + 1; k <= w; ++k)
        for (int j = j0; j < j1; ++j) d[j] += t[j + k];
      const auto clamped = [&](int j) {
        float s = t[std::clamp(j - w, 0, C - 1)];
        for (int k = -w + 1; k <= w; ++k) s += t[std::clamp(j + k, 0, C - 1)];
        d[j] = s;
      };
      for (int j = 0; j < j0; ++j) clamped(j);
      for (int j = j1; j < C; ++j) clamped(j);
    }
    return;
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

}  // namespace regolith::common
