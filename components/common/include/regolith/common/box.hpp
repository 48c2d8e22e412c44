#pragma once
// Box sums over a (2 radius + 1)^2 window with clamped (replicated) borders, CV_32F, separable:
// a vertical pass into a caller-owned scratch image, then a running horizontal sum in double.
// The vertical pass sums the window's rows directly (sequential memory, no drift) for small
// radii; for larger ones it keeps running column sums in `acc` (CV_64F, one row: O(1) per pixel).
// No allocation once `dst`, `tmp` (src's size, CV_32F) and `acc` (1 x cols, CV_64F) exist (the
// real-time path preallocates them).
#include <algorithm>

#include <opencv2/core.hpp>

namespace regolith::common {

inline void box_sum(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp, int radius, cv::Mat* acc = nullptr) {
  const int w = radius, R = src.rows, C = src.cols;
  dst.create(R, C, CV_32F);
  tmp.create(R, C, CV_32F);
  if (acc != nullptr && w > 3) {
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
  for (int i = 0; i < R; ++i) {
    const float* t = tmp.ptr<float>(i);
    float* d = dst.ptr<float>(i);
    double run = 0;
    for (int j = -w; j <= w; ++j) run += t[std::clamp(j, 0, C - 1)];
    for (int j = 0; j < C; ++j) {
      d[j] = static_cast<float>(run);
      run += t[std::min(j + w + 1, C - 1)] - t[std::max(j - w, 0)];
    }
  }
}

}  // namespace regolith::common
