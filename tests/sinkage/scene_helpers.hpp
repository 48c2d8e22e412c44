#pragma once
// Shared helpers for the sinkage tests: the estimator's geometry from the synthetic scene's model.
#include "regolith/sinkage/sinkage.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"

namespace regolith::sinkage::testing {

inline WheelGeometry geometry_of(const wheel_scene::WheelModel& w) {
  WheelGeometry g;
  g.hub_center_px = w.hub_center_px;
  g.leg_count = w.leg_count;
  g.leg_spacing_rad = w.leg_spacing_rad;
  g.leg_length_px = w.leg_length_px;
  g.leg_width_px = w.leg_width_px;
  g.hub_radius_px = w.hub_radius_px;
  g.foot_width_px = w.foot_width_px;
  g.foot_thickness_px = w.foot_thickness_px;
  g.angle_offset_rad = w.angle_offset_rad;
  g.rotation_direction = w.rotation_direction;
  return g;
}

inline SinkageParams params_for(const wheel_scene::WheelModel& w) {
  SinkageParams p;
  p.mm_per_px = w.mm_per_px;
  return p;
}

inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

}  // namespace regolith::sinkage::testing
