#pragma once
// Box sums over a (2 radius + 1)^2 window with clamped (replicated) borders, CV_32F: a direct
// vertical sum of the window's rows (sequential memory, no drift) into a caller-owned scratch
// image, then a running horizontal sum in double. No allocation once `dst` and `tmp` have src's
// size and type (the real-time path preallocates them).
#include <opencv2/core.hpp>

#include <algorithm>

namespace regolith::common {

inline void box_sum(const cv::Mat& src, cv::Mat& dst, cv::Mat& tmp, int radius) {
  const int w = radius, R = src.rows, C = src.cols;
  dst.create(R, C, CV_32F);
  tmp.create(R, C, CV_32F);
  for (int i = 0; i < R; ++i) {
    float* t = tmp.ptr<float>(i);
    const float* s0 = src.ptr<float>(std::clamp(i - w, 0, R - 1));
    std::copy(s0, s0 + C, t);
    for (int k = -w + 1; k <= w; ++k) {
      const float* s = src.ptr<float>(std::clamp(i + k, 0, R - 1));
      for (int j = 0; j < C; ++j) t[j] += s[j];
    }
  }
  for (int i = 0; i < R; ++i) {
    const float* t = tmp.ptr<float>(i);
    float* d = dst.ptr<float>(i);
    double acc = 0;
    for (int j = -w; j <= w; ++j) acc += t[std::clamp(j, 0, C - 1)];
    for (int j = 0; j < C; ++j) {
      d[j] = static_cast<float>(acc);
      acc += t[std::min(j + w + 1, C - 1)] - t[std::max(j - w, 0)];
    }
  }
}

}  // namespace regolith::common
