#include "regolith/saliency/contrast.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

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
    throw FieldError("ContrastParams", "sigma_px", "must be in (0, 200] px (got " + std::to_string(sigma_px) + ")");
  }
  if (!std::isfinite(smooth_sigma_px) || smooth_sigma_px < 0.0 || smooth_sigma_px > 50.0) {
    throw FieldError("ContrastParams", "smooth_sigma_px",
                     "must be in [0, 50] px (got " + std::to_string(smooth_sigma_px) + ")");
  }
}

PostProcessParams contrast_post_processing() {
  PostProcessParams p;
  p.threshold_scale = 0.8;
  p.min_area = 1600;
  return p;
}

void gaussian_blur_decimated(const cv::Mat& src, cv::Mat& dst, double sigma, cv::Mat& small, cv::Mat& small_blur) {
  if (src.empty() || src.type() != CV_32FC1)
    throw std::invalid_argument("gaussian_blur_decimated: src must be a non-empty CV_32FC1 image");
  if (!std::isfinite(sigma) || sigma <= 0.0) throw std::invalid_argument("gaussian_blur_decimated: sigma must be > 0");
  int f = 1;
  while (sigma / (2 * f) >= 4.0 && src.cols >= 2 * f * 4 && src.rows >= 2 * f * 4) f *= 2;
  if (f == 1) {
    cv::GaussianBlur(src, dst, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT_101);
    return;
  }
  const cv::Size reduced((src.cols + f - 1) / f, (src.rows + f - 1) / f);
  cv::resize(src, small, reduced, 0, 0, cv::INTER_AREA);
  const double fd = static_cast<double>(f);
  const double s_small = std::sqrt(sigma * sigma - fd * fd / 4.0) / fd;
  cv::GaussianBlur(small, small_blur, cv::Size(0, 0), s_small, s_small, cv::BORDER_REFLECT_101);
  cv::resize(small_blur, dst, src.size(), 0, 0, cv::INTER_LINEAR);
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
  gaussian_blur_decimated(intensity, surround_, params_.sigma_px, small_, small_blur_);
  if (params_.smooth_sigma_px > 0.0) {
    cv::absdiff(intensity, surround_, diff_);
    gaussian_blur_decimated(diff_, saliency, params_.smooth_sigma_px, small_, small_blur_);
  } else {
    cv::absdiff(intensity, surround_, saliency);
  }
  double mx = 0.0;
  cv::minMaxLoc(saliency, nullptr, &mx);
  if (mx > kNoContrast)
    saliency.convertTo(saliency, CV_32F, 1.0 / mx);
  else
    saliency.setTo(0.0);
}

}  // namespace regolith::saliency
