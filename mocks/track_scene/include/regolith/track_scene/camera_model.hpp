#pragma once
// The rear camera of a rendered track scene in the estimators' camera model (header-only; links
// regolith::direct_depth, whose model the soil estimator uses). The renderer keeps its own
// pinhole so that it stays independent of what it checks.
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/track_scene/track_scene.hpp"

namespace regolith::track_scene {

inline direct_depth::CameraModel camera_model_of(const CameraModel& c) {
  direct_depth::CameraModel m;
  m.width = c.width;
  m.height = c.height;
  m.fx = c.fx;
  m.fy = c.fy;
  m.cx = c.cx;
  m.cy = c.cy;
  m.mount_height_m = c.mount_height_m;
  m.pitch_rad = c.pitch_rad;
  return m;
}

}  // namespace regolith::track_scene
