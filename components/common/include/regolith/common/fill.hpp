#pragma once
// Fills a (continuous or strided) single- or multi-channel Mat with one value without allocating:
// cv::Mat::setTo converts its scalar through a heap buffer, which a rate-group cycle must avoid.
#include <algorithm>

#include <opencv2/core.hpp>

namespace regolith::common {

template <class T>
void fill(cv::Mat& m, T v) {
  for (int r = 0; r < m.rows; ++r) {
    T* p = m.ptr<T>(r);
    std::fill(p, p + static_cast<std::ptrdiff_t>(m.cols) * m.channels(), v);
  }
}

}  // namespace regolith::common
