#pragma once
// The rendered camera in the estimators' camera model, and back (header-only; links
// regolith::direct_depth): a test or bench that renders with terrain_scene and measures with
// direct_depth (or anything built on it) states the same pinhole, height, pitch and roll once.
// The renderer keeps its own camera type so that it stays independent of what it checks.
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

namespace regolith::terrain_scene {

/// The estimators' model of rendered camera `pose` (no lens distortion: the renderer has none).
inline direct_depth::CameraModel camera_model_of(const CameraPose& pose) {
  direct_depth::CameraModel m;
  m.fx = pose.fx;
  m.fy = pose.fy;
  m.cx = pose.cx;
  m.cy = pose.cy;
  m.width = pose.width;
  m.height = pose.height;
  m.mount_height_m = pose.height_m;
  m.pitch_rad = pose.pitch_rad;
  m.roll_rad = pose.roll_rad;
  return m;
}

/// The camera to render so that `model` sees it (at the world origin, heading +x; distortion is
/// not rendered).
inline CameraPose camera_pose_of(const direct_depth::CameraModel& model) {
  CameraPose p;
  p.fx = model.fx;
  p.fy = model.fy;
  p.cx = model.cx;
  p.cy = model.cy;
  p.width = model.width;
  p.height = model.height;
  p.height_m = model.mount_height_m;
  p.pitch_rad = model.pitch_rad;
  p.roll_rad = model.roll_rad;
  return p;
}

}  // namespace regolith::terrain_scene
