#pragma once
// Header-only adapter: the SAMS height map from regolith::sfs (shape from
// shading of the same frame). Include it only in targets that link
// regolith::sfs (guard with REGOLITH_HAVE_SFS, which their CMake file defines
// when that library is built); the regolith::saliency library itself
// does not depend on the SfS component.
#include <cmath>
#include <optional>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "regolith/saliency/dataset.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::saliency {

struct SfsHeightParams {
  int downsample_levels = 2;  ///< SfS runs on the image reduced by 2^levels (speed), then the
                              ///< height is resized back; the structure channel only uses
                              ///< pyramid levels >= 2 anyway
  /// Light direction used for the SfS. The moment-based slant estimate of
  /// regolith::sfs returns slant 0 (confidence 0, hence a flat height map) on
  /// natural Mastcam frames, so by default the slant is fixed and only the tilt
  /// is estimated (Lee-Rosenfeld mean gradient direction).
  std::optional<double> slant_rad = 0.7853981633974483;  ///< rad, fixed slant; nullopt = estimate
  std::optional<double> tilt_rad;                        ///< rad, fixed tilt; nullopt = estimate
  sfs::SfsParams solver = [] {
    sfs::SfsParams p;
    p.estimate_light = true;       // used only when both slant and tilt are estimated
    p.min_light_confidence = 0.0;  // never refuse a frame
    // The structure channel's Pentland as SAMS's thresholds and the trained ranking's
    // features (the shipped model) were chosen with; the library default differs since.
    p.pentland_min_denominator = 0.05;
    p.pentland_fill_masked = true;
    return p;
  }();
  void validate() const {
    if (downsample_levels < 0 || downsample_levels > 4) {
      throw std::invalid_argument("SfsHeightParams.downsample_levels: must be in [0,4]");
    }
    if (slant_rad && !(*slant_rad >= 0.0 && *slant_rad < 1.5707963267948966)) {
      throw std::invalid_argument("SfsHeightParams.slant_rad: must be in [0, pi/2)");
    }
    if (tilt_rad && !std::isfinite(*tilt_rad)) {
      throw std::invalid_argument("SfsHeightParams.tilt_rad: must be finite");
    }
    solver.validate();
  }
};

/// Reusable height-map source for IttiSaliency / RockStudy.
class SfsHeight {
 public:
  explicit SfsHeight(SfsHeightParams p = {}) : p_(std::move(p)), solver_(p_.solver) { p_.validate(); }

  /// `image` any 1/3/4-channel 8U/16U/32F frame; `height` CV_32F of the image's
  /// size.
  void operator()(const cv::Mat& image, cv::Mat& height) {
    if (image.channels() == 3)
      cv::cvtColor(image, grey_, cv::COLOR_BGR2GRAY);
    else if (image.channels() == 4)
      cv::cvtColor(image, grey_, cv::COLOR_BGRA2GRAY);
    else
      grey_ = image;
    double scale = 1.0;
    if (grey_.depth() == CV_8U)
      scale = 1.0 / 255.0;
    else if (grey_.depth() == CV_16U)
      scale = 1.0 / 65535.0;
    grey_.convertTo(f_, CV_32F, scale);
    for (int l = 0; l < p_.downsample_levels; ++l) cv::pyrDown(f_, f_);
    std::optional<sfs::LightDirection> light;
    if (p_.slant_rad || p_.tilt_rad) {
      sfs::LightDirection l;
      if (!p_.slant_rad || !p_.tilt_rad) {
        const sfs::LightEstimate est = sfs::estimate_light(f_, p_.solver.zheng_chellappa_refine);
        l = est.light;
      }
      if (p_.slant_rad) l.slant_rad = *p_.slant_rad;
      if (p_.tilt_rad) l.tilt_rad = *p_.tilt_rad;
      light = l;
    }
    solver_.compute(f_, light, result_);
    cv::resize(result_.height, height, image.size(), 0, 0, cv::INTER_LINEAR);
  }

  /// As a HeightFn (the object must outlive the function).
  HeightFn function() {
    return [this](const cv::Mat& image, cv::Mat& height) { (*this)(image, height); };
  }

  const sfs::SfsResult& last() const { return result_; }

 private:
  SfsHeightParams p_;
  sfs::ShapeFromShading solver_;
  sfs::SfsResult result_;
  cv::Mat grey_, f_;
};

}  // namespace regolith::saliency
