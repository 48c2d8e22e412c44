#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "regolith/core/error.hpp"
#include "regolith/sinkage/sinkage.hpp"

namespace regolith::sinkage {
namespace {

[[noreturn]] void fail(const char* owner, const char* field, const std::string& what, double got) {
  std::ostringstream os;
  os << what << " (got " << got << ')';
  throw FieldError(owner, field, os.str());
}

void require_finite(const char* owner, const char* field, double v) {
  if (!std::isfinite(v)) fail(owner, field, "must be finite", v);
}

void require_range(const char* owner, const char* field, double v, double lo, double hi) {
  require_finite(owner, field, v);
  if (v < lo || v > hi) {
    std::ostringstream os;
    os << "must be in [" << lo << ", " << hi << ']';
    fail(owner, field, os.str(), v);
  }
}

double wrap_pi(double a) {
  const double two_pi = 2.0 * std::numbers::pi;
  a = std::fmod(a + std::numbers::pi, two_pi);
  if (a <= 0.0) a += two_pi;
  return a - std::numbers::pi;
}

}  // namespace

void WheelGeometry::validate() const {
  constexpr const char* o = "WheelGeometry";
  require_finite(o, "hub_center_px.x", hub_center_px.x);
  require_finite(o, "hub_center_px.y", hub_center_px.y);
  if (leg_count < 1 || leg_count > static_cast<int>(kMaxLegs)) {
    fail(o, "leg_count", "must be in [1, " + std::to_string(kMaxLegs) + "]", leg_count);
  }
  require_finite(o, "leg_spacing_rad", leg_spacing_rad);
  if (leg_spacing_rad <= 0.0 || leg_spacing_rad * leg_count > 2.0 * std::numbers::pi + 1e-6) {
    fail(o, "leg_spacing_rad", "must be > 0 and leg_count * spacing <= 2 pi", leg_spacing_rad);
  }
  require_finite(o, "hub_radius_px", hub_radius_px);
  if (hub_radius_px < 0.0) fail(o, "hub_radius_px", "must be >= 0", hub_radius_px);
  require_finite(o, "leg_length_px", leg_length_px);
  if (leg_length_px <= hub_radius_px + 4.0) {
    fail(o, "leg_length_px", "must exceed hub_radius_px by at least 4 px", leg_length_px);
  }
  if (leg_length_px > kMaxLegLengthPx) {
    fail(o, "leg_length_px",
         "must be <= " + std::to_string(static_cast<int>(kMaxLegLengthPx)) + " px (twice the largest camera side)",
         leg_length_px);
  }
  require_finite(o, "leg_width_px", leg_width_px);
  if (leg_width_px < 2.0 || leg_width_px > leg_length_px) {
    fail(o, "leg_width_px", "must be in [2, leg_length_px]", leg_width_px);
  }
  require_finite(o, "foot_width_px", foot_width_px);
  if (foot_width_px < 0.0 || foot_width_px > leg_length_px) {
    fail(o, "foot_width_px", "must be in [0, leg_length_px] (0 = no foot)", foot_width_px);
  }
  require_finite(o, "foot_thickness_px", foot_thickness_px);
  if (foot_thickness_px < 0.0 || foot_thickness_px > leg_length_px - hub_radius_px) {
    fail(o, "foot_thickness_px", "must be in [0, leg_length_px - hub_radius_px]", foot_thickness_px);
  }
  require_finite(o, "angle_offset_rad", angle_offset_rad);
  if (rotation_direction != 1 && rotation_direction != -1) {
    fail(o, "rotation_direction", "must be +1 or -1", rotation_direction);
  }
}

double WheelGeometry::leg_angle(int k, double encoder_angle_rad) const {
  return wrap_pi(rotation_direction * encoder_angle_rad + angle_offset_rad + k * leg_spacing_rad);
}

double WheelGeometry::half_width_at(double along_px) const {
  const double hw = 0.5 * leg_width_px;
  if (foot_width_px > 0.0 && foot_thickness_px > 0.0 && along_px >= leg_length_px - foot_thickness_px) {
    return std::max(hw, 0.5 * foot_width_px);
  }
  return hw;
}

void SinkageParams::validate() const {
  constexpr const char* o = "SinkageParams";
  require_range(o, "hue_min_deg", hue_min_deg, 0.0, 360.0);
  require_range(o, "hue_max_deg", hue_max_deg, 0.0, 360.0);
  require_range(o, "sat_min", sat_min, 0.0, 1.0);
  require_range(o, "val_min", val_min, 0.0, 1.0);
  if (mode != SegmentationMode::kHsv && mode != SegmentationMode::kAdaptive && mode != SegmentationMode::kAuto) {
    fail(o, "mode", "unknown segmentation mode", static_cast<double>(mode));
  }
  require_range(o, "dark_mean_value", dark_mean_value, 0.0, 1.0);
  require_range(o, "adaptive_min_separation", adaptive_min_separation, 0.0, 255.0);
  if (open_kernel_px < 1 || open_kernel_px > 15 || open_kernel_px % 2 == 0) {
    fail(o, "open_kernel_px", "must be odd in [1, 15]", open_kernel_px);
  }
  if (close_kernel_px < 1 || close_kernel_px > 15 || close_kernel_px % 2 == 0) {
    fail(o, "close_kernel_px", "must be odd in [1, 15]", close_kernel_px);
  }
  require_range(o, "contact_half_angle_rad", contact_half_angle_rad, 0.0, std::numbers::pi / 2);
  require_range(o, "angle_tolerance_rad", angle_tolerance_rad, 0.0, 0.5);
  require_range(o, "mask_margin_px", mask_margin_px, 0.0, 100.0);
  require_finite(o, "mm_per_px", mm_per_px);
  if (mm_per_px <= 0.0) fail(o, "mm_per_px", "must be > 0", mm_per_px);
  require_finite(o, "leg_length_mm", leg_length_mm);
  if (leg_length_mm < 0.0) fail(o, "leg_length_mm", "must be >= 0 (0 = use mm_per_px)", leg_length_mm);
  require_range(o, "min_confidence", min_confidence, 0.0, 1.0);
  require_range(o, "min_visible_px", min_visible_px, 0.0, 1e4);
  require_range(o, "contact_min_mm", contact_min_mm, 0.0, 1e4);
  if (filter != TemporalFilter::kNone && filter != TemporalFilter::kEma && filter != TemporalFilter::kMedian) {
    fail(o, "filter", "unknown temporal filter", static_cast<double>(filter));
  }
  require_finite(o, "ema_alpha", ema_alpha);
  if (ema_alpha <= 0.0 || ema_alpha > 1.0) fail(o, "ema_alpha", "must be in (0, 1]", ema_alpha);
  if (median_window < 1 || median_window > 31) {
    fail(o, "median_window", "must be in [1, 31]", median_window);
  }
}

double SinkageParams::scale_mm_per_px(const WheelGeometry& g) const {
  return leg_length_mm > 0.0 ? leg_length_mm / g.leg_length_px : mm_per_px;
}

const char* to_string(InvalidReason r) {
  switch (r) {
    case InvalidReason::kNone: return "none";
    case InvalidReason::kBadAngle: return "bad_encoder_angle";
    case InvalidReason::kNoContactLeg: return "no_contact_leg";
    case InvalidReason::kOutsideImage: return "leg_outside_image";
    case InvalidReason::kNoLegPixels: return "no_leg_pixels";
    case InvalidReason::kLowConfidence: return "low_confidence";
    case InvalidReason::kCount: break;
  }
  return "unknown";
}

std::string geometry_to_yaml(const WheelGeometry& g, int indent) {
  const std::string pad(static_cast<std::size_t>(std::max(indent, 0)), ' ');
  std::ostringstream os;
  os << std::setprecision(10);
  os << pad << "geometry:\n";
  os << pad << "  hub_center_px: [" << g.hub_center_px.x << ", " << g.hub_center_px.y << "]\n";
  os << pad << "  leg_count: " << g.leg_count << '\n';
  os << pad << "  leg_spacing_rad: " << g.leg_spacing_rad << '\n';
  os << pad << "  leg_length_px: " << g.leg_length_px << '\n';
  os << pad << "  leg_width_px: " << g.leg_width_px << '\n';
  os << pad << "  hub_radius_px: " << g.hub_radius_px << '\n';
  os << pad << "  foot_width_px: " << g.foot_width_px << '\n';
  os << pad << "  foot_thickness_px: " << g.foot_thickness_px << '\n';
  os << pad << "  angle_offset_rad: " << g.angle_offset_rad << '\n';
  os << pad << "  rotation_direction: " << g.rotation_direction << '\n';
  return os.str();
}

}  // namespace regolith::sinkage
