#include "regolith/saliency/contrast.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "regolith/core/error.hpp"
#include "regolith/saliency/image_ops.hpp"

namespace regolith::saliency {

namespace {
// Below this (in units of the [0,1] intensity; one 16-bit grey level is 1.5e-5) the map is
// float rounding of the blur of a flat image, not contrast: it is zeroed, not stretched.
constexpr double kNoContrast = 1e-6;
}  // namespace

void ContrastParams::validate() const {
  if (!std::isfinite(sigma_px) || sigma_px <= 0.0 || sigma_px > 200.0) {
    throw FieldError("ContrastParams", "sigma_px", "must be in (0, 200] px (got " + number_text(sigma_px) + ")");
  }
  if (!std::isfinite(smooth_sigma_px) || smooth_sigma_px < 0.0 || smooth_sigma_px > 50.0) {
    throw FieldError("ContrastParams", "smooth_sigma_px",
                     "must be in [0, 50] px (got " + number_text(smooth_sigma_px) + ")");
  }
}

PostProcessParams contrast_post_processing() {
  PostProcessParams p;
  p.threshold_scale = 0.8;
  p.min_area = 1600;
  return p;
}

void DecimatedGaussian::apply(const cv::Mat& src, cv::Mat& dst, double sigma) {
  if (src.empty() || src.type() != CV_32FC1)
    throw std::invalid_argument("DecimatedGaussian: src must be a non-empty CV_32FC1 image");
  if (!std::isfinite(sigma) || sigma <= 0.0) throw std::invalid_argument("DecimatedGaussian: sigma must be > 0");
  if (src.size() != size_ || sigma != sigma_) {
    int f = 1;
    while (sigma / (2 * f) >= 4.0 && src.cols >= 2 * f * 4 && src.rows >= 2 * f * 4) f *= 2;
    factor_ = f;
    if (f > 1) {
      const cv::Size reduced((src.cols + f - 1) / f, (src.rows + f - 1) / f);
      down_.build(src.size(), reduced, ResizeTable::Mode::kArea);
      up_.build(reduced, src.size(), ResizeTable::Mode::kLinear);
    }
    size_ = src.size();
    sigma_ = sigma;
  }
  if (factor_ == 1) {
    blur_.apply(src, dst, sigma);
    return;
  }
  const double fd = static_cast<double>(factor_);
  down_.apply(src, small_);
  blur_.apply(small_, small_blur_, std::sqrt(sigma * sigma - fd * fd / 4.0) / fd);
  up_.apply(small_blur_, dst);
}

ContrastSaliency::ContrastSaliency(ContrastParams params) : params_(params) {
  params_.validate();
}

void ContrastSaliency::compute(const cv::Mat& image, cv::Mat& saliency) {
  if (image.empty()) throw std::invalid_argument("image: empty");
  const int ch = image.channels();
  if (ch != 1 && ch != 3 && ch != 4) {
    throw std::invalid_argument("image: must have 1, 3 or 4 channels (got " + std::to_string(ch) + ")");
  }
  to_unit_float(image, unit_);
  intensity_of(unit_, intensity_);
  compute_from_intensity(intensity_, saliency);
}

void ContrastSaliency::compute_from_intensity(const cv::Mat& intensity, cv::Mat& saliency) {
  if (intensity.empty() || intensity.type() != CV_32FC1)
    throw std::invalid_argument("intensity: must be a non-empty CV_32FC1 image");
  surround_blur_.apply(intensity, surround_, params_.sigma_px);
  if (params_.smooth_sigma_px > 0.0) {
    cv::absdiff(intensity, surround_, diff_);
    smooth_blur_.apply(diff_, saliency, params_.smooth_sigma_px);
  } else {
    cv::absdiff(intensity, surround_, saliency);
  }
  double mx = 0.0;
  cv::minMaxLoc(saliency, nullptr, &mx);
  if (mx > kNoContrast)
    saliency.convertTo(saliency, CV_32F, 1.0 / mx);
  else
    for (int r = 0; r < saliency.rows; ++r)  // Mat::setTo(scalar) allocates
      std::fill(saliency.ptr<float>(r), saliency.ptr<float>(r) + saliency.cols, 0.0f);
}

}  // namespace regolith::saliency
