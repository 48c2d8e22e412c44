#include "regolith/saliency/ranging.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace regolith::saliency {

void RangingParams::validate() const {
  if (!std::isfinite(hazard_size_m) || hazard_size_m <= 0.0) {
    throw std::invalid_argument("RangingParams.hazard_size_m: must be finite and > 0 m (got " +
                                std::to_string(hazard_size_m) + ")");
  }
}

RangedRock range_rock(const Detection& d, const GroundRanger& ranger, const RangingParams& p) {
  p.validate();
  if (!ranger) throw std::invalid_argument("range_rock: empty GroundRanger");
  RangedRock r;
  r.detection = d;
  const cv::Rect& b = d.box;
  if (b.width <= 0 || b.height <= 0) return r;
  const double v = b.y + b.height;  // bottom edge of the last row (max exclusive)
  const auto c = ranger(b.x + 0.5 * b.width, v);
  const auto l = ranger(static_cast<double>(b.x), v);
  const auto rr = ranger(static_cast<double>(b.x + b.width), v);
  if (!c || !l || !rr) return r;
  r.ranged = true;
  r.range_m = c->forward_m;
  r.lateral_m = c->left_m;
  r.width_m = std::hypot(l->forward_m - rr->forward_m, l->left_m - rr->left_m);
  r.height_m = b.height * r.width_m / b.width;
  r.hazard = r.width_m > p.hazard_size_m || r.height_m > p.hazard_size_m;
  return r;
}

}  // namespace regolith::saliency
