#include "regolith/saliency/detect.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = static_cast<double>(a.area()) + b.area() - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

void PostProcessParams::validate() const {
  if (!std::isfinite(threshold_scale) || threshold_scale <= 0.0 || threshold_scale > 10.0) {
    throw std::invalid_argument("PostProcessParams.threshold_scale: must be in (0, 10] (got " +
                                std::to_string(threshold_scale) + ")");
  }
  if (open_radius < 0 || open_radius > 100) {
    throw std::invalid_argument("PostProcessParams.open_radius: must be in [0,100] px");
  }
  if (close_radius < 0 || close_radius > 100) {
    throw std::invalid_argument("PostProcessParams.close_radius: must be in [0,100] px");
  }
  if (min_area < 1) throw std::invalid_argument("PostProcessParams.min_area: must be >= 1 px");
  if (max_detections < 0) {
    throw std::invalid_argument("PostProcessParams.max_detections: must be >= 0");
  }
}

int otsu_threshold(const std::array<double, 256>& hist) {
  double total = 0.0, sum_all = 0.0;
  for (int i = 0; i < 256; ++i) {
    total += hist[static_cast<size_t>(i)];
    sum_all += i * hist[static_cast<size_t>(i)];
  }
  if (total <= 0.0) return 0;
  double w0 = 0.0, sum0 = 0.0, best = -1.0;
  int best_t = 0;
  for (int t = 0; t < 255; ++t) {
    w0 += hist[static_cast<size_t>(t)];
    sum0 += t * hist[static_cast<size_t>(t)];
    const double w1 = total - w0;
    if (w0 <= 0.0 || w1 <= 0.0) continue;
    const double mu0 = sum0 / w0;
    const double mu1 = (sum_all - sum0) / w1;
    // w0 w1 (mu0 - mu1)^2 with class probabilities (normalised by total^2,
    // irrelevant to argmax).
    const double between = (w0 / total) * (w1 / total) * (mu0 - mu1) * (mu0 - mu1);
    if (between > best) {
      best = between;
      best_t = t;
    }
  }
  return best_t;
}

int otsu_threshold(const cv::Mat& image8u, const cv::Mat& mask) {
  if (image8u.empty() || image8u.type() != CV_8UC1) {
    throw std::invalid_argument("otsu_threshold: image must be non-empty CV_8UC1");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != image8u.size())) {
    throw std::invalid_argument("otsu_threshold: mask must be CV_8UC1 of the image's size");
  }
  // Integer counts in four interleaved histograms (no store-to-load chain on runs of one value),
  // summed exactly into the double histogram.
  std::array<std::array<std::uint32_t, 256>, 4> c{};
  for (int y = 0; y < image8u.rows; ++y) {
    const uchar* p = image8u.ptr<uchar>(y);
    const int n = image8u.cols;
    if (mask.empty()) {
      int x = 0;
      for (; x + 4 <= n; x += 4) {
        ++c[0][p[x]];
        ++c[1][p[x + 1]];
        ++c[2][p[x + 2]];
        ++c[3][p[x + 3]];
      }
      for (; x < n; ++x) ++c[0][p[x]];
    } else {
      const uchar* m = mask.ptr<uchar>(y);
      for (int x = 0; x < n; ++x) c[0][p[x]] += m[x] != 0 ? 1u : 0u;
    }
  }
  std::array<double, 256> h{};
  for (std::size_t v = 0; v < 256; ++v)
    h[v] = static_cast<double>(c[0][v]) + static_cast<double>(c[1][v]) + static_cast<double>(c[2][v]) +
           static_cast<double>(c[3][v]);
  return otsu_threshold(h);
}

void to_8bit(const cv::Mat& saliency, cv::Mat& out8) {
  if (saliency.empty() || saliency.channels() != 1) {
    throw std::invalid_argument("saliency: must be a non-empty single-channel map");
  }
  if (saliency.type() == CV_8UC1) {
    saliency.copyTo(out8);
  } else if (saliency.depth() == CV_32F || saliency.depth() == CV_64F) {
    saliency.convertTo(out8, CV_8U, 255.0);  // saturate_cast clamps to [0,255]
  } else {
    throw std::invalid_argument("saliency: must be CV_8U, CV_32F or CV_64F");
  }
}

BoxDetector::BoxDetector(PostProcessParams params) : params_(params) {
  params_.validate();
  if (params_.open_radius > 0) {
    const int d = 2 * params_.open_radius + 1;
    open_.emplace(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(d, d)));
  }
  if (params_.close_radius > 0) {
    const int d = 2 * params_.close_radius + 1;
    close_.emplace(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(d, d)));
  }
}

const cv::Mat& BoxDetector::mask() const {
  if (mask_stale_ && bits_.rows() > 0) bits_.unpack(mask_);
  mask_stale_ = false;
  return mask_;
}

void PreparedMap::prepare(const cv::Mat& saliency, bool sums_now) {
  to_8bit(saliency, map8);
  otsu = otsu_threshold(map8);
  integral.create(map8.rows + 1, map8.cols + 1, CV_64F);
  summed = false;
  if (sums_now) sums();
}

const cv::Mat& PreparedMap::sums() const {
  if (!summed) cv::integral(map8, integral, CV_64F);  // into the buffer prepare() sized
  summed = true;
  return integral;
}

int BoxDetector::detect(const cv::Mat& saliency, std::vector<Detection>& out) {
  prepared_.prepare(saliency, false);
  return detect(prepared_, out);
}

int BoxDetector::detect(const PreparedMap& map, std::vector<Detection>& out) {
  out.clear();
  const cv::Mat& map8 = map.map8;
  const int otsu = map.otsu;
  if (map8.empty() || map8.type() != CV_8UC1 || map.integral.rows != map8.rows + 1 ||
      map.integral.cols != map8.cols + 1 || map.integral.type() != CV_64F)
    throw std::invalid_argument("BoxDetector::detect: the map is not prepared (PreparedMap::prepare)");
  const int thr = std::clamp(static_cast<int>(std::lround(params_.threshold_scale * otsu)), 0, 254);
  bits_.threshold(map8, thr);  // > thr
  mask_stale_ = true;
  // Opening / closing = cv::morphologyEx MORPH_OPEN / MORPH_CLOSE with the default border, and
  // 8-connected labelling = cv::connectedComponentsWithStats, on bits into buffers kept between
  // calls (the OpenCV calls allocate engines and tables at every call).
  if (open_) {
    open_->erode(bits_, bits_tmp_);
    open_->dilate(bits_tmp_, bits_);
  }
  if (close_) {
    close_->dilate(bits_, bits_tmp_);
    close_->erode(bits_tmp_, bits_);
  }
  const int n = components_.run(bits_);
  if (n < 1) return thr;
  double box_pixels = 0.0;
  for (int i = 0; i < n; ++i) {
    const std::array<int, 5>& st = components_.stats(i);
    const int area = st[cv::CC_STAT_AREA];
    if (area < params_.min_area) continue;
    Detection d;
    d.box = cv::Rect(st[cv::CC_STAT_LEFT], st[cv::CC_STAT_TOP], st[cv::CC_STAT_WIDTH], st[cv::CC_STAT_HEIGHT]);
    d.area = area;
    box_pixels += static_cast<double>(d.box.area());
    out.push_back(d);
  }
  // Score = mean of map8 in the box: summed directly while the boxes cover less than the frame,
  // else from the integral image (exact integer sums either way, so the same scores).
  const bool direct = !map.summed && box_pixels <= static_cast<double>(map8.total());
  for (Detection& d : out) {
    const cv::Rect& b = d.box;
    double s = 0.0;
    if (direct) {
      std::uint64_t sum = 0;
      for (int y = b.y; y < b.y + b.height; ++y) {
        const uchar* p = map8.ptr<uchar>(y) + b.x;
        std::uint32_t row = 0;
        for (int x = 0; x < b.width; ++x) row += p[x];
        sum += row;
      }
      s = static_cast<double>(sum);
    } else {
      const cv::Mat& ii = map.sums();
      s = ii.at<double>(b.y + b.height, b.x + b.width) - ii.at<double>(b.y, b.x + b.width) -
          ii.at<double>(b.y + b.height, b.x) + ii.at<double>(b.y, b.x);
    }
    d.score = s / (255.0 * b.area());
  }
  // Descending score; equal scores in raster order of the box corner (deterministic).
  std::sort(out.begin(), out.end(), [](const Detection& a, const Detection& b) {
    if (a.score != b.score) return a.score > b.score;
    if (a.box.y != b.box.y) return a.box.y < b.box.y;
    return a.box.x < b.box.x;
  });
  if (params_.max_detections > 0 && static_cast<int>(out.size()) > params_.max_detections) {
    out.resize(static_cast<size_t>(params_.max_detections));
  }
  return thr;
}

}  // namespace regolith::saliency
