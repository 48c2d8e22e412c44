#pragma once
// The sinkage estimator set up exactly for a synthetic wheel: geometry and pixel scale taken from
// the scene's model, so that an evaluation on rendered scenes (the sinkage tests, `regolith eval
// sinkage` without a geometry file, bench_sinkage) measures the estimator, not a calibration.
#include "regolith/sinkage/sinkage.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"

namespace regolith::wheel_scene {

/// The estimator's wheel geometry of `w` (hub, legs, feet, encoder offset and direction).
inline sinkage::WheelGeometry sinkage_geometry(const WheelModel& w) {
  sinkage::WheelGeometry g;
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

/// `p` with the scene's pixel scale (mm per px at the wheel plane).
inline sinkage::SinkageParams sinkage_params(const WheelModel& w, sinkage::SinkageParams p = {}) {
  p.mm_per_px = w.mm_per_px;
  return p;
}

}  // namespace regolith::wheel_scene
